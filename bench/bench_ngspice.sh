#!/usr/bin/env bash
# xbarsim vs ngspice on the same netlists, measured side by side in one run.
# Usage: bench/bench_ngspice.sh [build-dir]   Prints wall times and the speed ratio.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
X="$BUILD/sw/xbarsim"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
now() { date +%s.%N; }
printf "%-22s %12s %14s %14s %10s %14s\n" case "ngspice_s" "xbarsim_proc_s" "xbarsim_solve_s" ratio "max_rel_diff"
for spec in "128 64 linear" "128 64 nonlinear" "32 32 linear"; do
  read -r M N KIND <<<"$spec"
  SETS=()
  [ "$KIND" = nonlinear ] && SETS=(--set crossbar.memristor.model=sinh --set crossbar.transistor.model=level1)
  awk -v m="$M" -v n="$N" 'BEGIN{srand(5); for(i=0;i<m;i++){l=""; for(j=0;j<n;j++) l=l (j?",":"") (1/300e3+rand()*(1/15e3-1/300e3)); print l}}' >"$TMP/g.csv"
  awk -v m="$M" 'BEGIN{srand(6); l=""; for(i=0;i<m;i++) l=l (i?",":"") (0.4*rand()); print l}' >"$TMP/v.csv"
  "$X" netlist --conductances "$TMP/g.csv" --inputs "$TMP/v.csv" --out "$TMP/net.cir" "${SETS[@]}"
  t0=$(now); ngspice -b "$TMP/net.cir" >"$TMP/ng.out" 2>&1 || true; t1=$(now)  # ngspice -b exits 1 after .control runs
  "$X" solve --conductances "$TMP/g.csv" --inputs "$TMP/v.csv" --out "$TMP/i.csv" --json "$TMP/r.json" "${SETS[@]}" 2>/dev/null
  t2=$(now)
  solve_ms=$(grep -o '"wall_time_ms": [0-9.e+-]*' "$TMP/r.json" | awk '{print $2}')
  # ngspice prints i(vsense_j) = value after the echo marker.
  diff=$(awk -F'[ =]+' -v n="$N" 'NR==FNR{c=split($0,a,","); for(j=1;j<=c;j++) x[j-1]=a[j]; next}
          /^i\(vsense_/{s=$1; gsub(/i\(vsense_|\)/,"",s); v=$2; d=(x[s]-v)/v; if(d<0)d=-d; if(d>w)w=d}
          END{printf "%.2e", w}' "$TMP/i.csv" "$TMP/ng.out")
  ng=$(echo "$t1 - $t0" | bc -l); px=$(echo "$t2 - $t1" | bc -l); sv=$(echo "$solve_ms / 1000" | bc -l)
  printf "%-22s %12.3f %14.4f %14.5f %9.0fx %14s\n" "${M}x${N} $KIND" "$ng" "$px" "$sv" "$(echo "$ng / $sv" | bc -l)" "$diff"
done
echo "ratio = ngspice wall time / xbarsim in-process solve time (program + solve, nothing reused)."
