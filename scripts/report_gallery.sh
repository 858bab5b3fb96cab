#!/usr/bin/env bash
# The three HTML reports a reader meets, rendered as a reader sees them: an exploration of 16
# ResNet-20 designs, a simulate sweep of 4 points (dense/sparse x sequential/pipelined) and an
# eval, each with --report, then a headless-Chromium screenshot of each at 1400 px width.
# Needs the shared data and chromium. Usage: scripts/report_gallery.sh [out-dir] [images]
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=$(mkdir -p "${1:-out/gallery}" && cd "${1:-out/gallery}" && pwd)
N=${2:-200}
X=build/sw/xbarsim
cat > "$OUT/space.yaml" <<YAML
explore:
  model: resnet20_cifar10
  objectives: "accuracy,energy,area,latency"
  color_by: converters.adc_bits
mapping:
  max_rows: [72, 144]
  g_headroom: [0.1, 0.2]
converters:
  adc_bits: [6, 8]
mitigation:
  method: [calibration, conversion+calibration]
eval:
  images: $N
YAML
rm -f "$OUT/space.jsonl"
"$X" explore --config "$OUT/space.yaml" --out "$OUT/space.jsonl" --report "$OUT/explore.html" > "$OUT/explore.txt"
"$X" simulate --model resnet20_cifar10 --dataset cifar10 --images 10 --set 'mapping.scheme=[dense, sparse]' \
  --set 'platform.schedule=[sequential, pipelined]' --csv "$OUT/simulate.csv" --report "$OUT/simulate.html" > "$OUT/simulate.txt"
"$X" eval --model resnet20_cifar10 --images "$N" --csv "$OUT/eval.csv" --report "$OUT/eval.html" > "$OUT/eval.txt"
B=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$B" ]; then echo "chromium not found: reports in $OUT, no screenshots"; exit 0; fi
for r in explore simulate eval; do
  "$B" --headless=new --no-sandbox --disable-gpu --hide-scrollbars --window-size=1400,6000 \
    --screenshot="$OUT/$r.png" "file://$OUT/$r.html" 2>/dev/null
  echo "$OUT/$r.html -> $OUT/$r.png"
done
