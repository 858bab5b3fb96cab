#!/usr/bin/env bash
# Installs the Debian packages xbarsim needs (idempotent), then configures and builds it.
# Usage: scripts/setup.sh [build-dir]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${1:-build}
PACKAGES=(build-essential cmake pkg-config libeigen3-dev libyaml-cpp-dev libgtest-dev libbenchmark-dev
          libsystemc-dev nlohmann-json3-dev libonnx-dev libprotobuf-dev protobuf-compiler zlib1g-dev ngspice
          libopenmpi-dev openmpi-bin chromium python3-numpy python3-onnx python3-torch python3-torchvision
          pybind11-dev python3-dev python3-pytest)
# Open MPI: mpirun -n N shards explore/eval/xbar-study (the build works without it); chromium:
# the report's browser test; python3-torch/torchvision: the torchvision zoo test exports its
# networks with them; pybind11-dev, python3-dev: the Python package (build/python); python3-pytest:
# its tests; python3-onnx: xbarsim.hwa, xbarsim.nn and their tests read and write ONNX with it
# (each part is skipped with a message without its package).
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD_DIR" -j "$(nproc)"
