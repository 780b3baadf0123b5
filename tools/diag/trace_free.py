#!/usr/bin/env python3
"""The voxels a dynamap-voxel-trace run ends with held free, and the depths of the rays that
lowered them (docs/notes/map-range-gap.md).

usage: trace_free.py TRACE LAST_FRAME

TRACE is dynamap-voxel-trace's output up to LAST_FRAME. For each voxel whose log-odds is below 0
(free) after LAST_FRAME: its final log-odds, how many frames lowered it and the depths of the
listed rays that crossed it then (the trace lists up to 12 per voxel and frame). Then a count of
the voxels lowered only by returns beyond 5 m (the map's default range). Python 3 standard
library only.
"""
import collections
import re
import sys

FRAME = re.compile(r'frame (\d+) camera .* voxel \(([-\d.]+), ([-\d.]+), ([-\d.]+)\) '
                   r'log-odds ([-\d.]+) -> ([-\d.]+)')
DEPTH = re.compile(r'depth ([\d.]+) m')


def main(path, last):
    lowered = collections.defaultdict(list)  # voxel -> [(frame, [depths])]
    final = {}
    current = None
    for line in open(path):
        m = FRAME.match(line)
        if m:
            frame = int(m.group(1))
            voxel = tuple(float(v) for v in m.group(2, 3, 4))
            before, after = float(m.group(5)), float(m.group(6))
            current = None
            if after < before:
                lowered[voxel].append((frame, []))
                current = voxel
            if frame == last:
                final[voxel] = after
            continue
        m = DEPTH.search(line)
        if m and current is not None:
            lowered[current][-1][1].append(float(m.group(1)))
    classes = collections.Counter()
    for voxel, after in sorted(final.items()):
        if after >= 0:
            continue
        depths = sorted(d for _, ds in lowered[voxel] for d in ds)
        shown = ', '.join('%.3f' % d for d in depths[:6]) + (' ...' if len(depths) > 6 else '')
        print('(%.2f, %.2f, %.2f) log-odds %.2f, lowered on %d frames, ray depths %s' %
              (voxel + (after, len(lowered[voxel]), shown or '-')))
        classes['only returns beyond 5 m' if depths and depths[0] > 5.0 else 'other'] += 1
    print(dict(classes))


if __name__ == '__main__':
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], int(sys.argv[2]))
