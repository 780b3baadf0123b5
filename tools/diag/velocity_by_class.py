#!/usr/bin/env python3
"""Velocity error of dynamic tracks by what their rows show, from dynamap-track-diag CSVs
(docs/evaluation.md, "What goes wrong in them").

usage: velocity_by_class.py FILE.csv...   (one `dynamap-track-diag SEQ > dK.csv` per run)

Rows of dynamic tracks within 0.5 m of a listed walker (gt_dist), each in the first class that
fits: younger than 15 frames; coasting (no detection); detection box at an image border
(within 5 px of a side, or of the top or bottom: people near the camera); touching a nearer
detection (partly hidden by it); the walker turning faster than 0.5 rad/s; none of these.
Prints, per file and over all files, each class's rows, mean velocity error (m/s) and share of
the summed error, then the mean error of tracks at least 20 frames old. Images are 640x480.
Python 3 standard library only.
"""
import collections
import csv
import math
import os
import sys

CLASSES = ('younger than 15 frames', 'coasting', 'at an image border', 'beside a nearer detection',
           'turning', 'none of these')
WIDTH, HEIGHT, MARGIN = 640, 480, 5


def row_class(r):
    if int(r['age']) < 15:
        return CLASSES[0]
    if r['det'] == '-1':
        return CLASSES[1]
    u0, u1, v0, v1 = (int(float(r[k])) for k in ('det_u0', 'det_u1', 'det_v0', 'det_v1'))
    if u0 <= MARGIN or u1 >= WIDTH - 1 - MARGIN or v0 <= MARGIN or v1 >= HEIGHT - 1 - MARGIN:
        return CLASSES[2]
    if r['det_touch_nearer'] == '1':
        return CLASSES[3]
    if abs(float(r['gt_turn_rate'])) > 0.5:
        return CLASSES[4]
    return CLASSES[5]


def tally(path, rows, errors, settled):
    with open(path) as f:
        for r in csv.DictReader(f):
            if r['dynamic'] != '1' or int(r['gt_id']) < 0 or float(r['gt_dist']) > 0.5:
                continue
            e = math.hypot(float(r['vx']) - float(r['gt_vx']), float(r['vy']) - float(r['gt_vy']))
            c = row_class(r)
            rows[c] += 1
            errors[c] += e
            if int(r['age']) >= 20:
                settled[0] += 1
                settled[1] += e


def report(name, rows, errors, settled):
    n, total = sum(rows.values()), sum(errors.values())
    if n == 0:
        print('%s: no rows' % name)
        return
    print('%s: %d rows, mean %.3f m/s; tracks >= 20 frames old %.3f m/s (%d rows)' %
          (name, n, total / n, settled[1] / max(settled[0], 1), settled[0]))
    for c in CLASSES:
        if rows[c]:
            print('    %-28s %5d rows (%3.0f %%)  mean %.3f  share of error %3.0f %%' %
                  (c, rows[c], 100.0 * rows[c] / n, errors[c] / rows[c], 100.0 * errors[c] / total))


def main(paths):
    all_rows, all_errors, all_settled = collections.Counter(), collections.Counter(), [0, 0.0]
    for path in paths:
        rows, errors, settled = collections.Counter(), collections.Counter(), [0, 0.0]
        tally(path, rows, errors, settled)
        report(os.path.basename(path), rows, errors, settled)
        all_rows.update(rows)
        all_errors.update(errors)
        all_settled[0] += settled[0]
        all_settled[1] += settled[1]
    if len(paths) > 1:
        report('all', all_rows, all_errors, all_settled)


if __name__ == '__main__':
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
