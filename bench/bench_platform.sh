#!/usr/bin/env bash
# Wall-clock speed of the SystemC platform, side by side in one run (the machine is shared and
# noisy: compare the ratios, not the absolute figures of two runs):
#  1. ResNet-20 on real CIFAR-10 images with the full parasitic circuit, simulate with its
#     values on one worker thread and on all cores (solver.threads), against eval (all cores,
#     software and crossbar networks): on ISAAC-CE (configs/isaac.yaml) and on the default
#     layer-sized design. Images per second of simulation, programming excluded.
#  2. Timing only: 1000 pipelined ResNet-20 images on ISAAC-CE (whole process, seconds).
# Usage: bench/bench_platform.sh [build-dir] [images]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; N=${2:-500}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
X="$B/sw/xbarsim"
field() { grep -o "\"$1\": [0-9.e+-]*" "$2" | head -1 | awk '{print $2}'; }
for design in isaac default; do
  cfg=(); [ "$design" = isaac ] && cfg=(--config configs/isaac.yaml)
  "$X" simulate --model resnet20_cifar10 --dataset cifar10 --images "$N" "${cfg[@]}" --set solver.threads=1 \
    --json "$T/s1.json" >/dev/null 2>&1
  "$X" simulate --model resnet20_cifar10 --dataset cifar10 --images "$N" "${cfg[@]}" --json "$T/s.json" >/dev/null 2>&1
  "$X" eval --model resnet20_cifar10 --images "$N" "${cfg[@]}" --json "$T/e.json" >/dev/null 2>&1
  s1=$(field simulated_images_per_wall_s "$T/s1.json"); s=$(field simulated_images_per_wall_s "$T/s.json")
  e=$(field images_per_s "$T/e.json")
  printf "%-8s ResNet-20, CIFAR-10, %d images: simulate 1 thread %.1f, all cores %.1f images/s (x%.2f); eval %.1f images/s; simulate/eval %.2f\n" \
    "$design" "$N" "$s1" "$s" "$(echo "$s / $s1" | bc -l)" "$e" "$(echo "$s / $e" | bc -l)"
done
start=$(date +%s.%N)
"$X" simulate --model resnet20_cifar10 --config configs/isaac.yaml --timing-only --images 1000 >/dev/null 2>&1
end=$(date +%s.%N)
printf "ResNet-20 on ISAAC-CE, 1000 pipelined images, timing only (whole process): %.2f s\n" "$(echo "$end - $start" | bc -l)"
