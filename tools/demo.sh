#!/usr/bin/env bash
# The README's first command: installs what is missing, builds capsflow (release) and runs `capsflow run` without a
# configuration: the embedded demo (8 capsules of two species in pressure-driven flow, a few minutes on 2 cores).
# Its files go to capsflow-run-demo/ (HDF5 series and frames, ParaView index, checkpoint); then `capsflow analyze`
# and `capsflow figures` turn them into capsflow-run-demo/analysis/ and capsflow-run-demo/figures/ (the study's
# figures and the run's diagnostics, demo_run_diagnostics.png); last `capsflow render` draws the suspension in 3D
# with ParaView (capsflow-run-demo/pictures/demo_species_f0080.png, and demo_species.mp4, a movie of the run, where
# ffmpeg is installed; demo_species.pvsm opens the same view in ParaView's GUI).
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/deps.sh
capsflow_ensure_deps
cmake --preset release >/dev/null
cmake --build --preset release --target capsflow -j "$(nproc)"
./build/release/capsflow run --force
./build/release/capsflow analyze capsflow-run-demo/demo.h5 --out capsflow-run-demo/analysis --force
./build/release/capsflow figures capsflow-run-demo/analysis capsflow-run-demo/demo.h5 --out capsflow-run-demo/figures \
  --force
movie=()
command -v ffmpeg >/dev/null && movie=(--movie)
./build/release/capsflow render capsflow-run-demo/demo.h5 --out capsflow-run-demo/pictures --force "${movie[@]}"
