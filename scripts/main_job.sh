#!/usr/bin/env bash
# xbarsim's main job on the default configuration (configs/default.yaml):
#  - with the shared data (../shared or $XBARSIM_DATA_DIR): ResNet-20 on CIFAR-10 with the
#    full parasitic circuit (accuracy and per-layer error propagation), then the SystemC
#    accelerator on a few images (timing, power, area, energy, accuracy);
#  - without data: the SystemC accelerator on the built-in ResNet-20 topology.
# Reports go to ${XBARSIM_OUT:-out}/: JSON, CSV and an HTML page per run (the paths are printed
# at the end: open them in a browser).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${XBARSIM_OUT:-out}
mkdir -p "$OUT"
X=build/sw/xbarsim
DATA=${XBARSIM_DATA_DIR:-../shared/data}
if [ -d "$DATA/cifar10" ] && [ -d "$DATA/../models" ]; then
  "$X" eval --model resnet20_cifar10 --images "${XBARSIM_IMAGES:-all}" --json "$OUT/eval_resnet20.json" \
    --csv "$OUT/eval_resnet20_layers.csv" --report "$OUT/eval_resnet20.html" "$@"
  "$X" simulate --model resnet20_cifar10 --dataset cifar10 --images 10 --json "$OUT/simulate_resnet20.json" \
    --report "$OUT/simulate_resnet20.html" "$@"
  pages=("$OUT/eval_resnet20.html" "$OUT/simulate_resnet20.html")
else
  echo "main job: no data directory ($DATA); simulating the built-in ResNet-20 topology with random weights"
  "$X" simulate --preset resnet20 --json "$OUT/simulate_resnet20.json" --report "$OUT/simulate_resnet20.html" "$@"
  pages=("$OUT/simulate_resnet20.html")
fi
echo "reports written to $OUT/; open in a browser:"
for p in "${pages[@]}"; do echo "  $(cd "$(dirname "$p")" && pwd)/$(basename "$p")"; done
