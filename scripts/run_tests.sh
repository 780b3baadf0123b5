#!/usr/bin/env bash
# Runs the whole test suite: dev tests, ASan+UBSan tests, TSan tests of the threaded code, the
# -fno-exceptions -fno-rtti build with its tests, and the aarch64 cross build with its tests
# under qemu-aarch64. Prints ctest's summary for each and exits non-zero if any step failed.
set -uo pipefail
cd "$(dirname "$0")/.."

PRESETS=(${DYNAMAP_TEST_PRESETS:-dev asan tsan noexcept aarch64})
declare -A result
failed=0
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
  echo "=== preset ${p}: ${result[$p]} in $(( $(date +%s) - start )) s ==="
done

echo
echo "Summary:"
for p in "${PRESETS[@]}"; do echo "  ${p}: ${result[$p]}"; done
exit ${failed}
