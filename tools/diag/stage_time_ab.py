#!/usr/bin/env python3
"""Stage time of two builds of dynamap-replay on the same sequences, alternated.

    tools/diag/stage_time_ab.py BIN_A BIN_B SEQ [SEQ ...] [--stage occupancy] [--pairs 2]

Each pair replays every sequence A, B, B, A (so a drift in the host's load falls on both),
with --cpu-clock --no-map-checks --quiet, and reads each run's timing.csv. Prints per sequence
the median over its runs of the per-frame median of the stage and of the whole frame, the
ratio B / A, and the median of the per-sequence ratios. BIN_A and BIN_B are directories
holding dynamap-replay (an old commit built in a worktree works: its outputs only need
timing.csv). Runs one replay at a time; keep the host otherwise quiet.
"""
import argparse
import csv
import os
import statistics
import subprocess
import sys
import tempfile


def replay(binary, seq, out, extra):
    cmd = [os.path.join(binary, "dynamap-replay"), seq, "--out", out, "--quiet", "--cpu-clock",
           "--no-map-checks"] + extra
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    # 3: completed with depth files skipped (the Bonn sequences list a few that are missing).
    if r.returncode not in (0, 3):
        sys.exit(f"{' '.join(cmd)} failed ({r.returncode}): {r.stderr.strip()[-400:]}")


def medians(out, stage):
    with open(os.path.join(out, "timing.csv")) as f:
        rows = list(csv.DictReader(f))
    if not rows or stage not in rows[0]:
        sys.exit(f"{out}/timing.csv has no column '{stage}'")
    return (statistics.median(float(r[stage]) for r in rows),
            statistics.median(float(r["total"]) for r in rows))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bin_a")
    ap.add_argument("bin_b")
    ap.add_argument("seqs", nargs="+")
    ap.add_argument("--stage", default="occupancy")
    ap.add_argument("--pairs", type=int, default=2, help="ABBA rounds per sequence")
    ap.add_argument("--replay-arg", action="append", default=[],
                    help="extra argument for both replays (repeat), e.g. --replay-arg=--poses "
                    "--replay-arg=bonn")
    a = ap.parse_args()
    stage_ratios, total_ratios = [], []
    print(f"{'sequence':28s} {'A ms':>7s} {'B ms':>7s} {'B/A':>6s}   "
          f"{'A frame':>7s} {'B frame':>7s} {'B/A':>6s}")
    with tempfile.TemporaryDirectory() as tmp:
        for seq in a.seqs:
            runs = {"a": [], "b": []}
            for _ in range(a.pairs):
                for which in ("a", "b", "b", "a"):
                    out = os.path.join(tmp, which)
                    replay(a.bin_a if which == "a" else a.bin_b, seq, out, a.replay_arg)
                    runs[which].append(medians(out, a.stage))
            sa = statistics.median(s for s, _ in runs["a"]) / 1000.0
            sb = statistics.median(s for s, _ in runs["b"]) / 1000.0
            ta = statistics.median(t for _, t in runs["a"]) / 1000.0
            tb = statistics.median(t for _, t in runs["b"]) / 1000.0
            stage_ratios.append(sb / sa)
            total_ratios.append(tb / ta)
            name = os.path.basename(os.path.normpath(seq))
            print(f"{name:28s} {sa:7.3f} {sb:7.3f} {sb / sa:6.3f}   {ta:7.3f} {tb:7.3f} {tb / ta:6.3f}",
                  flush=True)
    print(f"median of the ratios B/A: {a.stage} {statistics.median(stage_ratios):.3f} "
          f"({min(stage_ratios):.3f}-{max(stage_ratios):.3f}), whole frame "
          f"{statistics.median(total_ratios):.3f} ({min(total_ratios):.3f}-{max(total_ratios):.3f})")


if __name__ == "__main__":
    main()
