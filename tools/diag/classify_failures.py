#!/usr/bin/env python3
"""Failing Markov predictions by cause, from dynamap-predict-diag CSVs
(docs/notes/predictor-failures-2-free-choice.md).

usage: classify_failures.py diag_corridor.csv diag_env_a.csv ...  -> a Markdown table

Each failing prediction goes to the first category that applies, in the table's order:
false dynamic track (> 1 m from every listed obstacle), no library path truly free, no path
free in the map, the chosen path free in the map but truly blocked (split by what the map holds
on the true shape near the hit: unknown / occupied / free; unknown split by the hit's distance
from the camera and by whether any voxel of that shape's surface was ever seen occupied), and
the belief choosing a path the map blocks although one was free. Predictions with path -1 (no
path free in the map and the far-field layer: the evaluator counts them as failures) are split
first: no library path truly free (walker behaviour), a false far-field wall, or the map.
Python 3 standard library only.
"""
import collections
import csv
import math
import os
import sys

ROWS = [
    ("predictions", "predictions"),
    ("on_false_dyn", "... of which on false dynamic tracks"),
    ("eval_fail", "Markov failing as the evaluator counts (collides, or path -1)"),
    ("nopath_behaviour", "path -1, no library path truly free (walker behaviour: U-turn, stop at a wall)"),
    ("nopath_far", "path -1, one truly free, the far-field layer blocked it (false far wall)"),
    ("nopath_map", "path -1, one truly free, the map blocked every path (own body, map noise)"),
    ("markov_fail", "with a path (not -1), the chosen path truly colliding: by cause below"),
    ("linear_fail", "linear failing"),
    ("false_dyn", "false dynamic track (every path collides)"),
    ("no_lib_true_free", "no library path truly free"),
    ("no_map_free", "no path free in the map, one truly free (own body, map noise)"),
    ("unknown", "chosen map-free, truly blocked by a shape the map holds as unknown"),
    ("unknown_far", "... hit >= 5 m from the camera (beyond the map range)"),
    ("unknown_unseen", "... hit < 5 m, no voxel of that surface ever seen occupied"),
    ("unknown_seen", "... hit < 5 m, surface partly seen"),
    ("unknown_linear_ok", "... of all unknown: the straight (linear) path was truly free"),
    ("occupied", "chosen map-free, truly blocked by a shape the map holds as occupied"),
    ("free", "chosen map-free, truly blocked by a shape the map holds as free"),
    ("belief_blocked", "a map-free path existed, the chosen one is map-blocked"),
]


def classify(path):
    c = collections.Counter()
    for r in csv.DictReader(open(path)):
        c["predictions"] += 1
        mf, lf = int(r["markov_fail"]), int(r["linear_fail"])
        c["linear_fail"] += lf
        false_dyn = float(r["gt_dist"]) > 1.0
        c["on_false_dyn"] += false_dyn
        no_path = int(r["any_map_free"]) == 0
        c["eval_fail"] += mf or no_path
        if no_path:
            if int(r["true_free_mask"]) == 0:
                c["nopath_behaviour"] += 1
            elif int(r.get("far_mask", "0") or 0) != 0:
                c["nopath_far"] += 1
            else:
                c["nopath_map"] += 1
            continue  # one class per failing prediction: the rows below have a path
        if not mf:
            continue
        c["markov_fail"] += 1
        chosen = int(r["chosen"])
        map_mask, true_mask = int(r["map_free_mask"]), int(r["true_free_mask"])
        if false_dyn:
            c["false_dyn"] += 1
        elif true_mask == 0:
            c["no_lib_true_free"] += 1
        elif map_mask == 0:
            c["no_map_free"] += 1
        elif (map_mask >> chosen) & 1:
            occ, fre, unk = int(r["wall_occ"]), int(r["wall_free"]), int(r["wall_unknown"])
            kind = max((unk, "unknown"), (occ, "occupied"), (fre, "free"))[1]
            c[kind] += 1
            if kind == "unknown":
                d = math.hypot(float(r["hit_x"]) - float(r["cam_x"]),
                               float(r["hit_y"]) - float(r["cam_y"]))
                c["unknown_far" if d >= 5.0 else
                  ("unknown_unseen" if occ == 0 else "unknown_seen")] += 1
                c["unknown_linear_ok"] += lf == 0
        else:
            c["belief_blocked"] += 1
    return c


def main(paths):
    results = [classify(p) for p in paths]
    names = [os.path.basename(p).replace("diag_", "").replace(".csv", "") for p in paths]
    print("| cause | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for key, label in ROWS:
        print("| " + label + " | " + " | ".join(str(r[key]) for r in results) + " |")
    for key, label in (("eval_fail", "Markov ratio (evaluator's rule)"),
                       ("linear_fail", "linear ratio (straight path collides)")):
        print("| " + label + " | " + " | ".join(
            "%.3f" % (r[key] / max(1, r["predictions"])) for r in results) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
