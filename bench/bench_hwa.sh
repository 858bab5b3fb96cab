#!/usr/bin/env bash
# What hardware-aware training costs (issue 41), side by side in one run: one epoch of
# `python3 -m xbarsim.hwa` over CIFAR-10's data_batch_1 (10 000 images) on the shared ResNet-20,
# in software (--software: the noiseless fine-tuning) and under rram-wan2022 with differential
# pairs and the default converters (programming error per batch, read noise per forward, DAC and
# ADC), alternated ROUNDS times on every core. Prints each run's wall time and the median ratio.
# Usage: bench/bench_hwa.sh [build-dir] [data-dir] [rounds]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; D=${2:-../shared/data}; R=${3:-3}
M=${D%/}/../models/resnet20_cifar10.onnx
[ -f "$D/cifar10/data_batch_1.bin" ] && [ -f "$M" ] || { echo "bench_hwa: needs $D/cifar10/data_batch_1.bin and $M"; exit 0; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
mkdir "$T/train"; ln -s "$(realpath "$D/cifar10/data_batch_1.bin")" "$T/train/"
ln -s "$(realpath "$D/cifar10/calib_batch.bin")" "$T/train/" 2>/dev/null || true
hwa() { PYTHONPATH="$B/python" /usr/bin/python3 -m xbarsim.hwa --model "$M" --train "$T/train" --epochs 1 --quiet \
          --out "$T/out.onnx" "$@"; }
seconds() { local s; s=$(date +%s.%N); "$@" 2>/dev/null; echo "$(date +%s.%N) - $s" | bc -l; }
ratios=()
for r in $(seq "$R"); do
  a=$(seconds hwa --software)
  b=$(seconds hwa --set device.model=rram-wan2022 --set mapping.negative=differential)
  ratios+=("$(echo "$b / $a" | bc -l)")
  printf "round %d: software %6.1f s | HWA rram-wan2022 %6.1f s (x%.2f)\n" "$r" "$a" "$b" "$(echo "$b / $a" | bc -l)"
done
printf "median HWA / software: x%s\n" "$(printf '%s\n' "${ratios[@]}" | sort -g | awk '{a[NR]=$1} END {printf "%.2f", a[int((NR+1)/2)]}')"
