#!/usr/bin/env bash
# Evaluation speed of the ISAAC-style datapath (configs/isaac.yaml: 8 bit-serial reads per
# input vector, 4 cells per weight) against the default design, side by side in one run:
# ResNet-20 on CIFAR-10 with the full parasitic circuit, both on all threads, alternated
# ROUNDS times; prints each run's evaluation images/s (programming excluded) and the median
# ratio. Usage: bench/bench_bit_serial.sh [build-dir] [images] [rounds]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; N=${2:-1000}; R=${3:-3}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
X="$B/sw/xbarsim"
rate() { grep -o '"images_per_s": [0-9.e+-]*' "$1" | awk '{print $2}'; }
ratios=()
for r in $(seq "$R"); do
  "$X" eval --model resnet20_cifar10 --images "$N" --json "$T/d.json" >/dev/null 2>&1
  "$X" eval --model resnet20_cifar10 --images "$N" --config configs/isaac.yaml --json "$T/i.json" >/dev/null 2>&1
  d=$(rate "$T/d.json"); i=$(rate "$T/i.json")
  q=$(echo "$i / $d" | bc -l)
  ratios+=("$q")
  printf "round %d: default %.1f images/s, ISAAC-style %.1f images/s, ratio %.3f\n" "$r" "$d" "$i" "$q"
done
printf "median ratio ISAAC-style / default: %s\n" "$(printf '%s\n' "${ratios[@]}" | sort -g | awk '{a[NR]=$1} END {printf "%.3f", a[int((NR+1)/2)]}')"
