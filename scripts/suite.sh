#!/usr/bin/env bash
# The generated scenario suite (docs/evaluation.md, "Generated scenario suite"): renders N seeds
# with `dynamap-sim random` (two at a time), replays each (--quiet --cpu-clock), evaluates it
# (dynamap-eval --picture --map), draws an overlay contact sheet, and prints one table over the
# distribution with the five worst seeds per metric (dynamap-suite-table; also ROOT/suite.md).
#
#   scripts/suite.sh N [--first S] [--seeds "A B C"] [--out DIR] [--frames F] [--jobs J]
#                      [--bin DIR] [--reuse] [--params FILE] [--min KEY=V]... [--max KEY=V]...
#
# Seeds S .. S+N-1 (default S = 1), or the N seeds listed by --seeds; output in DIR (default
# out/suite): DIR/seed_K (sequence, README.md with every draw), DIR/seed_K_out (replay,
# metrics.json, pictures, overlay/contact_sheet.png), DIR/seed_K.log.
# --frames F: frames per seed (default: dynamap-sim random's 450, 15 s). --bin DIR: the tools'
# directory (default: build the release preset and use build/release/tools). --reuse: keep a
# seed's sequence already rendered in DIR (same seed and frames), e.g. to re-measure a library
# change without the render, which is most of the time. --params FILE: parameters for every
# replay (dynamap-replay --params; e.g. one setting against the defaults). --min / --max:
# bounds every seed must keep (the smoke test's floors); exit 1 when one does not.
set -euo pipefail
cd "$(dirname "$0")/.."
usage() { sed -n '7,8p' "$0" | sed 's/^# *//' >&2; exit 2; }
[ $# -ge 1 ] || usage
N=$1; shift
FIRST=1 SEEDS="" ROOT=out/suite FRAMES="" JOBS=2 BIN="" REUSE=0 PARAMS="" BOUNDS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --first) FIRST=$2; shift 2 ;;
    --seeds) SEEDS=$2; shift 2 ;;
    --out) ROOT=$2; shift 2 ;;
    --frames) FRAMES=$2; shift 2 ;;
    --jobs) JOBS=$2; shift 2 ;;
    --bin) BIN=$2; shift 2 ;;
    --reuse) REUSE=1; shift ;;
    --params) PARAMS=$(realpath "$2"); shift 2 ;;
    --min|--max) BOUNDS+=("$1" "$2"); shift 2 ;;
    *) usage ;;
  esac
done
if [ -z "$BIN" ]; then
  echo "== building (release preset) =="
  cmake --preset release >/dev/null
  cmake --build build/release -j2 --target dynamap-sim dynamap-replay dynamap-eval \
    dynamap-overlay dynamap-suite-table >/dev/null
  BIN=build/release/tools
fi
mkdir -p "$ROOT"
if [ -n "$SEEDS" ]; then
  echo "$SEEDS" | tr ' ' '\n' | grep . | head -n "$N" > "$ROOT/seeds.txt"
else
  seq "$FIRST" $((FIRST + N - 1)) > "$ROOT/seeds.txt"
fi

# One seed: render, replay, evaluate, overlay; one progress line when it is done.
run_seed() {
  local k=$1 seq="$ROOT/seed_$1" out="$ROOT/seed_$1_out" log="$ROOT/seed_$1.log" t0=$SECONDS
  rm -rf "$out"
  # A kept sequence is reused only when it was rendered for the same frame count.
  local want="${FRAMES:-default}"
  if [ "$REUSE" = 1 ] && [ -f "$seq/README.md" ] && [ "$(cat "$seq/.frames" 2>/dev/null)" = "$want" ]; then
    echo "reusing $seq" >"$log"
  else
    rm -rf "$seq"
    "$BIN/dynamap-sim" random --seed "$k" --out "$seq" ${FRAMES:+--frames "$FRAMES"} >"$log" 2>&1 ||
      { echo "seed $k FAILED (render; $log)"; return 1; }
    echo "$want" >"$seq/.frames"
  fi
  if "$BIN/dynamap-replay" "$seq" --out "$out" --quiet --cpu-clock ${PARAMS:+--params "$PARAMS"} \
       >>"$log" 2>&1 &&
     "$BIN/dynamap-eval" "$seq" "$out" --picture --map >>"$log" 2>&1 &&
     "$BIN/dynamap-overlay" "$seq" "$out" --out "$out/overlay" --every 45 --quiet >>"$log" 2>&1
  then
    local m="$out/metrics.json"
    val() { grep -m1 "\"$1\": " "$m" | sed 's/.*: \([^,]*\),*/\1/'; }
    printf 'seed %-5s %4ds  %s | recall %s precision %s SA %s DA %s\n' "$k" $((SECONDS - t0)) \
      "$(sed -n 5p "$seq/README.md" | cut -c1-60)" "$(val recall)" "$(val precision)" \
      "$(val sa)" "$(val da)"
  else
    echo "seed $k FAILED (see $log)"
  fi
}

echo "== seeds $(tr '\n' ' ' < "$ROOT/seeds.txt")($JOBS at a time) -> $ROOT =="
T0=$SECONDS
for k in $(cat "$ROOT/seeds.txt"); do
  while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do wait -n || true; done
  run_seed "$k" &
done
wait
echo "== done in $((SECONDS - T0)) s =="
echo
"$BIN/dynamap-suite-table" "$ROOT" "${BOUNDS[@]}"
