#!/usr/bin/env bash
# Real-data evaluation (docs/evaluation.md, "Real data"): on a recorded sequence in the TUM layout
# (default: the Bonn RGB-D Dynamic "crowd" excerpt in ../shared/data/bonn_crowd, which the
# repository does not hold), build the offline reference labels with dynamap-label, replay the
# pipeline (gaps in the published data are skipped and named), score it against the reference
# and draw the results on the depth images (one picture every 30 frames and a contact sheet).
# Then check the reference itself where truth exists: dynamap-label on every simulated scene,
# scored against the simulator's obstacles.txt.
#
#   scripts/real_data.sh [--no-sim]
#
# Environment: DYNAMAP_REAL_SEQ (sequence directory), DYNAMAP_REAL_DIR (output, default
# out/real), DYNAMAP_SEEDS (simulated seeds for the reference check, default "1 2"),
# DYNAMAP_REPLAY_ARGS (extra replay options, e.g. "--poses bonn").
set -euo pipefail
cd "$(dirname "$0")/.."
SEQ=${DYNAMAP_REAL_SEQ:-../shared/data/bonn_crowd}
ROOT=${DYNAMAP_REAL_DIR:-out/real}
SEEDS=(${DYNAMAP_SEEDS:-1 2})
SCENES=(corridor l_corridor env_a env_b env_c standing crowd corridor_flight)
SIM=1
[ "${1:-}" = "--no-sim" ] && SIM=0

if [ ! -f "$SEQ/depth.txt" ]; then
  echo "real_data: no sequence at $SEQ (set DYNAMAP_REAL_SEQ to a TUM-layout directory)" >&2
  exit 1
fi
NAME=$(basename "$SEQ")

echo "== building (release preset) =="
cmake --preset release >/dev/null
cmake --build build/release -j2 --target dynamap-sim dynamap-replay dynamap-eval dynamap-label \
  dynamap-overlay >/dev/null
BIN=build/release/tools
mkdir -p "$ROOT"

# A replay that skipped listed-but-missing depth files exits with 3: completed, gaps named.
replay() {
  local rc=0
  "$BIN/dynamap-replay" "$@" || rc=$?
  [ $rc = 0 ] || [ $rc = 3 ] || { echo "real_data: dynamap-replay failed ($rc)" >&2; exit $rc; }
}

# A value of metrics.json (written one key per line), numbers with three decimals, null as n/a.
json() {
  sed -n "s/^  \"$2\": \(.*\)$/\1/p" "$1" | sed 's/,$//' | head -n 1 |
    awk '{ if ($1 == "null") print "n/a"; else if ($1 ~ /\./ || $1 == "1" || $1 == "0") printf "%.3f\n", $1; else print $1 }'
}

echo "== $NAME: reference labels (offline, from the data) =="
"$BIN/dynamap-label" "$SEQ" --out "$ROOT/${NAME}_reference" --quiet
echo "== $NAME: replaying the pipeline =="
replay "$SEQ" --out "$ROOT/${NAME}_out" --quiet --cpu-clock ${DYNAMAP_REPLAY_ARGS:-}
echo "== $NAME: scoring against the reference =="
"$BIN/dynamap-eval" "$SEQ" "$ROOT/${NAME}_out" \
  --reference "$ROOT/${NAME}_reference/obstacles.txt" --picture | sed -n '1,14p'
echo "== $NAME: pictures on the depth images =="
"$BIN/dynamap-overlay" "$SEQ" "$ROOT/${NAME}_out" \
  --reference "$ROOT/${NAME}_reference/obstacles.txt" --every 30 --quiet

if [ $SIM = 1 ]; then
  echo
  echo "== the reference labeller against the simulator's truth =="
  printf '| scene | seed | moving GT frames | recall | precision | position error (m) | velocity error (m/s) |\n'
  printf '|---|---|---|---|---|---|---|\n'
  for seed in "${SEEDS[@]}"; do
    for s in "${SCENES[@]}"; do
      seq="$ROOT/sim_s$seed/$s"
      if [ ! -f "$seq/depth.txt" ]; then
        "$BIN/dynamap-sim" "$s" --out "$seq" --seed "$seed" --no-picture >/dev/null 2>&1
      fi
      "$BIN/dynamap-label" "$seq" --out "$seq.label" --quiet >"$seq.label.log" 2>&1 ||
        { cat "$seq.label.log" >&2; exit 1; }
      "$BIN/dynamap-eval" "$seq" "$seq.label" >/dev/null
      m="$seq.label/metrics.json"
      printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$s" "$seed" "$(json "$m" gt_count | cut -d. -f1)" \
        "$(json "$m" recall)" "$(json "$m" precision)" "$(json "$m" position_error_m)" \
        "$(json "$m" velocity_error_mps)"
    done
  done
fi
echo
echo "results: $ROOT/${NAME}_out (tracks, metrics.json, eval_topview.png, overlay/)"
echo "reference: $ROOT/${NAME}_reference/obstacles.txt"
