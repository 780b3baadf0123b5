#!/usr/bin/env bash
# ctest node_check: an independent implementation (Node.js with @mcap/core,
# @foxglove/rosmsg, @foxglove/rosmsg2-serialization; installed by scripts/setup.sh) reads every
# kind of file the project writes (bags from dynamap-convert, uncompressed and zstd; the replay's
# Foxglove MCAP) and decodes every message against its schema, and the C++ reader's values for
# the two real rosbag2 bags (../shared/data/rosbag2) must equal the Node reader's.
# Exit 77 (ctest: skipped) only when node is absent.
#   run_node_check.sh SIM CONVERT REPLAY SHARED_DATA_DIR WORK_DIR
set -uo pipefail
sim=$1 convert=$2 replay=$3 shared=$4 work=$5
here="$(cd "$(dirname "$0")" && pwd)"
if ! command -v node >/dev/null 2>&1; then
  echo "node_check: SKIPPED: node is not installed (scripts/setup.sh installs it)"
  exit 77
fi
if [ ! -d "$here/node_modules/@mcap/core" ]; then
  echo "node_check: FAILED: $here/node_modules is missing: run scripts/setup.sh"
  exit 1
fi
set -e
rm -rf "$work" && mkdir -p "$work"
"$sim" env_a --out "$work/seq" --frames 40 --no-picture >/dev/null
"$convert" "$work/seq" --to-bag "$work/bag" >/dev/null
"$convert" "$work/seq" --to-bag "$work/bag_zstd.mcap" --compression zstd >/dev/null
"$replay" "$work/bag" --out "$work/out" --quiet --mcap "$work/replay.mcap" --mcap-map-every 5 \
  --reference "$work/seq/obstacles.txt" >/dev/null
node "$here/check.js" "$work/bag" "$work/bag_zstd.mcap" "$work/replay.mcap"
if [ -d "$shared/rosbag2" ]; then
  for b in talker cdr_test; do
    "$convert" "$shared/rosbag2/$b" --json >"$work/$b.jsonl"
    node "$here/check.js" "$shared/rosbag2/$b"
    node "$here/check.js" --compare "$shared/rosbag2/$b" "$work/$b.jsonl"
  done
else
  echo "node_check: $shared/rosbag2 is absent: the real bags are not compared (the rest passed)"
fi
echo "node_check: passed"
