#!/usr/bin/env python3
"""Failure classes of a replay on a simulated sequence (docs/notes/crowd-scene.md).

Usage: scripts/crowd_failure_classes.py SEQ RESULT_DIR

Counts the ground truth as dynamap-eval does (docs/tools.md: speed >= 0.2 m/s, visible >= 0.5,
centre 0.5-5 m ahead of the camera) and matches dynamic tracks to it with a 1 m gate, keeping
last frame's pairs and otherwise nearest first (dynamap-eval uses the Hungarian method, so a
few pairs may differ; the totals are dynamap-eval's on the crowd runs). Each counted person-frame
gets one class, the first that applies:
  start            frame < 40 (people in view from the first frame, before any label)
  restart          the person stood (speed < 0.2 m/s) within the last 3 s
  near camera      centre < 1.6 m ahead
  beside another   another person's centre within 0.8 m (group members)
  partly hidden    visible < 0.9
  alone            the rest
and prints per class: counted, missed, mean position and velocity error and their shares; the
same errors by the matched track's age (frames since its first row); the track ids matched per
person; and for group members matched to a track nearer another person.
Standard library only."""
import collections
import math
import sys


def rows(path, sep=None):
    with open(path) as f:
        for line in f:
            if line.startswith('#') or line.startswith('stamp') or not line.strip():
                continue
            yield line.strip().split(sep)


def rotate(q, v):
    """v rotated by the unit quaternion q = (x, y, z, w)."""
    x, y, z, w = q
    tx, ty, tz = 2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])
    return (v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz),
            v[2] + w * tz + (x * ty - y * tx))


AGE_BINS = ((0, 5), (5, 10), (10, 20), (20, 40), (40, 10**9))


def top_dist(a, b):
    return math.hypot(a['p'][0] - b['p'][0], a['p'][1] - b['p'][1])


