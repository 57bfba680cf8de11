#!/usr/bin/env bash
# The README's first command: installs what is missing, builds capsflow (release) and runs the built-in demo.
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/deps.sh
capsflow_ensure_deps
cmake --preset release >/dev/null
cmake --build --preset release --target capsflow -j "$(nproc)"
./build/release/capsflow demo --out "${CAPSFLOW_DEMO_DIR:-capsflow-demo}" --force
