#!/usr/bin/env python3
"""Interior voxels of a simulated sequence's static world near the camera at one frame, as
arguments for dynamap-voxel-trace (docs/notes/map-range-gap.md).

usage: interior_voxels.py SEQ FRAME [RADIUS]

Reads SEQ/static_world.txt (boxes and cylinders) and SEQ/groundtruth.txt (the camera at frame
FRAME, counted from 0) and prints "X Y Z X Y Z ..." for every 0.1 m voxel whose centre lies
inside a shape by more than 0.1 mm and within RADIUS (default 3 m) of the camera: the voxels the
replay's `free_through_obstacle_voxels` counts when the map holds them free. Then:

  dynamap-voxel-trace SEQ FRAME $(interior_voxels.py SEQ FRAME) > trace.txt
  trace_free.py trace.txt FRAME

Python 3 standard library only.
"""
import math
import sys

RESOLUTION = 0.1
EPS = 1e-4


def camera_at(seq, frame):
    rows = [l.split() for l in open(seq + '/groundtruth.txt') if l.strip() and l[0] != '#']
    return tuple(float(v) for v in rows[frame][1:4])


def shapes(seq):
    for line in open(seq + '/static_world.txt'):
        t = line.split()
        if not t or t[0].startswith('#') or t[0] == 'floor':
            continue
        if t[0] == 'box':
            x0, y0, z0, x1, y1, z1 = map(float, t[1:7])
            yield ((x0, y0, z0), (x1, y1, z1),
                   lambda p, a=(x0, y0, z0), b=(x1, y1, z1):
                   all(a[k] + EPS < p[k] < b[k] - EPS for k in range(3)))
        elif t[0] == 'cylinder':
            cx, cy, r, z0, z1 = map(float, t[1:6])
            yield ((cx - r, cy - r, z0), (cx + r, cy + r, z1),
                   lambda p, cx=cx, cy=cy, r=r, z0=z0, z1=z1:
                   math.hypot(p[0] - cx, p[1] - cy) < r - EPS and z0 + EPS < p[2] < z1 - EPS)


def main(seq, frame, radius):
    cam = camera_at(seq, frame)
    out = []
    for lo, hi, inside in shapes(seq):
        ranges = [range(math.floor(lo[k] / RESOLUTION), math.ceil(hi[k] / RESOLUTION) + 1)
                  for k in range(3)]
        for i in ranges[0]:
            for j in ranges[1]:
                for k in ranges[2]:
                    p = ((i + 0.5) * RESOLUTION, (j + 0.5) * RESOLUTION, (k + 0.5) * RESOLUTION)
                    if inside(p) and math.dist(p, cam) <= radius:
                        out.append(p)
    print(' '.join('%.2f %.2f %.2f' % p for p in out))


if __name__ == '__main__':
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]) if len(sys.argv) == 4 else 3.0)
