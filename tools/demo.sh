#!/usr/bin/env bash
# The README's first command: installs what is missing, builds capsflow (release) and runs `capsflow run` without a
# configuration: the embedded demo (8 capsules of two species in pressure-driven flow, a few minutes on 2 cores).
# Its files go to capsflow-run-demo/ (HDF5 series and frames, ParaView index, trajectory plot, checkpoint).
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/deps.sh
capsflow_ensure_deps
cmake --preset release >/dev/null
cmake --build --preset release --target capsflow -j "$(nproc)"
./build/release/capsflow run --force
