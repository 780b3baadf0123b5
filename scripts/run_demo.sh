#!/usr/bin/env bash
# The main job: build dynamap (Release), simulate a built-in scene (default env_b: people walking
# among boxes and pillars), run the real-time pipeline over it, evaluate the result against the
# ground truth, and write pictures (top views, and the tracks drawn on the depth images).
# Usage: scripts/run_demo.sh [SCENE]
set -euo pipefail
cd "$(dirname "$0")/.."
SCENE=${1:-env_b}
OUT=${DYNAMAP_OUT:-out/demo}

echo "== building (release preset, this takes a few minutes the first time) =="
cmake --preset release >/dev/null
cmake --build build/release -j2 --target dynamap-sim dynamap-replay dynamap-eval dynamap-overlay >/dev/null
BIN=build/release/tools
rm -rf "${OUT:?}/$SCENE" "${OUT:?}/${SCENE}_out"
mkdir -p "$OUT"

echo "== simulating scene '$SCENE' (640x480 depth at 30 Hz, TUM layout) =="
"$BIN/dynamap-sim" "$SCENE" --out "$OUT/$SCENE" | tail -n 1
echo "== running the pipeline =="
"$BIN/dynamap-replay" "$OUT/$SCENE" --out "$OUT/${SCENE}_out" --picture-every 60
echo "== evaluating against the ground truth =="
"$BIN/dynamap-eval" "$OUT/$SCENE" "$OUT/${SCENE}_out" --map --picture
echo "== drawing the results on the depth images =="
"$BIN/dynamap-overlay" "$OUT/$SCENE" "$OUT/${SCENE}_out" --every 60 --quiet
echo
echo "pictures:"
echo "  $OUT/${SCENE}_out/topview.png        final map, tracks, predictions"
echo "  $OUT/${SCENE}_out/eval_topview.png   tracked vs true paths"
echo "  $OUT/${SCENE}_out/map_topview.png    the map against the true world: missing static (red), left-over walkers (orange)"
echo "  $OUT/${SCENE}_out/frames/            one top view every 60 frames"
echo "  $OUT/${SCENE}_out/overlay/           tracks on the depth images: contact_sheet.png, one frame every 60"
echo "  $OUT/$SCENE/scene_topview.png        the simulated scene"
