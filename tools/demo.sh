#!/usr/bin/env bash
# The README's first command: installs what is missing, builds capsflow (release) and runs `capsflow run` without a
# configuration: the embedded demo (8 capsules of two species in pressure-driven flow, a few minutes on 2 cores).
# Its files go to capsflow-run-demo/ (HDF5 series and frames, ParaView index, checkpoint); then `capsflow analyze`
# and `capsflow figures` turn them into capsflow-run-demo/analysis/ and capsflow-run-demo/figures/ (the run's
# diagnostics, demo_run_diagnostics.png, and the snapshot of its last frame, fig02_snapshots.png: the study's other
# figures need the sweeps' many capsules and strain, docs/reproduction.md); last `capsflow render` draws the
# suspension from the side with ParaView (capsflow-run-demo/pictures/demo_species_f0080.png, and demo_species.mp4, a
# movie of the run, where ffmpeg is installed; demo_species.pvsm opens the same view in ParaView's GUI). It ends with
# what the run printed at its end: each species' mean distance from the centreline, which one sits nearer the walls,
# and where the three pictures are (kept in capsflow-run-demo/what_to_look_at.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/deps.sh
capsflow_ensure_deps
cmake --preset release >/dev/null
cmake --build --preset release --target capsflow -j "$(nproc)"
mkdir -p capsflow-run-demo
./build/release/capsflow run --force | tee capsflow-run-demo/what_to_look_at.txt
./build/release/capsflow analyze capsflow-run-demo/demo.h5 --out capsflow-run-demo/analysis --force
./build/release/capsflow figures capsflow-run-demo/analysis capsflow-run-demo/demo.h5 --out capsflow-run-demo/figures \
  --only fig02_snapshots --force
movie=()
command -v ffmpeg >/dev/null && movie=(--movie)
./build/release/capsflow render capsflow-run-demo/demo.h5 --out capsflow-run-demo/pictures --force "${movie[@]}"
cat capsflow-run-demo/what_to_look_at.txt
