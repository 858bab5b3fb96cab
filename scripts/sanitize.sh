#!/usr/bin/env bash
# Builds everything with AddressSanitizer + UndefinedBehaviorSanitizer (gcc) in build-asan and
# runs the unit tests, except the slow whole-dataset ones.
# Usage: scripts/sanitize.sh
# Environment:
#   SANITIZE_EXCLUDE  ctest -E regex of excluded tests (default: the
#                     Shared/SharedModel.FullTestSetAccuracyMatchesMetadata/* cases, which push the
#                     whole 10 000-image test set through each network, the 128x64 nonlinear
#                     ngspice comparison (two minutes of ngspice itself), the nonlinear-device eval
#                     (two minutes under ASan; the batched Newton runs there in its unit tests), and the tests that run
#                     SystemC simulations: SystemC's user-level threads switch stacks behind
#                     AddressSanitizer's back, which then reports false stack overflows and
#                     crashes LeakSanitizer (google/sanitizers#189), explore among them (its platform
#                     runs), and the data-safety and bit-serial CLI cases that simulate or explore; they run in the
#                     regular build), and three cases that repeat whole evaluations to compare them
#                     (EvalCommand.SameResultOnOneTwoAndThreeThreads: ResNet-20 with devices on 1, 2
#                     and 3 threads, 548 s under ASan against 27 s; JournalResumesWithTheSameResultAsOneRun,
#                     229 s; Ranging.BiasCorrectionMatchesTheSoftwareMeanOnTheCalibrationImages, 115 s):
#                     their code paths run here in the single evaluations of the other EvalCommand
#                     and Ranging cases, and the comparisons themselves in the regular build
#   SANITIZE_EXCLUDE_LABEL  ctest -LE regex (default: ^slow$)
#   JOBS=2            parallel build and test jobs
# Every sanitizer report (also from the xbarsim processes that the CLI tests start, whose exit
# status a test may expect to be non-zero anyway) is written to build-asan/sanitizer-logs/;
# the script exits 1 if a test failed or any report was written.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=build-asan
JOBS=${JOBS:-2}
# Simulating tests are left out (SystemC runs); so are the CLI runs of a simulation on a machine
# (configs/isaac.yaml), whose xbarsim processes end, in 2 runs of 3, with LeakSanitizer's own
# stop-the-world tracer faulting while it reads the threads' stacks ("Tracer caught signal 11
# ... LeakSanitizer has encountered a fatal error", no report; LSAN_OPTIONS=use_stacks=0 avoids
# it): not understood yet. The machine's in-process simulations (MapperAgreesWithTheSimulation)
# stay here.
EXCLUDE=${SANITIZE_EXCLUDE:-'FullTestSet|^EvalCommand\.(SameResultOnOneTwoAndThreeThreads|JournalResumesWithTheSameResultAsOneRun)$|^Ranging\.BiasCorrectionMatchesTheSoftwareMeanOnTheCalibrationImages$|128x64_nonlinear|NonlinearDevicesRunEvery|^Platform\.|^Tile\.|^TileSchedule\.|^ShiftRegisterBuffer\.|^SimulateCommand|^ExploreCommand|^Consistency\.|VcdPath|^Safety\.(NoOutputFlag|Item5And12|Item12|Item6|Item8|Item10|Item11|Item14|Item15|Item16)|^BitSerialCli\.(Simulate|Explore)|^Robustness\.(MachineVcd|HugeMachines)|^TorchZooCli\.|^Safety\.OneImageReports'}
EXCLUDE_LABEL=${SANITIZE_EXCLUDE_LABEL:-^slow\$}
FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"

start=$(date +%s)
# The Python extension is left out: an instrumented module cannot load into an uninstrumented python3.
# -O1 -g1 (line tables: enough for the reports' stack traces) and no benchmarks: under ASan the
# build is most of this script's time, and -O2 -g costs ~1.4x its compile time (measured on
# test_platform.cpp and analog_layer.cpp: 100 s -> 72 s, 77 s -> 46 s).
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS="$FLAGS" \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DXBARSIM_BENCH=OFF -DXBARSIM_PYTHON=OFF >/dev/null
# Test discovery (gtest_discover_tests) runs the instrumented test binaries at build time.
cmake --build "$BUILD_DIR" -j "$JOBS"
built=$(date +%s)

LOG_DIR=$PWD/$BUILD_DIR/sanitizer-logs
rm -rf "$LOG_DIR"
mkdir -p "$LOG_DIR"
export ASAN_OPTIONS="detect_leaks=1:log_path=$LOG_DIR/asan"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$LOG_DIR/ubsan"
export LSAN_OPTIONS="log_path=$LOG_DIR/lsan"

cd "$BUILD_DIR"
echo "sanitize: excluded tests (-E '$EXCLUDE', -LE '$EXCLUDE_LABEL'):"
comm -23 <(ctest -N | sed -nE 's/^ *Test +#[0-9]+: (.*)$/\1/p' | sort) \
         <(ctest -N -E "$EXCLUDE" -LE "$EXCLUDE_LABEL" | sed -nE 's/^ *Test +#[0-9]+: (.*)$/\1/p' | sort) |
  sed 's/^/  /'
set +e
ctest --output-on-failure -j "$JOBS" --timeout 900 -E "$EXCLUDE" -LE "$EXCLUDE_LABEL"
rc=$?
set -e
end=$(date +%s)
echo "sanitize: build $((built - start)) s, tests $((end - built)) s"

mapfile -t reports < <(find "$LOG_DIR" -type f | sort)
if ((${#reports[@]})); then
  echo "sanitize: ${#reports[@]} sanitizer report(s):"
  for r in "${reports[@]}"; do
    echo "---- $r"
    head -40 "$r"
  done
  exit 1
fi
if ((rc)); then
  echo "sanitize: tests failed (ctest exit $rc)"
  exit 1
fi
echo "sanitize: no findings"
