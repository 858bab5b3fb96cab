#!/usr/bin/env bash
# The default main job: the paper's largest crossbar (576 x 64, paper parameters) solved
# with the full parasitic circuit for 10 random input vectors (50 % sparse, 0..0.4 V).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${XBARSIM_OUT:-out}
mkdir -p "$OUT"
awk -v m=576 -v n=64 'BEGIN{srand(1); for(i=0;i<m;i++){l=""; for(j=0;j<n;j++) l=l (j?",":"") (1/300e3+rand()*(1/15e3-1/300e3)); print l}}' > "$OUT/g576x64.csv"
awk -v m=576 -v k=10 'BEGIN{srand(2); for(a=0;a<k;a++){l=""; for(i=0;i<m;i++) l=l (i?",":"") (rand()<0.5?0:0.4*rand()); print l}}' > "$OUT/v576.csv"
build/sw/xbarsim solve --conductances "$OUT/g576x64.csv" --inputs "$OUT/v576.csv" --out "$OUT/i576x64.csv" "$@"
echo "column currents written to $OUT/i576x64.csv"
