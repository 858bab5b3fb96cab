#!/usr/bin/env bash
# What realistic devices cost in evaluation speed and memory (issue 40), side by side in one run:
# ResNet-20 on CIFAR-10, the default design and the ISAAC-style one (configs/isaac.yaml), each
# noiseless (device.model: ideal) and under rram-wan2022 (programming error, relaxation, 1 % read
# noise on every read), alternated ROUNDS times on all threads. Prints each run's evaluation
# images/s (programming excluded) and peak memory, the median noisy / noiseless ratios, and the
# programming time of each point of a device.time_s sweep (the sweep programs once: the later
# points only move the crossbars in time).
# Usage: bench/bench_device_noise.sh [build-dir] [images] [rounds]
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build}; N=${2:-500}; R=${3:-3}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
X="$B/sw/xbarsim"
field() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); j=j[-1] if isinstance(j,list) else j; print(j[sys.argv[2]])" "$1" "$2"; }
run() {  # run NAME ARGS...: eval, then images/s and peak KB into $T/NAME.{rate,kb}
  local name=$1; shift
  /usr/bin/time -f %M -o "$T/$name.kb" "$X" eval --model resnet20_cifar10 --images "$N" "$@" --json "$T/$name.json" \
    >/dev/null 2>&1
  field "$T/$name.json" images_per_s >"$T/$name.rate"
}
median() { sort -g | awk '{a[NR]=$1} END {printf "%.3f", a[int((NR+1)/2)]}'; }
for design in default isaac; do
  cfg=(); [ "$design" = isaac ] && cfg=(--config configs/isaac.yaml)
  speed=(); mem=()
  for r in $(seq "$R"); do
    run ideal "${cfg[@]}"
    run noisy "${cfg[@]}" --set device.model=rram-wan2022
    a=$(cat "$T/ideal.rate"); b=$(cat "$T/noisy.rate"); ka=$(cat "$T/ideal.kb"); kb=$(cat "$T/noisy.kb")
    speed+=("$(echo "$b / $a" | bc -l)"); mem+=("$(echo "$kb / $ka" | bc -l)")
    printf "%-7s round %d: ideal %7.1f images/s %7d KB | rram-wan2022 %7.1f images/s %7d KB\n" "$design" "$r" "$a" "$ka" \
      "$b" "$kb"
  done
  printf "%-7s median rram-wan2022 / ideal: speed %s, peak memory %s\n" "$design" \
    "$(printf '%s\n' "${speed[@]}" | median)" "$(printf '%s\n' "${mem[@]}" | median)"
done
# A sweep over time programs once: the first point programs, the others move in time.
"$X" eval --model resnet20_cifar10 --images 50 --set device.model=pcm-joshi2020 \
  --set "device.time_s=[1,3600,86400,2.63e6,3.156e7]" --json "$T/sweep.json" >/dev/null 2>&1
python3 - "$T/sweep.json" <<'EOF'
import json, sys
runs = json.load(open(sys.argv[1]))
runs = runs if isinstance(runs, list) else [runs]
print("device.time_s sweep, programming time per point (s): " +
      ", ".join("%g s: %.2f" % (r["device_time_s"], r["program_time_s"]) for r in runs))
EOF
