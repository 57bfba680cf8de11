#!/usr/bin/env bash
# The host's vector paths, each tested (kernels/simd_path.hpp; docs/performance.md section 6). The x86-64 host loops
# of the local sums, the spreading and interpolation and the mode solves pick their instruction set once per process
# (AVX-512, AVX2 + FMA, portable), so one ctest run tests one path: the CPU's best. This runs the suites whose code
# takes a path once per path the CPU has (CAPSFLOW_SIMD caps the path), prints a count per path, and fails when a
# test fails, when a process took another path than it was given, or when neither SIMD path (avx2, avx512) ran.
#   tools/simd_paths.sh [BUILD_DIR]       (default build/ci; the suites below must be built there)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/ci}
suites=(test_simd_path test_local_single_layer test_double_layer test_spread_interp test_slit_stokes_plan
        test_mode_solve test_single_layer_plan test_ggem_solver test_ggem_exact test_slit_green_reference)
path_of() { CAPSFLOW_SIMD=$1 "$build/capsflow" info | sed -n 's/^vector *\([a-z0-9]*\) .*/\1/p'; }
cpu=$("$build/capsflow" info | sed -n "s/.*this CPU's best: \([a-z0-9]*\).*/\1/p")
case "$cpu" in
  avx512) paths=(portable avx2 avx512) ;;
  avx2) paths=(portable avx2) ;;
  portable) paths=(portable) ;;
  *) echo "simd_paths: '$build/capsflow info' names no vector path"; exit 1 ;;
esac
export OMP_NUM_THREADS=2 CAPSFLOW_SOURCE_DIR=$PWD CAPSFLOW_BINARY=$PWD/$build/capsflow
unset CAPSFLOW_NO_AVX512
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# gtest's summary lines: "[  PASSED  ] 12 tests.", "[  SKIPPED ] 1 test, listed below:", "[  FAILED  ] 2 tests, ..."
count() { local c; c=$(sed -n "s/^\[ *$1 *\] \([0-9][0-9]*\) tests\{0,1\}[,.].*/\1/p" "$log" | head -1); echo "${c:-0}"; }
status=0 simd_passed=0
table=$(printf '%-10s %7s %7s %7s' "path" passed skipped failed)
for p in "${paths[@]}"; do
  took=$(path_of "$p")
  if [ "$took" != "$p" ]; then echo "simd_paths: CAPSFLOW_SIMD=$p gave the path '$took'"; status=1; continue; fi
  passed=0 skipped=0 failed=0
  for s in "${suites[@]}"; do
    if ! CAPSFLOW_SIMD=$p "$build/tests/$s" --gtest_brief=1 >"$log" 2>&1; then
      echo "simd_paths: $s failed on the $p path:"; cat "$log"; status=1
    fi
    passed=$((passed + $(count PASSED))) skipped=$((skipped + $(count SKIPPED))) failed=$((failed + $(count FAILED)))
  done
  [ "$p" != portable ] && simd_passed=$((simd_passed + passed))
  table+=$'\n'$(printf '%-10s %7d %7d %7d' "$p" "$passed" "$skipped" "$failed")
done
echo "simd_paths: the vector-sensitive suites (${#suites[@]}) per host vector path (this CPU's best: $cpu)"
echo "$table"
if [ "$simd_passed" -eq 0 ]; then
  echo "simd_paths: neither SIMD path (avx2, avx512) was tested here: this CPU has '$cpu' only"
  status=1
fi
exit "$status"
