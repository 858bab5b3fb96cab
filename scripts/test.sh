#!/usr/bin/env bash
# The test command of the README: installs what is needed (scripts/setup.sh), builds once and
# runs the whole test suite (CTest + GoogleTest). About 8 minutes on 2 cores from a fresh clone.
# CI (.ci/run) runs this first, then the libFuzzer harnesses (scripts/fuzz.sh) and the unit tests
# under ASan + UBSan (scripts/sanitize.sh), which build twice more.
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
if [ -n "$summary" ]; then
  read -r failed total <<<"$summary"
  echo "tests: $((total - failed)) passed, $failed failed"
fi
exit "$rc"
