#!/usr/bin/env bash
# Batched nonlinear solver vs the per-vector Newton (the reference), side by side in one run.
# 144x64 crossbar, sinh (k = 5) memristors + level-1 transistors, 1024 input vectors with half
# the inputs at 0 V. Each solver runs RUNS times, alternating; the ratio is of the medians of
# the in-process solve times. A second binary (e.g. an older build) can be the reference:
# Usage: bench/bench_nonlinear.sh [build-dir] [threads] [reference-binary]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
THREADS=${2:-2}
X="$BUILD/sw/xbarsim"
REF=${3:-$X}
RUNS=${RUNS:-3}
M=144 N=64 V=${VECTORS:-1024}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
awk -v m=$M -v n=$N 'BEGIN{srand(5); for(i=0;i<m;i++){l=""; for(j=0;j<n;j++) l=l (j?",":"") (1/300e3+rand()*(1/15e3-1/300e3)); print l}}' >"$TMP/g.csv"
awk -v m=$M -v v=$V 'BEGIN{srand(6); for(k=0;k<v;k++){l=""; for(i=0;i<m;i++) l=l (i?",":"") (rand()<0.5?0:0.4*rand()); print l}}' >"$TMP/v.csv"
SETS=(--set crossbar.memristor.model=sinh --set crossbar.memristor.k=5 --set crossbar.transistor.model=level1
      --set solver.threads="$THREADS")
solve_ms() {  # binary, output, extra args: the in-process solve time (ms) from --json
  local bin=$1 out=$2; shift 2
  "$bin" solve --conductances "$TMP/g.csv" --inputs "$TMP/v.csv" --out "$out" --json "$TMP/r.json" "${SETS[@]}" "$@" \
    2>/dev/null
  grep -o '"wall_time_ms": [0-9.e+-]*' "$TMP/r.json" | awk '{print $2}'
}
median() { sort -g | awk '{a[NR]=$1} END{print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
: >"$TMP/batched" ; : >"$TMP/newton"
for ((r = 0; r < RUNS; r++)); do
  solve_ms "$X" "$TMP/b.csv" >>"$TMP/batched"
  if [ "$REF" = "$X" ]; then solve_ms "$REF" "$TMP/n.csv" --set solver.nonlinear=newton >>"$TMP/newton"
  else solve_ms "$REF" "$TMP/n.csv" >>"$TMP/newton"; fi
done
b=$(median <"$TMP/batched") n=$(median <"$TMP/newton")
diff=$(awk -F, 'NR==FNR{for(j=1;j<=NF;j++) r[FNR,j]=$j; next}
  {mx=0; for(j=1;j<=NF;j++){a=r[FNR,j]<0?-r[FNR,j]:r[FNR,j]; if(a>mx)mx=a}
   for(j=1;j<=NF;j++){d=$j-r[FNR,j]; if(d<0)d=-d; if(mx>0 && d/mx>w)w=d/mx}} END{printf "%.2e", w}' "$TMP/n.csv" "$TMP/b.csv")
printf "%dx%d sinh(k=5)+level1, %d vectors, %s thread(s), %d runs each (medians of in-process solve time)\n" \
  $M $N $V "$THREADS" "$RUNS"
printf "per-vector Newton (%s): %10.1f ms  %8.3f ms/vector\n" "$REF" "$n" "$(echo "$n / $V" | bc -l)"
printf "batched Newton    (%s): %10.1f ms  %8.3f ms/vector\n" "$X" "$b" "$(echo "$b / $V" | bc -l)"
printf "speed-up %.1fx; largest column-current difference %s of the vector's largest current\n" \
  "$(echo "$n / $b" | bc -l)" "$diff"
