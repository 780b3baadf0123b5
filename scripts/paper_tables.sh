#!/usr/bin/env bash
# The paper's evaluation on our simulated scenes: simulates every built-in scene (once; pass
# --fresh to re-simulate), replays it through the pipeline, evaluates it, and prints Table I
# (position/velocity error per scene), Table II (runtime per module) and the prediction failure
# ratio of the Markov predictor against the linear baseline, and the map accuracy table (SA, DA,
# AA of the final map, dynamap-eval --map). Stage times are thread CPU time
# (dynamap-replay --cpu-clock), so a shared machine's load does not inflate Table II. Output in ${DYNAMAP_EVAL_DIR:-out/eval}.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=${DYNAMAP_EVAL_DIR:-out/eval}
SCENES=(${DYNAMAP_SCENES:-corridor l_corridor env_a env_b env_c standing crowd corridor_flight})
FRESH=0
[ "${1:-}" = "--fresh" ] && FRESH=1

echo "== building (release preset) =="
cmake --preset release >/dev/null
cmake --build build/release -j2 --target dynamap-sim dynamap-replay dynamap-eval dynamap-tables >/dev/null
BIN=build/release/tools
mkdir -p "$ROOT"
for s in "${SCENES[@]}"; do
  if [ $FRESH = 1 ] || [ ! -f "$ROOT/$s/depth.txt" ]; then
    echo "== simulating $s =="
    rm -rf "${ROOT:?}/$s"
    "$BIN/dynamap-sim" "$s" --out "$ROOT/$s" | tail -n 1
  fi
  echo "== replaying $s =="
  "$BIN/dynamap-replay" "$ROOT/$s" --out "$ROOT/${s}_out" --quiet --cpu-clock | grep -E "frames:|tracks:|total|wall time"
  "$BIN/dynamap-eval" "$ROOT/$s" "$ROOT/${s}_out" --picture --map >/dev/null
done
echo
"$BIN/dynamap-tables" "$ROOT" "${SCENES[@]}"
echo
echo "tables written to $ROOT/tables.md; pictures: $ROOT/*_out/topview.png, eval_topview.png and map_topview.png"
