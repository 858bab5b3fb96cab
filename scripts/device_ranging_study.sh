#!/bin/bash
# ResNet-20 under the published device models with the device defaults of issue 50 (differential
# pairs, weights at their mse clip per column, no conductance headroom, 200 calibration vectors;
# docs/results.md, "Ranging under real devices"), and the same with an older xbarsim for the
# "before" columns. Resumable: a finished result is kept.
# Usage: scripts/device_ranging_study.sh OUT_DIR [BUILD_DIR (build)] [BEFORE_BINARY (none)]
# About an hour on 2 cores (three quarters of it the 10 000-image rows).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: scripts/device_ranging_study.sh OUT_DIR [BUILD_DIR] [BEFORE_BINARY]}
build=$(cd "${2:-$root/build}" && pwd)
before=${3:-}
mkdir -p "$out"
cd "$root"
times='[1,3600,86400,2592000,31536000]'
ev() {  # tag binary args...
  local tag=$1 bin=$2; shift 2
  if [ ! -f "$out/$tag.json" ]; then
    "$bin" eval --model resnet20_cifar10 --json "$out/$tag.json.tmp" "$@" \
    > "$out/$tag.txt" 2> "$out/$tag.err"
    mv "$out/$tag.json.tmp" "$out/$tag.json"
  fi
  echo "$tag done"
}
X=$build/sw/xbarsim
# The targets: 10 000 images, three device seeds.
ev rram_none_10k "$X" --set device.model=rram-wan2022 --set device.compensation=none \
  --set "device.time_s=[1,86400]" --set "device.seed=[11,12,13]"
ev rram_column_10k "$X" --set device.model=rram-wan2022 --set device.compensation=column \
  --set "device.time_s=[1,86400]" --set "device.seed=[11,12,13]"
ev pcm_global_10k "$X" --set device.model=pcm-joshi2020 --set device.compensation=global \
  --set "device.time_s=[86400,31536000]" --set "device.seed=[11,12,13]"
# Every model and compensation over time, 2000 images, one seed, after and before.
for m in rram-wan2022 pcm-joshi2020 rram-cmo; do
  for c in none global column recalibrate; do
    ev "after_${m}_${c}" "$X" --images 2000 --set device.model=$m --set device.compensation=$c --set "device.time_s=$times"
    if [ -n "$before" ]; then
      ev "before_${m}_${c}" "$before" --images 2000 --set mapping.negative=differential --set device.model=$m \
        --set device.compensation=$c --set "device.time_s=$times"
    fi
  done
done
# NeuRRAM's precisions with ideal devices, 10 000 images.
ev neurram_ideal_10k "$X" --config configs/neurram.yaml --set device.model=ideal
# ISAAC's cell precisions under rram-wan2022 at one day, 500 images, each with 8-bit ADCs.
ev isaac_rram_1day "$X" --config configs/isaac.yaml --images 500 --set architecture.machine=layer-sized \
  --set device.model=rram-wan2022 --set device.time_s=86400 --set device.compensation=column \
  --set "crossbar.cell_bits=[1,2,4]" --set converters.adc_bits=8 --set "device.seed=[11,12,13]"
