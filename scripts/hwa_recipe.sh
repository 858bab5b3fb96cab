#!/bin/bash
# Issue 51's rows (docs/results.md, "Training recipes"): ResNet-20 trained by `python3 -m xbarsim.hwa`
# with each recipe on the 20 000 shared training images (2000 of them held out for model
# selection), then evaluated by `xbarsim eval` on all 10 000 test images over three device seeds.
# Resumable: a finished model or result made with the same arguments is kept, an interrupted
# training goes on from its checkpoint. About 110 minutes on 2 cores alone, as measured by parts:
# training 43 min (NeuRRAM 1392 s, PCM 596 s, rram 573 s), then 66 evaluations of 10 000 images
# at about a minute each.
# Usage: scripts/hwa_recipe.sh OUT_DIR [BUILD_DIR (build)] [DATA_DIR (../shared/data)] [IMAGES (10000)]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:?usage: scripts/hwa_recipe.sh OUT_DIR [BUILD_DIR] [DATA_DIR] [IMAGES]}
build=$(cd "${2:-$root/build}" && pwd)
data=$(cd "${3:-$root/../shared/data}" && pwd)
images=${4:-10000}
mkdir -p "$out/train"
for f in data_batch_1.bin data_batch_2.bin calib_batch.bin; do
  [ -e "$out/train/$f" ] || ln -s "$data/cifar10/$f" "$out/train/$f"
done
cd "$root"
X=$build/sw/xbarsim
original=$data/../models/resnet20_cifar10.onnx
[ -f "$original" ] || original=$root/../shared/models/resnet20_cifar10.onnx
# A finished model or result is kept only when it was made with the same arguments ($out/NAME.args):
# a changed recipe, configuration or script makes it again instead of reporting the old one.
made() {  # file name args...: true when $file exists and $out/$name.args holds these arguments
  local file=$1 name=$2; shift 2
  [ -f "$file" ] && [ -f "$out/$name.args" ] && [ "$(cat "$out/$name.args")" = "$*" ]
}
train() {  # name args...: the model $out/$name.onnx
  local name=$1; shift
  made "$out/$name.onnx" "$name" "$original" "$@" && { echo "$name trained"; return; }
  local resume=()
  [ -f "$out/$name.onnx.ckpt" ] && resume=(--resume)
  local t0=$SECONDS
  PYTHONPATH=$build/python /usr/bin/python3 -m xbarsim.hwa --model "$original" --train "$out/train" \
    --out "$out/$name.onnx" "${resume[@]}" "$@" 2> >(tee -a "$out/$name.train.log" >&2)
  echo "$original $*" > "$out/$name.args"
  echo "$name: $((SECONDS - t0)) s of training" | tee -a "$out/times.txt"
}
ev() {  # tag model args...
  local tag=$1 model=$2; shift 2
  # (and only when newer than its model: a model trained again is evaluated again)
  if ! { made "$out/$tag.json" "$tag" "$model" "$images" "$@" && [ "$out/$tag.json" -nt "$model" ]; }; then
    "$X" eval --model "$model" --images "$images" --json "$out/$tag.json.tmp" "$@" \
    > "$out/$tag.txt" 2> "$out/$tag.err"
    mv "$out/$tag.json.tmp" "$out/$tag.json"
    echo "$model $images $*" > "$out/$tag.args"
  fi
  echo "$tag done"
}
times='[1,3600,86400,2592000,31536000]'
seeds='[11,12,13]'
neurram=(--config configs/neurram.yaml --set device.model=rram-wan2022 --set device.time_s=1)
pcm=(--set device.model=pcm-joshi2020 --set device.compensation=global)
rram=(--set device.model=rram-wan2022 --set device.compensation=recalibrate)
# Each training is resumable; NeuRRAM's rows first, precisions under rram-wan2022 at 1 s.
train neurram --recipe neurram "${neurram[@]}"
ev neurram_trained "$out/neurram.onnx" "${neurram[@]}" --set "device.seed=$seeds"
ev neurram_original "$original" "${neurram[@]}" --set "device.seed=$seeds"
train pcm --recipe pcm-joshi2020 "${pcm[@]}"
# rram-wan2022 with recalibration at the read time (issue 50's best at a day): the PCM recipe with
# the times drawn over 1 s .. 1 day, the user's settings over a recipe. Training draws a
# recalibration as the column gain plus its own calibration fit: the same model as column.
train rram --recipe pcm-joshi2020 --time 1,86400 "${rram[@]}"
# Over time (programmed once per seed, read at each time), trained and untrained side by side.
for dev in pcm rram; do
  declare -n keys=$dev
  ev "${dev}_trained" "$out/$dev.onnx" "${keys[@]}" --set "device.time_s=$times" --set "device.seed=$seeds"
  ev "${dev}_original" "$original" "${keys[@]}" --set "device.time_s=$times" --set "device.seed=$seeds"
done
