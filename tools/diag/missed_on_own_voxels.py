#!/usr/bin/env python3
"""Missed walker frames on long-occupied voxels: did the walker stand there before?

usage: missed_on_own_voxels.py DIR   (DIR holds one `dynamap-track-diag SEQ > DIR/dK.csv` per run)

Takes the frames missed_by_cause.py files under "on long-occupied voxels" (frames >= 40, the
walker scored as dynamap-eval scores it, the nearest track measured, voting, with a static share
above 0.5) and splits them by whether the walker stood still (true speed < 0.2 m/s) in the 90
frames before, and whether its track had been labelled dynamic before. A walker that stood
longer than refiner.static_frames has made its own voxels long occupied, so its detection reads
as static structure when it walks off. Python 3 standard library only.
"""
import collections
import csv
import glob
import math
import sys


def main(directory):
    split = collections.Counter()
    for path in sorted(glob.glob(directory + '/*.csv')):
        with open(path) as f:
            rows = list(csv.DictReader(f))
        true_speed = collections.defaultdict(dict)  # walker -> frame -> speed
        dynamic_frames = collections.defaultdict(set)  # track -> frames labelled dynamic
        by_frame = collections.defaultdict(list)
        for r in rows:
            walker, frame = int(r['gt_id']), int(r['frame'])
            if walker >= 0:
                true_speed[walker][frame] = math.hypot(float(r['gt_vx']), float(r['gt_vy']))
                if float(r['gt_dist']) <= 1.0:
                    by_frame[(frame, walker)].append(r)
            if r['dynamic'] == '1':
                dynamic_frames[r['id']].add(frame)
        for (frame, walker), rs in by_frame.items():
            r0 = rs[0]
            if frame < 40 or true_speed[walker][frame] < 0.2 or float(r0['gt_visible']) < 0.5:
                continue
            if not 0.5 <= float(r0['gt_depth']) <= 5.0:
                continue
            if any(r['dynamic'] == '1' for r in rs):
                continue
            r = min(rs, key=lambda r: float(r['gt_dist']))
            if r['det'] == '-1' or int(r['votes']) == 0 or float(r['static_share']) <= 0.5:
                continue
            stood = any(true_speed[walker].get(k, 1.0) < 0.2 for k in range(frame - 90, frame))
            was_dynamic = any(k < frame for k in dynamic_frames[r['id']])
            split[('stood in the 90 frames before' if stood else 'kept walking',
                   'track dynamic before' if was_dynamic else 'track never dynamic')] += 1
    print('missed frames on long-occupied voxels: %d' % sum(split.values()))
    for (stood, track), n in split.most_common():
        print('  %5d  %s, %s' % (n, stood, track))


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