def main(seq, out):
    pose = {r[0]: (tuple(map(float, r[1:4])), tuple(map(float, r[4:8])))
            for r in rows(seq + '/groundtruth.txt')}
    gt, tracks = collections.defaultdict(list), collections.defaultdict(list)
    for r in rows(seq + '/obstacles.txt'):
        gt[r[0]].append(dict(id=int(r[1]), p=tuple(map(float, r[2:5])),
                             v=tuple(map(float, r[5:8])), vis=float(r[11])))
    for r in rows(out + '/tracks.csv', ','):
        tracks[r[0]].append(dict(id=int(r[1]), p=tuple(map(float, r[2:5])),
                                 v=tuple(map(float, r[5:8])), dyn=int(r[11])))
    first_frame = {}  # track id -> frame index of its first row
    for fi, stamp in enumerate(sorted(pose)):
        for k in tracks[stamp]:
            first_frame.setdefault(k['id'], fi)
    by_age = collections.defaultdict(list)  # age bin -> [(position error, velocity error)]
    prev, speeds = {}, collections.defaultdict(list)
    total, missed = collections.Counter(), collections.Counter()
    perr, verr = collections.defaultdict(list), collections.defaultdict(list)
    ids = collections.defaultdict(set)
    shared = []  # group member matched to a track nearer another person
    for fi, stamp in enumerate(sorted(pose)):
        t, q = pose[stamp]
        fwd = rotate(q, (0.0, 0.0, 1.0))
        for o in gt[stamp]:
            speeds[o['id']].append(math.hypot(o['v'][0], o['v'][1]))
        counted = []
        for o in gt[stamp]:
            ahead = sum((o['p'][i] - t[i]) * fwd[i] for i in range(3))
            if speeds[o['id']][-1] >= 0.2 and o['vis'] >= 0.5 and 0.5 <= ahead <= 5.0:
                o['ahead'] = ahead
                counted.append(o)
        dyn = [k for k in tracks[stamp] if k['dyn']]
        match, used = {}, set()
        for o in counted:  # pairs of the previous frame stay while within the gate
            for k in dyn:
                if prev.get(o['id']) == k['id'] and top_dist(o, k) < 1.0:
                    match[o['id']] = k
                    used.add(k['id'])
        pairs = sorted((top_dist(o, k), o['id'], k['id']) for o in counted if o['id'] not in match
                       for k in dyn if k['id'] not in used and top_dist(o, k) < 1.0)
        for _, oi, ki in pairs:
            if oi not in match and ki not in used:
                match[oi] = next(k for k in dyn if k['id'] == ki)
                used.add(ki)
        prev = {oi: k['id'] for oi, k in match.items()}
        for o in counted:
            beside = any(g['id'] != o['id'] and top_dist(g, o) < 0.8 for g in gt[stamp])
            if fi < 40:
                cls = 'start (frame < 40)'
            elif min(speeds[o['id']][-90:]) < 0.2:
                cls = 'restart after a stop (< 3 s)'
            elif o['ahead'] < 1.6:
                cls = 'near camera (< 1.6 m)'
            elif beside:
                cls = 'beside another (< 0.8 m)'
            elif o['vis'] < 0.9:
                cls = 'partly hidden (visible < 0.9)'
            else:
                cls = 'alone, in full view'
            total[cls] += 1
            if o['id'] not in match:
                missed[cls] += 1
                continue
            k = match[o['id']]
            ids[o['id']].add(k['id'])
            perr[cls].append(top_dist(o, k))
            verr[cls].append(math.hypot(o['v'][0] - k['v'][0], o['v'][1] - k['v'][1]))
            age = fi - first_frame[k['id']]
            by_age[next(b for b in AGE_BINS if age < b[1])].append((perr[cls][-1], verr[cls][-1]))
            if beside:
                nearest = min(gt[stamp], key=lambda g: top_dist(g, k))
                if nearest['id'] != o['id']:
                    shared.append((fi, o['id'], nearest['id'], k['id'], top_dist(o, k)))
    psum = sum(sum(v) for v in perr.values())
    vsum = sum(sum(v) for v in verr.values())
    print(f'{"class":32s} counted missed  pos(m) vel(m/s)  share of pos, vel error sums')
    for c in sorted(total):
        n = len(perr[c])
        pe = sum(perr[c]) / n if n else float('nan')
        ve = sum(verr[c]) / n if n else float('nan')
        print(f'{c:32s} {total[c]:7d} {missed[c]:6d}  {pe:6.3f} {ve:8.3f}  '
              f'{sum(perr[c]) / psum:.2f}, {sum(verr[c]) / vsum:.2f}')
    print(f'{"all":32s} {sum(total.values()):7d} {sum(missed.values()):6d}  '
          f'{psum / sum(map(len, perr.values())):6.3f} {vsum / sum(map(len, verr.values())):8.3f}')
    print(f'{"track age (frames)":32s} matched  pos(m) vel(m/s)  share of vel error sum')
    for b in AGE_BINS:
        e = by_age[b]
        if e:
            print(f'{"%d-%s" % (b[0], b[1] - 1 if b[1] < 10**9 else "")!s:32s} {len(e):7d}  '
                  f'{sum(p for p, _ in e) / len(e):6.3f} {sum(v for _, v in e) / len(e):8.3f}  '
                  f'{sum(v for _, v in e) / vsum:.2f}')
    n = [len(v) for v in ids.values()]
    print('track ids matched per person:', dict(sorted((i, len(v)) for i, v in ids.items())),
          f'mean {sum(n) / len(n):.2f} over {len(n)} people')
    if shared:
        err = [s[4] for s in shared]
        print(f'matched to the track of the person beside them: {len(shared)} person-frames, '
              f'mean position error {sum(err) / len(err):.3f} m, sum {sum(err):.1f} m of {psum:.1f} m')
        print('  (frame, person, nearer person, track):', [s[:4] for s in shared[::5]])


if __name__ == '__main__':
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
