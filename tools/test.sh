#!/usr/bin/env bash
# The README's second command (and CI's): installs what is missing, builds with warnings as errors, runs the
# default test suite, then builds and runs it again under AddressSanitizer + UndefinedBehaviorSanitizer, then
# compiles the OpenMP-offload configuration (GCC nvptx; compile only: no GPU here) when its toolchain installs.
# The real-Slurm sweep test (ctest label 'slurm') runs after the default suite. Long validation runs are not part
# of this: ctest --preset validation (docs/validation.md).
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/deps.sh
capsflow_ensure_deps
jobs=$(nproc)

echo "== build (warnings are errors) and default tests"
cmake --preset ci >/dev/null
cmake --build --preset ci -j "$jobs"
ctest --preset ci

echo "== capsflow sweep under a real single-node Slurm (installs slurm-wlm, munge, hdf5-tools; ~40 s)"
ctest --preset slurm

echo "== AddressSanitizer + UndefinedBehaviorSanitizer"
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --preset asan

echo "== device backend (OpenMP offload to nvptx), compile only"
if [ "${CAPSFLOW_SKIP_OFFLOAD:-0}" != 1 ] && capsflow_install gcc-12-offload-nvptx; then
  cmake --preset offload-gcc -DCAPSFLOW_TESTS=OFF -DCAPSFLOW_BENCHMARKS=OFF >/dev/null
  cmake --build --preset offload-gcc -j "$jobs"
  echo "offload build compiled: build/offload-gcc/capsflow"
else
  echo "offload toolchain not installable here: skipped"
fi
