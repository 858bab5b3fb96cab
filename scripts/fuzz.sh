#!/usr/bin/env bash
# Builds the libFuzzer harnesses (fuzz/) with clang + ASan + UBSan in build-fuzz and runs each
# for the given number of seconds on a copy of its seed corpus.
# Usage: scripts/fuzz.sh [seconds-per-harness]   (default 60)
# Environment:
#   FUZZ_HARNESSES="fuzz_csv fuzz_onnx"  run only these (default: all four)
#   FUZZ_FRESH=1      start from the committed seeds instead of the corpus grown by earlier runs
#   FUZZ_FORK=0       stop each harness at its first crash (default: keep fuzzing past crashes,
#                     libFuzzer -fork=1 -ignore_crashes=1, so one bug does not hide the next)
#   JOBS=2            parallel build jobs
# Output: build-fuzz/corpus/<harness> (grown corpus), build-fuzz/artifacts/<harness>/ (crash-*,
# leak-*, timeout-*, oom-* reproducers; cleared at the start of each harness's run),
# build-fuzz/logs/<harness>.log. Exit status 1 if any harness produced a reproducer.
# Reproduce one: build-fuzz/fuzz/<harness> <reproducer-file>
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER=${1:-60}
BUILD_DIR=build-fuzz
JOBS=${JOBS:-2}
HARNESSES=(${FUZZ_HARNESSES:-fuzz_csv fuzz_config fuzz_onnx fuzz_dataset})

# --- toolchain (idempotent, like scripts/setup.sh)
PACKAGES=(clang libclang-rt-14-dev cmake libeigen3-dev libyaml-cpp-dev libonnx-dev libprotobuf-dev
          protobuf-compiler zlib1g-dev)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "fuzz: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --- build (-O1 -g without NDEBUG: Eigen's and our own asserts stay on)
CC=clang CXX=clang++ cmake -S . -B "$BUILD_DIR" -DXBARSIM_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS" --target "${HARNESSES[@]}"

max_len_for() {
  case "$1" in
    fuzz_csv | fuzz_config) echo 4096 ;;
    *) echo 65536 ;;
  esac
}

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
FORK_ARGS=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
[ "${FUZZ_FORK:-1}" = 0 ] && FORK_ARGS=()

mkdir -p "$BUILD_DIR/logs"
summary=()
found=()
for h in "${HARNESSES[@]}"; do
  corpus="$BUILD_DIR/corpus/$h"
  artifacts="$BUILD_DIR/artifacts/$h"
  log="$BUILD_DIR/logs/$h.log"
  [ "${FUZZ_FRESH:-0}" = 1 ] && rm -rf "$corpus"
  mkdir -p "$corpus"
  rm -rf "$artifacts"
  mkdir -p "$artifacts"
  cp -n fuzz/corpus/"$h"/* "$corpus"/ 2>/dev/null || true
  echo "fuzz: $h for ${SECONDS_PER}s (log: $log)"
  set +e
  "$BUILD_DIR/fuzz/$h" "$corpus" "${FORK_ARGS[@]}" -max_total_time="$SECONDS_PER" \
    -max_len="$(max_len_for "$h")" -rss_limit_mb=2048 -timeout=10 -print_funcs=0 -print_final_stats=1 \
    -artifact_prefix="$artifacts/" >"$log" 2>&1
  rc=$?
  set -e
  # Final libFuzzer status line: "#N ... cov: C ft: F corp: K..." (plain and fork mode).
  last=$(grep -E '^#[0-9]+.*cov: [0-9]+' "$log" | tail -1 || true)
  execs=$(sed -nE 's/^#([0-9]+).*/\1/p' <<<"$last")
  execs_final=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+).*/\1/p' "$log" | tail -1)
  cov=$(sed -nE 's/.*cov: ([0-9]+).*/\1/p' <<<"$last")
  ft=$(sed -nE 's/.*ft: ([0-9]+).*/\1/p' <<<"$last")
  ncorp=$(find "$corpus" -type f | wc -l)
  corp_kb=$(find "$corpus" -type f -printf '%s\n' | awk '{s += $1} END {print int((s + 1023) / 1024)}')
  mapfile -t arts < <(find "$artifacts" -type f | sort)
  summary+=("$(printf '%-13s execs %-10s corpus %5s files (%6s KB)  cov %-6s ft %-6s reproducers %s  (exit %s)' \
    "$h" "${execs_final:-${execs:-?}}" "$ncorp" "$corp_kb" "${cov:-?}" "${ft:-?}" "${#arts[@]}" "$rc")")
  ((${#arts[@]})) && found+=("${arts[@]}")
done

echo
echo "fuzz: summary (${SECONDS_PER}s per harness)"
printf '  %s\n' "${summary[@]}"
if ((${#found[@]})); then
  echo "fuzz: FINDINGS (reproduce with $BUILD_DIR/fuzz/<harness> <file>):"
  printf '  %s\n' "${found[@]}"
  exit 1
fi
echo "fuzz: no findings"
