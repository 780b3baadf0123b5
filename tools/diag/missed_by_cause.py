#!/usr/bin/env python3
"""Missed walker frames by what the nearest track lacked, from dynamap-track-diag CSVs
(docs/notes/tracker-reacquire.md).

usage: missed_by_cause.py DIR   (DIR holds one `dynamap-track-diag SEQ > DIR/dK.csv` per run)

A walker frame counts as dynamap-eval counts it (speed >= 0.2 m/s, visible >= 0.5, 0.5-5 m
ahead) when some track lies within 1 m of it; it is missed when none of those tracks is
dynamic. The nearest track's row gives the first cause that fits: coasting, no vote yet (a
new track, or an older one abstaining), on long-occupied voxels, slower than v_min, a dynamic
run after static votes (window young or full), voting static. Frames before 40 and after are
counted apart (the run's start). Walker frames with no track within 1 m are not counted.
Python 3 standard library only.
"""
import collections
import csv
import glob
import math
import sys


def cause(r):
    votes, age = int(r['votes']), int(r['age'])
    if r['det'] == '-1':
        return 'coasting (no detection)'
    if votes == 0:
        return 'no vote yet (age %s)' % ('<7' if age < 7 else '>=7')
    if float(r['static_share']) > 0.5:
        return 'on long-occupied voxels'
    if float(r['speed']) < 0.4:
        return 'slower than v_min'
    if int(r['streak']) > 0:
        return 'dynamic run after static votes, window %s' % ('young' if votes < 20 else 'full')
    return 'voting static now'


def main(directory):
    missed = {True: collections.Counter(), False: collections.Counter()}
    counted = collections.Counter()
    for path in sorted(glob.glob(directory + '/*.csv')):
        by_frame = collections.defaultdict(list)
        with open(path) as f:
            for r in csv.DictReader(f):
                if int(r['gt_id']) >= 0 and float(r['gt_dist']) <= 1.0:
                    by_frame[(int(r['frame']), int(r['gt_id']))].append(r)
        for (frame, _), rs in by_frame.items():
            r0 = rs[0]
            speed = math.hypot(float(r0['gt_vx']), float(r0['gt_vy']))
            if speed < 0.2 or float(r0['gt_visible']) < 0.5:
                continue
            if not 0.5 <= float(r0['gt_depth']) <= 5.0:
                continue
            start = frame < 40
            counted[start] += 1
            if any(r['dynamic'] == '1' for r in rs):
                continue
            missed[start][cause(min(rs, key=lambda r: float(r['gt_dist'])))] += 1
    for start, name in ((True, 'frames < 40'), (False, 'frames >= 40')):
        print('%s: counted %d, missed %d' % (name, counted[start], sum(missed[start].values())))
        for what, n in missed[start].most_common():
            print('  %5d  %s' % (n, what))


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
