#!/bin/bash
# ResNet-20 at NeuRRAM's precisions (configs/neurram.yaml: 4-bit weights on differential pairs,
# 3-bit activations, 5-bit outputs, rram-wan2022 at 1 s) on the full CIFAR-10 test set, the
# shared model and its hardware-aware fine-tunes, and what separates them from the chip
# (docs/results.md, "NeuRRAM: ResNet-20's accuracy"). Resumable: a finished result is kept.
# Usage: scripts/neurram_accuracy.sh OUT_DIR [BUILD_DIR (build)] [DATA_DIR (../shared/data)]
# About 25 minutes on one core (solver.threads=1, --threads 1).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: scripts/neurram_accuracy.sh OUT_DIR [BUILD_DIR] [DATA_DIR]}
build=$(cd "${2:-$root/build}" && pwd)
data=$(cd "${3:-$root/../shared/data}" && pwd)
mkdir -p "$out/train"
cd "$out"
for f in data_batch_1.bin data_batch_2.bin calib_batch.bin; do ln -sf "$data/cifar10/$f" train/$f; done
export PYTHONPATH=$build/python XBARSIM_BINARY=$build/sw/xbarsim XBARSIM_DATA_DIR=$data
C=$root/configs/neurram.yaml
# The rows were measured before converters.image_bits: every layer, the image too, at 3 bits.
I=(--set converters.image_bits=none)
ev() {
  local tag=$1; shift
  [ -f $tag.json ] || "$build/sw/xbarsim" eval --dataset cifar10 --config "$C" --set solver.threads=1 "${I[@]}" \
    --json $tag.json.tmp "$@" > $tag.txt 2> $tag.err && mv $tag.json.tmp $tag.json
  printf '%-22s %s\n' "$tag" "$(sed -n 2p $tag.txt)"
}
hwa() {
  local name=$1 epochs=$2
  [ -f $name.onnx ] || /usr/bin/python3 -m xbarsim.hwa --model "$data/../models/resnet20_cifar10.onnx" --train train \
    --epochs $epochs --config "$C" "${I[@]}" --threads 1 --out $name.onnx > $name.train.txt 2> $name.train.err
}
ev original --model resnet20_cifar10
hwa hwa1 1
ev hwa1 --model hwa1.onnx
hwa hwa3 3
ev hwa3 --model hwa3.onnx
# What separates them: the devices ideal; then the wires too (quantization alone); 8-bit
# outputs; 8-bit inputs (10-bit outputs); 8-bit weights (a layer-sized design: the machine's
# cells hold 3 bits).
ev original_ideal_devices --model resnet20_cifar10 --set device.model=ideal
ev hwa1_ideal_devices --model hwa1.onnx --set device.model=ideal
ev original_quantization_only --model resnet20_cifar10 --set device.model=ideal \
  --set crossbar.r_wire=1e-6 --set crossbar.r_in=1e-6 --set crossbar.r_out=1e-6
ev original_adc8 --model resnet20_cifar10 --set converters.adc_bits=8
ev original_inputs8 --model resnet20_cifar10 --set converters.input_bits=8 --set converters.dac_bits=8 \
  --set converters.adc_bits=10
ev original_weights8 --model resnet20_cifar10 --set architecture.machine=layer-sized \
  --set components.library=isaac_paper --set mapping.weight_bits=8 --set crossbar.cell_bits=7
