#!/usr/bin/env bash
# Wall-clock speed of the SystemC platform on ResNet-20 (full parasitic circuit, default
# configuration), side by side with the batch engine on the same images in one run.
# Usage: bench/bench_platform.sh [build-dir] [images]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; N=${2:-500}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
"$B/sw/xbarsim" simulate --model resnet20_cifar10 --dataset cifar10 --images "$N" --json "$T/sim.json" >/dev/null
"$B/sw/xbarsim" eval --model resnet20_cifar10 --images "$N" --json "$T/eval.json" >/dev/null
sim=$(grep -o '"simulated_images_per_wall_s": [0-9.e+-]*' "$T/sim.json" | awk '{print $2}')
ev=$(grep -o '"images_per_s": [0-9.e+-]*' "$T/eval.json" | awk '{print $2}')
printf "platform (SystemC, 1 thread): %.1f images/s   batch eval (2 threads, software+crossbar): %.1f images/s   ratio %.2f\n" "$sim" "$ev" "$(echo "$sim / $ev" | bc -l)"
