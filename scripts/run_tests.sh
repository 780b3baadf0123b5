#!/usr/bin/env bash
# Runs the whole test suite: dev tests, ASan+UBSan tests, TSan tests of the threaded code, the
# -fno-exceptions -fno-rtti build with its tests, the aarch64 cross build with its tests under
# qemu-aarch64, and a short fixed-seed run of each libFuzzer target (ASan+UBSan, about 15 s
# each), and clang-tidy over the library's, the tools' and the benchmarks' sources (.clang-tidy:
# functions of at most 80 lines, bug-prone checks, warnings as errors; on the dev build's compile
# commands). The dev preset compiles the benchmarks so they cannot rot unseen; none is a test.
# Prints ctest's summary for each and exits non-zero if any step failed.
# A preset's build tree is removed once its tests pass (the dev preset's is kept for clang-tidy;
# DYNAMAP_KEEP_BUILDS=1 keeps all): the peak is then the dev tree (about 3 GB) and one other,
# about 4.3 GB, where all six trees together take about 5 GB.
set -uo pipefail
cd "$(dirname "$0")/.."

# A full disk fails the build with "No space left on device" deep in a log; say it up front.
free_kb=$(df -Pk . | awk 'NR == 2 {print $4}')
if [ "${free_kb:-0}" -lt 5000000 ]; then
  echo "warning: only $((free_kb / 1024)) MB free here; the test builds need about 4.5 GB at their peak"
fi

PRESETS=(${DYNAMAP_TEST_PRESETS:-dev asan tsan noexcept aarch64 fuzz})
declare -A result
failed=0

# Formatting is part of the build's warnings-as-errors discipline.
echo "=== clang-format check ==="
unformatted=$(git ls-files '*.cpp' '*.hpp' | while read -r f; do
  clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || echo "$f"; done)
if [ -n "$unformatted" ]; then
  echo "not formatted with .clang-format (run clang-format -i):"; echo "$unformatted"
  failed=1
else
  echo "=== clang-format check: all sources formatted ==="
fi
for p in "${PRESETS[@]}"; do
  echo "=== preset ${p}: configure, build, test ==="
  log="build/${p}-workflow.log"
  mkdir -p build
  start=$(date +%s)
  if cmake --workflow --preset "${p}" >"${log}" 2>&1; then
    result[$p]="passed"
  else
    result[$p]="FAILED (log: ${log})"
    failed=1
    tail -n 60 "${log}"
  fi
  # ctest's own summary lines.
  grep -E "tests passed|tests failed|Total Test time|\*\*\*Failed|\(Failed\)|Timeout" "${log}" || true
  if [ "${result[$p]}" = "passed" ] && [ "${p}" != "dev" ] && [ "${DYNAMAP_KEEP_BUILDS:-0}" != "1" ]; then
    rm -rf "build/${p}"
  fi
  echo "=== preset ${p}: ${result[$p]} in $(( $(date +%s) - start )) s ==="
done

# clang-tidy on every library, tool and benchmark source the dev build compiles (src/,
# platform/, tools/, bench/; the dev preset builds the tools and the benchmarks). fuzz/ is not in
# the dev build's compile commands.
tidy="skipped (needs the dev preset)"
if [ -f build/dev/compile_commands.json ]; then
  echo "=== clang-tidy: src/, platform/, tools/ and bench/ ==="
  start=$(date +%s)
  files=$(git ls-files 'src/*.cpp' 'platform/*.cpp' 'tools/*.cpp' 'bench/*.cpp' |
    while read -r f; do
      grep -q "\"file\": \"$(pwd)/$f\"" build/dev/compile_commands.json && echo "$f"; done)
  if echo "$files" | xargs -P 2 -n 1 clang-tidy -p build/dev --quiet >build/tidy.log 2>&1; then
    tidy="passed ($(echo "$files" | wc -l) files)"
  else
    tidy="FAILED (log: build/tidy.log)"
    failed=1
    grep -E "error:|warning:" build/tidy.log | sort -u | head -n 40
  fi
  echo "=== clang-tidy: ${tidy} in $(( $(date +%s) - start )) s ==="
fi

echo
echo "Summary:"
[ -n "$unformatted" ] && echo "  format: FAILED" || echo "  format: passed"
for p in "${PRESETS[@]}"; do echo "  ${p}: ${result[$p]}"; done
echo "  clang-tidy: ${tidy}"
exit ${failed}
