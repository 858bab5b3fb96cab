#!/usr/bin/env bash
# Wall-clock speed of the SystemC platform, side by side with the batch engine in one run:
#  1. ResNet-20 on real CIFAR-10 images, full parasitic circuit, default configuration
#     (simulate, one thread) vs eval (all threads, software and crossbar networks);
#  2. a preset-only timing run of 1000 pipelined ResNet-20 images (whole process, seconds).
# Usage: bench/bench_platform.sh [build-dir] [images]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; N=${2:-500}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
X="$B/sw/xbarsim"
"$X" simulate --model resnet20_cifar10 --dataset cifar10 --images "$N" --json "$T/sim.json" >/dev/null
"$X" eval --model resnet20_cifar10 --images "$N" --json "$T/eval.json" >/dev/null
sim=$(grep -o '"simulated_images_per_wall_s": [0-9.e+-]*' "$T/sim.json" | awk '{print $2}')
ev=$(grep -o '"images_per_s": [0-9.e+-]*' "$T/eval.json" | awk '{print $2}')
printf "ResNet-20, CIFAR-10, %d images: platform (SystemC) %.1f images/s, batch eval %.1f images/s, ratio %.2f\n" \
  "$N" "$sim" "$ev" "$(echo "$sim / $ev" | bc -l)"
start=$(date +%s.%N)
"$X" simulate --preset resnet20 --set platform.schedule=pipelined --images 1000 >/dev/null
end=$(date +%s.%N)
printf "ResNet-20 preset, 1000 pipelined images (timing run, whole process): %.2f s\n" "$(echo "$end - $start" | bc -l)"
