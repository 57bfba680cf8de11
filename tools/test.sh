#!/usr/bin/env bash
# The README's second command (and CI's): installs what is missing, builds with warnings as errors, runs the
# default test suite, the vector-sensitive suites once per host vector path the CPU has (tools/simd_paths.sh) and the
# reduced validations, then builds and runs the suite again under AddressSanitizer + UndefinedBehaviorSanitizer, then
# builds the OpenMP-offload configuration (GCC nvptx) with its backend suites and runs them, device included, on
# the host fallback when its toolchain installs (no GPU here; docs/device.md), then the clang 19 build for NVIDIA GPUs
# (offload-clang: the GPU check's programs and their device code), and last the device tests on LLVM's host offload
# device (clang 19), where mapped arrays are copies. The real-Slurm sweep test (ctest label
# 'slurm') runs after the default suite. The validations run reduced (ctest --preset validation-ci); the full runs
# are not part of this: ctest --preset validation (docs/validation.md).
set -euo pipefail
cd "$(dirname "$0")/.."
# Each stage's wall time, printed as it ends and together at the end: CI's limit is 90 minutes on 2 cores, and the
# stages are what a change of this script trades.
stage_name="" stage_start=$SECONDS stage_log=""
stage() {
  if [ -n "$stage_name" ]; then
    local t=$((SECONDS - stage_start))
    echo "-- $stage_name: $((t / 60)) min $((t % 60)) s"
    stage_log+=$(printf '%5d s  %s' "$t" "$stage_name")$'\n'
  fi
  stage_name=$1 stage_start=$SECONDS
  [ -n "$1" ] && echo "== $1"
  return 0
}
trap 'stage ""; printf "== stage times (total %d min)\n%s" $((SECONDS / 60)) "$stage_log"' EXIT
stage "Debian packages (tools/deps.sh)"
source tools/deps.sh
capsflow_ensure_deps
jobs=$(nproc)
# The render test (tests/python/test_render.py) fails instead of skipping when pvbatch, ffmpeg or xvfb-run is missing:
# deps.sh has just installed them, so a skip here would hide a broken render path.
export CAPSFLOW_REQUIRE_RENDER=1

# The test suites that can hold device instances (the device builds build only these and capsflow: every other suite
# is host code the ci build runs): those that name the device backend or the backend harness, found by their text,
# and test_cli (Cli.InfoListsBackends).
device_suites() {
  grep -l -E 'OnEachBackend|Backend::Device|kEveryBackend|kParallelBackends|_BACKENDS\(' tests/test_*.cpp |
    xargs -n1 basename | sed 's/[.]cpp$//'
  echo test_cli
}

stage "build (warnings are errors)"
cmake --preset ci >/dev/null
cmake --build --preset ci -j "$jobs"
stage "default tests"
ctest --preset ci

stage "the host's vector paths: the vector-sensitive suites once per path this CPU has (tools/simd_paths.sh)"
# One ctest run tests one path (the CPU's best, chosen once per process); this prints a count per path and fails when
# neither SIMD path ran.
tools/simd_paths.sh build/ci

stage "physics validations, reduced (ctest --preset validation-ci)"
# The reduced twins of the validation label (docs/validation.md, "Two layers of tests"): shear deformation, the
# small-deformation limit, rest and volume, migration, pair collisions, the stability probe confirmed by runs. The
# full runs (ctest --preset validation, hours) are run by hand before results are claimed.
ctest --preset validation-ci

stage "Debian package (cpack -G DEB) of the ci build: its contents"
# The install layout itself is checked by ctest (python_install: cmake --install into a temporary prefix, then the
# installed capsflow runs, draws and is read back).
(cd build/ci && rm -f capsflow_*.deb && cpack -G DEB >/dev/null)
deb=$(ls build/ci/capsflow_*.deb)
contents=$(dpkg-deb --contents "$deb")
for f in ./usr/bin/capsflow ./usr/share/capsflow/capsflow_figures.py ./usr/share/capsflow/capsflow_render.py \
         ./usr/share/capsflow/capsflow_flow.py ./usr/share/capsflow/capsflow_atomic.py \
         ./usr/share/capsflow/docs/usage.md ./usr/share/capsflow/LICENSE ./usr/share/capsflow/CITATION.cff \
         ./usr/share/doc/capsflow/copyright \
         ./usr/share/capsflow/examples/presets/set_a.toml; do
  grep -q " $f\$" <<<"$contents" || { echo "$deb lacks $f"; exit 1; }
done
grep -q "/dist-packages/capsflow/__init__.py\$" <<<"$contents" || { echo "$deb lacks the Python package"; exit 1; }
dpkg-deb --field "$deb" Package Version Depends
echo "$deb: ok"

stage "capsflow sweep under a real single-node Slurm (installs slurm-wlm, munge, hdf5-tools; ~40 s)"
ctest --preset slurm

stage "AddressSanitizer + UndefinedBehaviorSanitizer build"
# Without the validation programs (CAPSFLOW_VALIDATIONS=OFF) and benchmarks, which the asan test preset never runs;
# that preset leaves out the Python-only and packaging checks and python_render too (CMakePresets.json, README).
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$jobs"
stage "the default tests under AddressSanitizer + UndefinedBehaviorSanitizer"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --preset asan

stage "device backend (OpenMP offload to nvptx, GCC 12): the backend tests on the host fallback"
# No GPU here: ctest sets CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1, so the device tests run their target regions on the
# OpenMP runtime's host fallback (arithmetic and control flow checked; data movement needs a GPU: tools/device-check.sh).
# The backend-sensitive suites only (device_suites): the rest is the host code the ci build has just run. (Every
# program of this build links its own nvptx image, mkoffload and ptxas included: the other ~40 test programs and the
# benchmarks cost their device links and ran nothing here.)
if [ "${CAPSFLOW_SKIP_OFFLOAD:-0}" != 1 ] && capsflow_install gcc-12-offload-nvptx; then
  cmake --preset offload-gcc >/dev/null
  mapfile -t suites < <(device_suites)
  cmake --build --preset offload-gcc -j "$jobs" --target capsflow "${suites[@]}"
  ctest --test-dir build/offload-gcc -j "$jobs" --output-on-failure \
    -R '/(serial|threads|device)( |$)|KernelDispatch|DeviceAvailability|DeviceBackend|Cli[.]InfoListsBackends|DeviceCode[.]'
else
  echo "offload toolchain not installable here: skipped"
fi

stage "device backend for NVIDIA GPUs with clang 19 (offload-clang): the GPU check's programs, and their device code"
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

stage "device backend on LLVM's host offload device (clang 19): the device tests with data movement"
# The host fallback above shares the host's arrays; this device copies every mapped array, so a missing map or
# target update fails here as it would on a GPU (docs/device.md, "The host-memory test device"). The tests whose
# name ends in /device (about 25 s).
if [ "${CAPSFLOW_SKIP_OFFLOAD:-0}" != 1 ] && capsflow_install clang-19 clang-tools-19 libomp-19-dev; then
  cmake --preset offload-host >/dev/null
  mapfile -t suites < <(device_suites)
  cmake --build --preset offload-host -j "$jobs" --target capsflow "${suites[@]}"
  ctest --preset offload-host
else
  echo "clang 19 offload toolchain not installable here: skipped"
fi
