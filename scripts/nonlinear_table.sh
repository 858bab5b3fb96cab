#!/usr/bin/env bash
# ResNet-20 on CIFAR-10 with nonlinear devices (sinh memristors + level-1 access transistors,
# the default design otherwise): accuracy against software and per-layer error for
# k in $KS under
#   cc  conversion+calibration (the default mitigation),
#   pd  + DAC pre-distortion,
#   df  + pre-distortion and differential mapping (mapping.negative: differential).
# One eval per cell, each writing DIR/<cfg>-k<k>.{json,csv,txt}; a cell whose JSON exists is
# skipped, and a cell cut short resumes from its journal (DIR/<cfg>-k<k>.jsonl, every finished
# image), so a killed run loses about a second. At ~0.85 images/s on 2 cores (differential 0.44) a
# full-test-set cell takes ~3.3 h (differential ~6.3 h, as measured): use a cluster, e.g. MPIRUN="mpirun -n 64" with
# XBARSIM_SET="--set solver.threads=1", or a subset of images (the table's 95 % interval of
# the drop says what a subset can tell).
# `table` instead of a number prints the table of what DIR holds without running anything; a
# cell still running or cut short is shown from its journal, marked "(partial)"; only the lines
# of the journal's last run count (its key: the configuration, model and dataset).
# Usage: scripts/nonlinear_table.sh [images|all|table] [out-dir]   (env: KS, CFGS, MPIRUN, XBARSIM_SET)
set -euo pipefail
usage() { sed -n '2,/^# Usage/s/^# \{0,1\}//p' "$0"; }
case "${1:-all}" in
  -h | --help | help) usage; exit 0 ;;
  all | table) ;;
  *[!0-9]* | 0*) echo "nonlinear_table.sh: '$1' is not a number of images, all or table" >&2; usage >&2; exit 2 ;;
esac
cd "$(dirname "$0")/.."
IMAGES=${1:-all}
DIR=${2:-out/nonlinear}
if [ "$IMAGES" = table ] && [ ! -d "$DIR" ]; then
  echo "nonlinear_table.sh: no directory $DIR to make a table of" >&2
  exit 2
fi
KS=${KS:-"1 2 3 5"}
CFGS=${CFGS:-"cc pd df"}
X=${XBARSIM:-build/sw/xbarsim}
mkdir -p "$DIR"
declare -A EXTRA=([cc]="" [pd]="--set converters.dac_predistortion=true"
                  [df]="--set converters.dac_predistortion=true --set mapping.negative=differential")
declare -A NAME=([cc]="conv+cal" [pd]="+ pre-distortion" [df]="+ pre-distortion, differential")
for cfg in $CFGS; do
  for k in $KS; do
    base="$DIR/$cfg-k$k"
    [ "$IMAGES" = table ] || [ -s "$base.json" ] && continue
    echo "nonlinear table: $cfg k=$k ($IMAGES images)" >&2
    # shellcheck disable=SC2086  # word splitting of the option lists is intended
    ${MPIRUN:-} "$X" eval --model resnet20_cifar10 --images "$IMAGES" --set crossbar.memristor.model=sinh \
      --set crossbar.transistor.model=level1 --set crossbar.memristor.k="$k" ${EXTRA[$cfg]} ${XBARSIM_SET:-} \
      --journal "$base.jsonl" --json "$base.json.part" --csv "$base.csv" >"$base.txt"
    mv "$base.json.part" "$base.json"
  done
done
printf '| mitigation | k (1/V) | images | software %% | crossbars %% | drop (points) | 95 %% interval | mean layer error %% |\n'
printf '|---|---|---|---|---|---|---|---|\n'
for cfg in $CFGS; do
  for k in $KS; do
    base="$DIR/$cfg-k$k"
    if [ ! -s "$base.json" ] && [ -s "$base.jsonl" ]; then
      # From the journal: one line per finished image ("sw"/"xb": correct or not), the interval
      # as eval computes it (Agresti-Min: 0.5 added to each cell of the paired table).
      # The last run's key (from the last line that has one: a kill can cut the very last).
      key=$(grep -o '"key":"[^"]*"' "$base.jsonl" | tail -n 1 || true)
      if [ -z "$key" ]; then
        echo "${NAME[$cfg]} k=$k: $base.jsonl has no journal line; left out" >&2
        continue
      fi
      awk '{ if (!index($0, key)) { other++; next } if (!match($0, /"image":[0-9]+/)) next; im = substr($0, RSTART + 8, RLENGTH - 8); if (im in seen) next
             seen[im] = 1; n++; s = ($0 ~ /"sw":1/); x = ($0 ~ /"xb":1/); sw += s; xb += x; b += s && !x; c += x && !s }
           END { if (other) printf "%s k=%s: %d journal lines of other runs left out\n", name, k, other > "/dev/stderr"
                 if (!n) exit; N = n + 2; bb = b + 0.5; cc = c + 0.5; d = (bb - cc) / N
                 v = (bb + cc) - (bb - cc) ^ 2 / N; h = 1.959963984540054 * sqrt(v > 0 ? v : 0) / N
                 lo = d - h < -1 ? -1 : d - h; hi = d + h > 1 ? 1 : d + h
                 printf "| %s | %s | %d (partial) | %.2f | %.2f | %.2f | %+.2f..%+.2f | - |\n", name, k, n, 100 * sw / n,
                   100 * xb / n, 100 * (b - c) / n, 100 * lo, 100 * hi }' name="${NAME[$cfg]}" k="$k" key="$key" "$base.jsonl"
      continue
    fi
    [ -s "$base.json" ] || continue
    # The run's row of eval's table: run images software crossbar drop interval ... (fractions), in %.
    read -r _ n sw xb drop ci _ < <(grep -m1 '^default' "$base.txt")
    read -r sw xb drop ci < <(awk -v a="$sw" -v b="$xb" -v d="$drop" -v c="$ci" 'BEGIN {
      split(c, r, /\.\./); printf "%.2f %.2f %.2f %+.2f..%+.2f\n", 100 * a, 100 * b, 100 * d, 100 * r[1], 100 * r[2] }')
    mean=$(awk -F, 'NR > 1 {s += $(NF - 1); c++} END {if (c) printf "%.2f", 100 * s / c}' "$base.csv")
    printf '| %s | %s | %s | %s | %s | %s | %s | %s |\n' "${NAME[$cfg]}" "$k" "$n" "$sw" "$xb" "$drop" "$ci" "$mean"
  done
done
