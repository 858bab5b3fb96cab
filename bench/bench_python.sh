#!/usr/bin/env bash
# The Python package's overhead, side by side in one run: Crossbar.matvec on a 576 x 64
# crossbar (default design, 1024 vectors, double) from Python against the same AnalogLayer
# forward in C++ (bench_analog_layer's matvec_576x64). Each side's best of ROUNDS; prints
# microseconds per vector and the ratio Python / C++. Usage: bench/bench_python.sh [build-dir] [rounds]
set -euo pipefail
cd "$(dirname "$0")/.."
B=$(cd "${1:-build}" && pwd); R=${2:-10}
cxx=$("$B/bench/bench_analog_layer" --benchmark_filter=matvec_576x64 --benchmark_repetitions="$R" \
        --benchmark_report_aggregates_only=true --benchmark_format=json |
      /usr/bin/python3 -c 'import json,sys; b=[x for x in json.load(sys.stdin)["benchmarks"] if x.get("aggregate_name")=="min"][0]; print(b["real_time"] * {"ms":1e3,"us":1,"ns":1e-3}[b["time_unit"]] / 1024)')
py=$(PYTHONPATH="$B/python" /usr/bin/python3 - "$R" <<'PY'
import sys, time
import numpy as np
import xbarsim
rounds = int(sys.argv[1])
rng = np.random.default_rng(5)
w = rng.normal(size=(576, 64))
x = np.where(rng.random((1024, 576)) < 0.5, 0.0, np.minimum(1.0, rng.exponential(1 / 8, size=(1024, 576))))
cfg = xbarsim.Config(overrides={"mitigation.method": "calibration", "solver.threads": 1})  # one core, as the C++ side
xb = xbarsim.Crossbar(w, cfg, calibration=x[:512])
best = float("inf")
for _ in range(rounds):
    t = time.perf_counter()
    xb.matvec(x)
    best = min(best, time.perf_counter() - t)
print(best * 1e6 / 1024)
PY
)
printf "C++ forward:           %8.3f us/vector\nPython Crossbar.matvec: %8.3f us/vector\nratio Python / C++:     %8.3f\n" \
  "$cxx" "$py" "$(echo "$py / $cxx" | bc -l)"
