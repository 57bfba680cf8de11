#!/usr/bin/env bash
# The README's second command (and CI's): installs what is missing, builds with warnings as errors, runs the
# default test suite, then builds and runs it again under AddressSanitizer + UndefinedBehaviorSanitizer, then
# builds the OpenMP-offload configuration (GCC nvptx) with its tests and runs the backend tests, device included, on
# the host fallback when its toolchain installs (no GPU here; docs/device.md), then the clang 19 build for NVIDIA GPUs
# (offload-clang: the GPU check's programs and their device code), and last the device tests on LLVM's host offload
# device (clang 19), where mapped arrays are copies. The real-Slurm sweep test (ctest label
# 'slurm') runs after the default suite. Long validation runs are not part of this: ctest --preset validation
# (docs/validation.md).
set -euo pipefail
cd "$(dirname "$0")/.."
source tools/deps.sh
capsflow_ensure_deps
jobs=$(nproc)
# The render test (tests/python/test_render.py) fails instead of skipping when pvbatch, ffmpeg or xvfb-run is missing:
# deps.sh has just installed them, so a skip here would hide a broken render path.
export CAPSFLOW_REQUIRE_RENDER=1

echo "== build (warnings are errors) and default tests"
cmake --preset ci >/dev/null
cmake --build --preset ci -j "$jobs"
ctest --preset ci

echo "== Debian package (cpack -G DEB) of the ci build: its contents"
# The install layout itself is checked by ctest (python_install: cmake --install into a temporary prefix, then the
# installed capsflow runs, draws and is read back).
(cd build/ci && rm -f capsflow_*.deb && cpack -G DEB >/dev/null)
deb=$(ls build/ci/capsflow_*.deb)
contents=$(dpkg-deb --contents "$deb")
for f in ./usr/bin/capsflow ./usr/share/capsflow/capsflow_figures.py ./usr/share/capsflow/capsflow_render.py \
         ./usr/share/capsflow/docs/usage.md ./usr/share/capsflow/LICENSE ./usr/share/capsflow/CITATION.cff \
         ./usr/share/doc/capsflow/copyright \
         ./usr/share/capsflow/examples/presets/set_a.toml; do
  grep -q " $f\$" <<<"$contents" || { echo "$deb lacks $f"; exit 1; }
done
grep -q "/dist-packages/capsflow/__init__.py\$" <<<"$contents" || { echo "$deb lacks the Python package"; exit 1; }
dpkg-deb --field "$deb" Package Version Depends
echo "$deb: ok"

echo "== capsflow sweep under a real single-node Slurm (installs slurm-wlm, munge, hdf5-tools; ~40 s)"
ctest --preset slurm

echo "== AddressSanitizer + UndefinedBehaviorSanitizer"
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --preset asan

echo "== device backend (OpenMP offload to nvptx): build with tests and benchmarks, backend tests on the host fallback"
# No GPU here: ctest sets CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1, so the device tests run their target regions on the
# OpenMP runtime's host fallback (arithmetic and control flow checked; data movement needs a GPU: tools/device-check.sh).
# The backend-sensitive tests only: the rest of the suite is the host code the ci build has just run.
if [ "${CAPSFLOW_SKIP_OFFLOAD:-0}" != 1 ] && capsflow_install gcc-12-offload-nvptx; then
  cmake --preset offload-gcc >/dev/null
  cmake --build --preset offload-gcc -j "$jobs"
  ctest --test-dir build/offload-gcc -j "$jobs" --output-on-failure \
    -R '/(serial|threads|device)( |$)|KernelDispatch|DeviceAvailability|DeviceBackend|Cli[.]InfoListsBackends|DeviceCode[.]'
else
  echo "offload toolchain not installable here: skipped"
fi

echo "== device backend for NVIDIA GPUs with clang 19 (offload-clang): the GPU check's programs, and their device code"
# The clang build a GPU runs (cubins for sm_80 and sm_90 made at build time), here without a GPU: capsflow (the whole
# core library) and two device suites, then tools/check_device_code.py (label device-code): every unit with a target
# region compiled for the device, no fused multiply-add in the cell lists' regions. tools/device-check.sh pack builds
# the rest of what it carries. Needs CUDA's ptxas and libdevice (/usr/local/cuda); skipped with a line without them.
if [ "${CAPSFLOW_SKIP_OFFLOAD:-0}" != 1 ] && [ -x /usr/local/cuda/bin/ptxas ] &&
   capsflow_install clang-19 clang-tools-19 libomp-19-dev; then
  cmake --preset offload-clang >/dev/null
  cmake --build --preset offload-clang -j "$jobs" --target capsflow test_device_cells test_local_single_layer
  ctest --test-dir build/offload-clang --output-on-failure -L device-code
else
  echo "offload-clang: skipped (no CUDA toolkit at /usr/local/cuda, or clang 19 not installable here)"
fi

echo "== device backend on LLVM's host offload device (clang 19): the device tests with data movement"
# The host fallback above shares the host's arrays; this device copies every mapped array, so a missing map or
# target update fails here as it would on a GPU (docs/device.md, "The host-memory test device"). The tests whose
# name ends in /device (about 25 s).
if [ "${CAPSFLOW_SKIP_OFFLOAD:-0}" != 1 ] && capsflow_install clang-19 clang-tools-19 libomp-19-dev; then
  cmake --preset offload-host >/dev/null
  # The suites that can hold device instances only (every other suite is host code the ci build ran): those that
  # name the device backend or the backend harness, found by their text; and capsflow, which tests run.
  mapfile -t device_suites < <(grep -l -E 'OnEachBackend|Backend::Device|kEveryBackend|kParallelBackends|_BACKENDS\(' \
                               tests/test_*.cpp | xargs -n1 basename | sed 's/[.]cpp$//')
  cmake --build --preset offload-host -j "$jobs" --target capsflow "${device_suites[@]}"
  ctest --preset offload-host
else
  echo "clang 19 offload toolchain not installable here: skipped"
fi
