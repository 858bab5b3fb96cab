#!/usr/bin/env bash
# Installs what is needed, builds, and runs the whole test suite (CTest + GoogleTest), then
# every libFuzzer harness briefly (scripts/fuzz.sh) and the unit tests under ASan + UBSan
# (scripts/sanitize.sh). XBARSIM_QUICK=1 runs the test suite only.
# The last line is the suite's count: "tests: N passed, M failed".
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build
log=$(mktemp)
set +e
(cd build && ctest --output-on-failure -j "$(nproc)" --timeout 900) 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
set -e
summary=$(sed -nE 's/^[0-9]+% tests passed, ([0-9]+) tests failed out of ([0-9]+)$/\1 \2/p' "$log" | tail -1)
rm -f "$log"
# The fuzzing and the sanitizer run count as one check each.
checks_passed=0 checks_failed=0
if [ "${XBARSIM_QUICK:-0}" != 1 ] && [ "$rc" = 0 ]; then
  for check in "scripts/fuzz.sh ${XBARSIM_FUZZ_SECONDS:-20}" "scripts/sanitize.sh"; do
    if FUZZ_FRESH=1 $check; then checks_passed=$((checks_passed + 1)); else checks_failed=$((checks_failed + 1)); fi
  done
fi
if [ -n "$summary" ]; then
  read -r failed total <<<"$summary"
  echo "tests: $((total - failed + checks_passed)) passed, $((failed + checks_failed)) failed"
fi
[ "$rc" = 0 ] && [ "$checks_failed" = 0 ]
