#!/usr/bin/env bash
# Installs what is needed, builds, and runs xbarsim's main job on the default configuration.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build
exec scripts/main_job.sh "$@"
