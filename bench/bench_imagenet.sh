#!/usr/bin/env bash
# ImageNet-size timing (issue 26): ResNet-50 at 3 x 224 x 224 (torchvision, seeded random weights,
# exported by tests/nn/torch_zoo.py with Debian's python3-torch) against ResNet-20 at 32 x 32,
# both timing only, pipelined on ISAAC-CE (configs/isaac.yaml), side by side in one run:
# simulated images per second of wall time.
# Usage: bench/bench_imagenet.sh [build-dir] [images]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; N=${2:-200}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
X="$B/sw/xbarsim"
/usr/bin/python3 tests/nn/torch_zoo.py "$T" 224 resnet50 >/dev/null 2>&1 ||
  { echo "bench_imagenet: needs python3-torch and python3-torchvision (scripts/setup.sh installs them)"; exit 1; }
field() { grep -o "\"$1\": [0-9.e+-]*" "$2" | head -1 | awk '{print $2}'; }
"$X" simulate --model "$T/resnet50.onnx" --config configs/isaac.yaml --timing-only --images "$N" --json "$T/r50.json" >/dev/null 2>&1
"$X" simulate --model resnet20_cifar10 --config configs/isaac.yaml --timing-only --images "$N" --json "$T/r20.json" >/dev/null 2>&1
r50=$(field simulated_images_per_wall_s "$T/r50.json"); r20=$(field simulated_images_per_wall_s "$T/r20.json")
printf "timing only on ISAAC-CE, %d images: ResNet-50 224x224 %.1f images/s of wall time, ResNet-20 32x32 %.1f (ratio %.3f)\n" \
  "$N" "$r50" "$r20" "$(echo "$r50 / $r20" | bc -l)"
