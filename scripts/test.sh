#!/usr/bin/env bash
# The test command of the README: installs what is needed (scripts/setup.sh), builds once and
# runs the test suite (CTest + GoogleTest), all of it but the cases CI runs after it
# (XBARSIM_CI_ONLY, a ctest -E regex; "" runs everything), which keep this command within 10
# minutes on 2 cores: the 128x64 nonlinear ngspice comparison (four minutes of ngspice itself;
# the 64x32 one stays here), the 256x64 voltage-sensing ones (two minutes of ngspice; 64x32 and
# 256x16 stay), the software accuracy of ResNet-32 and ResNet-56 over the whole
# CIFAR-10 test set (ResNet-20's stays here), python.agreement (the converted ResNet-20 and
# LeNet against eval on 500 images), every command on the whole torchvision zoo (the zoo's
# import against torch's logits stays), the linear per-slice ngspice comparison (the
# nonlinear one stays) and explore on two MPI ranks.
# CI (.ci/run) runs this first, then those cases, the libFuzzer harnesses (scripts/fuzz.sh) and
# the unit tests under ASan + UBSan (scripts/sanitize.sh), which build twice more.
# The last line is the suite's count: "tests: N passed, M failed".
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build
log=$(mktemp)
set +e
ci_only=${XBARSIM_CI_ONLY-'128x64_nonlinear|256x64_voltage|FullTestSetAccuracyMatchesMetadata/.resnet(32|56)|python[.]agreement|TorchZooCli[.]EveryCommand|BitSlicedNgspice[.]EverySliceLinear|TwoMpiRanksEqualOne'}
exclude=()
[ -n "$ci_only" ] && exclude=(-E "$ci_only")
(cd build && ctest --output-on-failure -j "$(nproc)" --timeout 900 "${exclude[@]}") 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
set -e
summary=$(sed -nE 's/^[0-9]+% tests passed, ([0-9]+) tests failed out of ([0-9]+)$/\1 \2/p' "$log" | tail -1)
rm -f "$log"
if [ -n "$summary" ]; then
  read -r failed total <<<"$summary"
  echo "tests: $((total - failed)) passed, $failed failed"
fi
exit "$rc"
