#!/usr/bin/env bash
# The device backend's check on a GPU machine (issue 12; docs/device.md), prepared here and run there in one call.
#
# Here (Debian 12 with gcc-12-offload-nvptx and CUDA 13 in /usr/local/cuda; no GPU needed), in the checkout the
# work runs from (the device tool sends that checkout, whichever worktree calls it):
#     tools/device-check.sh pack       # builds build/offload-gcc, writes .devpack/capsflow-device.tar.gz (< 60 MiB)
#     tools/device-check.sh selftest   # unpacks it and runs the smoke stage and the full stage's tests here, on the
#                                      # OpenMP host fallback: checks the pack (libraries, paths) and this script
# On the GPU machine, one call of the device tool (.devpack is git-ignored, so it travels through carry):
#     run(command="bash tools/device-check.sh diagnose smoke full", carry=[".devpack"], timeout_s=560)
# The working tree travels too, 64 MiB with the pack, and the committed reproduction runs alone are ~400 MB:
#     tools/device-check.sh light      # before the call: the runs and docs/figures out of the index, ignored locally,
#                                      # and commits refused (a pre-commit hook) until:
#     tools/device-check.sh restore    # after it: tracked again (the files themselves never move)
# diagnose -> $OUT/diagnose.tar.gz: what the first GPU run left open (below), one test at a time under GOMP_DEBUG=1,
#          and memcheck on the local sums, 25 s each.                                                  (< 3 min)
# smoke -> $OUT/smoke.tar.gz: nvidia-smi, `capsflow info` (GPU name and memory), ldd of the binaries, the device
#          global solve's tests (cuFFT) and one GGEM device test, a few device steps of the embedded demo.  (< 1 min)
# full  -> $OUT/full.tar.gz: every device test with OMP_TARGET_OFFLOAD=MANDATORY (a silent host fallback fails), the
#          set-A two-step compare device vs serial (target 1e-10), the embedded demo on the device against the serial
#          run made here at pack time (how long the series stay together), a device restart halfway against the
#          uninterrupted device run, bench_step set A device vs threads at 16, 8, 4, 2, 1 threads, and bench_ggem's
#          set-A and 618-sphere cases likewise (the sweep stops at a time budget).                       (< 4 min)
# Each stage prints its summary lines as they come (the run's output tail) and writes them to $OUT/STAGE-summary.txt
# as it goes, so a call cut short still brings them back; its logs go into its archive at its end. Every command runs
# under a time limit (CAPSFLOW_DEVICE_LIMIT, 60 s; 25 s in diagnose) and the full stage's tests stop at a time budget
# (180 s), so the three stages stay within about 9 minutes of a 15-minute device budget even where kernels hang.
#
# What the GPU machine lacks travels in the pack: libgomp and its nvptx plugin, HDF5, FFTW, toml++, Google Benchmark
# and their dependencies (everything ldd lists except the driver's libcuda.so.1, which the GPU machine has; glibc and
# the C++ runtime travel too but are used only where the machine's own do not run the binaries: the summary's
# "libraries:" line says which). The CUDA runtime is linked statically; cuFFT (the device global solve) is loaded at run
# time from the machine's own CUDA (libcufft is ~280 MB): unpack points CAPSFLOW_CUFFT_LIBRARY at it. CAPSFLOW_DEVICE_PRESET=offload-clang
# packs the clang build instead: its runtime (libomptarget with libLLVM, about 47 MB compressed) may not fit the limit.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
PRESET=${CAPSFLOW_DEVICE_PRESET:-offload-gcc}
BUILD=$ROOT/build/$PRESET
DEMO_END=${CAPSFLOW_DEVICE_DEMO_END:-2.0}  # strain of the demo compare (about 75 steps)
MAX_PACK_MIB=55                            # the device tool carries 64 MiB in all, the repository (~9) included

# Test executables with device instantiations, benchmarks.
TESTS=(test_backend_dispatch test_capsule_geometry test_single_layer_plan test_contact test_device_cells
       test_device_mirror test_double_layer test_ggem_exact test_ggem_solver test_local_single_layer
       test_membrane_forces test_resident_step test_simulation test_slit_cells test_slit_stokes_plan
       test_slit_stokes_plan_device test_spread_interp test_step_workspace test_viscosity_ratio)
BENCHES=(bench_step bench_ggem)
if [ "$PRESET" = offload-gcc ]; then
  PACKDIR=$ROOT/.devpack
  PACK=$PACKDIR/capsflow-device.tar.gz
else
  # The clang build's runtime (libomptarget and libLLVM with its dependencies, ~146 MB) is ~41 MB under xz -9: its
  # pack holds the suites of diagnose and smoke only, in a folder of its own (carry=[".devpack-$PRESET"]: one pack a
  # call fits the limit, two do not).
  PACKDIR=$ROOT/.devpack-$PRESET
  PACK=$PACKDIR/capsflow-device.tar.xz
  TESTS=(test_device_cells test_local_single_layer test_double_layer test_simulation test_slit_stokes_plan_device
         test_ggem_solver test_spread_interp test_membrane_forces test_resident_step test_viscosity_ratio)
  BENCHES=(bench_step)
  # offload-host (LLVM's host offload device, for the rehearsal) builds no benchmarks.
  [ "$PRESET" = offload-host ] && BENCHES=()
fi

log() { printf '== %s\n' "$*"; }

# ----------------------------------------------------------------------------------------------------------------
pack() {
  log "build $PRESET (tests and benchmarks)"
  local launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
  cmake --preset "$PRESET" "${launcher[@]}" >/dev/null
  cmake --build "$BUILD" -j "$(nproc)" --target capsflow "${TESTS[@]}" "${BENCHES[@]}"

  local stage
  stage=$(mktemp -d)
  trap 'rm -rf "$stage"' RETURN
  mkdir -p "$stage/bin" "$stage/lib" "$stage/ref"
  cp "$BUILD/capsflow" "$stage/bin/"
  for t in "${TESTS[@]}"; do cp "$BUILD/tests/$t" "$stage/bin/"; done
  for b in "${BENCHES[@]}"; do cp "$BUILD/bench/$b" "$stage/bin/"; done
  # Not stripped: the binaries are small, and the offload tables must stay exactly as the linker wrote them.

  # libgomp dlopens its plugin by name; ship it with its own dependencies. (clang: libomptarget holds its CUDA
  # plugin, and ldd below finds it.)
  local plugin=
  if [ "$PRESET" = offload-gcc ]; then
    plugin=$(ldconfig -p | awk '/libgomp-plugin-nvptx.so.1 / && !found {print $NF; found = 1}')
    [ -n "$plugin" ] || { echo "libgomp-plugin-nvptx.so.1 not found (apt-get install libgomp-plugin-nvptx1)"; exit 2; }
    cp -L "$plugin" "$stage/lib/"
  fi
  # Everything ldd resolves, except the driver (the GPU machine's). glibc goes to lib/glibc and the C++ runtime to
  # lib/compat, used there only when the machine's own do not run the binaries (unpack below): a newer system
  # libstdc++ is better than ours, an older glibc than 2.36 needs ours and its loader.
  local glibc='^(ld-linux-x86-64|libc|libm|libdl|libpthread|librt|libresolv|libutil)\.so'
  mkdir -p "$stage/lib/glibc" "$stage/lib/compat"
  { for f in "$stage"/bin/* ${plugin:+"$stage/lib/$(basename "$plugin")"}; do ldd "$f"; done; } |
    awk '$2 == "=>" && $3 ~ /^\// {print $1, $3} $1 ~ /^\/.*ld-linux/ {print "ld-linux-x86-64.so.2", $1}' |
    sort -u | while read -r name path; do
      case $name in
        libcuda.so*) ;;
        libstdc++.so* | libgcc_s.so*) cp -Ln "$path" "$stage/lib/compat/$name" ;;
        *) if [[ $name =~ $glibc ]]; then cp -Ln "$path" "$stage/lib/glibc/$name"; else cp -Ln "$path" "$stage/lib/$name"; fi ;;
      esac
    done
  local missing
  missing=$(LD_LIBRARY_PATH="$stage/lib" ldd "$stage"/bin/* | grep "not found" || true)
  if [ -n "$missing" ]; then echo "$missing"; exit 2; fi

  log "serial reference: the embedded demo to strain $DEMO_END"
  (cd "$stage/ref" && OMP_NUM_THREADS=1 LD_LIBRARY_PATH="$stage/lib" "$stage/bin/capsflow" run --backend serial \
     --end "$DEMO_END" --output demo_serial.h5 --progress 0 -q)
  rm -f "$stage"/ref/*.checkpoint.h5 "$stage"/ref/*.xdmf "$stage"/ref/*.svg

  {
    echo "commit   $(git rev-parse HEAD 2>/dev/null || echo unknown)$([ -n "$(git status --porcelain 2>/dev/null)" ] && echo ' (with local changes)')"
    echo "built    $(date -u +%FT%TZ) on $(uname -n), preset $PRESET"
    echo "demo     reference to strain $DEMO_END, serial backend, this build"
    LD_LIBRARY_PATH="$stage/lib" "$stage/bin/capsflow" info
    echo "glibc symbols needed (highest): $(objdump -T "$stage"/bin/* "$stage"/lib/* 2>/dev/null |
      grep -o 'GLIBC_2\.[0-9]*' | sort -t. -k2 -n -u | tail -1)"
  } >"$stage/MANIFEST"
  mkdir -p "$PACKDIR"
  if [ "${PACK##*.}" = xz ]; then
    tar -C "$stage" -cf - . | xz -9 -T0 >"$PACK"
  else
    tar -C "$stage" -czf "$PACK" .
  fi
  local mib
  mib=$(( ($(stat -c %s "$PACK") + 1048575) / 1048576 ))
  log "pack $PACK: ${mib} MiB (limit ${MAX_PACK_MIB} MiB); contents:"
  du -sh "$stage/bin" "$stage/lib" "$stage/ref"
  if [ "$mib" -gt "$MAX_PACK_MIB" ]; then echo "pack too large"; exit 2; fi
}

# ----------------------------------------------------------------------------------------------------------------
# Unpacks into $CAPSFLOW_DEVICE_DIR (default /tmp/capsflow-device) once per machine.
unpack() {
  [ -f "$PACK" ] || { echo "no pack at $PACK: run tools/device-check.sh pack here first, then carry $(basename "$PACKDIR")"; exit 2; }
  DIR=${CAPSFLOW_DEVICE_DIR:-/tmp/capsflow-device}
  if [ ! -f "$DIR/MANIFEST" ]; then
    mkdir -p "$DIR"
    tar -C "$DIR" -xf "$PACK"  # gzip or xz, as GNU tar finds it
  fi
  export CAPSFLOW_SOURCE_DIR=$ROOT CAPSFLOW_BINARY=$DIR/bin/capsflow
  BIN=$DIR/bin
  # The machine's own C++ runtime and glibc if they run the binaries, else ours, else ours with our loader.
  RUN=()
  LINKMODE="system C++ runtime and glibc"
  export LD_LIBRARY_PATH="$DIR/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  if ! "$BIN/capsflow" --version >/dev/null 2>&1; then
    LINKMODE="packed C++ runtime, system glibc"
    export LD_LIBRARY_PATH="$DIR/lib:$DIR/lib/compat${LD_LIBRARY_PATH#$DIR/lib}"
    if ! "$BIN/capsflow" --version >/dev/null 2>&1; then
      LINKMODE="packed C++ runtime and glibc, packed loader"
      RUN=("$DIR/lib/glibc/ld-linux-x86-64.so.2" --library-path "$DIR/lib:$DIR/lib/compat:$DIR/lib/glibc:$LD_LIBRARY_PATH")
      "${RUN[@]}" "$BIN/capsflow" --version >/dev/null || { echo "the packed binaries do not start here"; exit 2; }
    fi
  fi
  echo "libraries: $LINKMODE"
  # The device global solve dlopens cuFFT (never packed): the machine's own, wherever its CUDA lives.
  if [ -z "${CAPSFLOW_CUFFT_LIBRARY:-}" ]; then
    local cufft
    cufft=$(ls /usr/local/cuda*/lib64/libcufft.so.[0-9]* /usr/local/cuda*/targets/x86_64-linux/lib/libcufft.so.[0-9]* \
      2>/dev/null | grep -E 'libcufft\.so\.[0-9]+$' | head -1 || true)
    [ -n "$cufft" ] || cufft=$(ldconfig -p 2>/dev/null | awk '/libcufft\.so\.[0-9]+ / {print $NF; exit}')
    if [ -n "$cufft" ]; then export CAPSFLOW_CUFFT_LIBRARY=$cufft; fi
  fi
  echo "cufft: ${CAPSFLOW_CUFFT_LIBRARY:-not found (the device global solve will say so)}"
}

# On the GPU: device tests must reach the device (MANDATORY) and never the test-only host fallback.
# selftest sets CAPSFLOW_DEVICE_CHECK_HOST=1: no MANDATORY, the fallback switch on.
device_env() {
  if [ "${CAPSFLOW_DEVICE_CHECK_HOST:-0}" = 1 ]; then
    export CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1
    unset OMP_TARGET_OFFLOAD
  else
    unset CAPSFLOW_TEST_DEVICE_HOST_FALLBACK
    export OMP_TARGET_OFFLOAD=MANDATORY
  fi
}

# run_logged NAME [VAR=VALUE...] CMD...: runs CMD (the packed loader in front of packed binaries where unpack chose
# it) with its output in $RES/NAME.log, for at most $LIMIT seconds (a hung kernel must not eat the device budget),
# and notes pass / FAIL / FAIL (timeout) and seconds in the summary; a failed GoogleTest run adds its first failure
# messages.
LIMIT=${CAPSFLOW_DEVICE_LIMIT:-60}
run_logged() {
  local name=$1
  shift
  local envs=()
  while [[ $# -gt 0 && $1 == [A-Z_]*=* ]]; do envs+=("$1"); shift; done
  local cmd=("$@")
  [[ ${cmd[0]} == "$BIN"/* ]] && cmd=("${RUN[@]}" "${cmd[@]}")
  local t0=$SECONDS rc=0 verdict=pass
  timeout -k 5 "$LIMIT" env "${envs[@]}" "${cmd[@]}" >"$RES/$name.log" 2>&1 || rc=$?
  if [ "$rc" = 124 ] || [ "$rc" = 137 ]; then verdict="FAIL (timeout after ${LIMIT}s)"
  elif [ "$rc" != 0 ]; then verdict="FAIL (exit $rc)"; fi
  printf '%-34s %s  %3ds\n' "$name" "$verdict" $((SECONDS - t0)) | note
  if [ "$rc" != 0 ]; then
    grep -E -A3 ': Failure$' "$RES/$name.log" | head -16 | sed 's/^/    /' | note || true
    # The runtime's own words: a kernel fault (libgomp: ... illegal memory access) ends the process through exit
    # handlers that may then wait for ever, which looks like a hang from outside.
    grep -m 4 -iE 'libgomp|cuda error|illegal|out of memory|terminate called' "$RES/$name.log" | cut -c1-300 |
      sed 's/^/    /' | note || true
    grep -E '^\[ RUN      \]' "$RES/$name.log" | tail -1 | sed 's/^/    last started: /' | note || true
  fi
  return 0
}

# note: appends stdin to the stage's summary, which lives in $OUT from the start (it comes back even when the call
# runs out of time), and prints it.
note() { tee -a "$SUMMARY"; }

begin() {  # begin STAGE: $RES for the logs, $SUMMARY in $OUT
  local out=${OUT:-$ROOT/out}
  mkdir -p "$out"
  RES=$(mktemp -d)/$1
  mkdir -p "$RES"
  SUMMARY=$out/$1-summary.txt
  : >"$SUMMARY"
  log "$1 (each command at most ${LIMIT}s; summary in $SUMMARY)"
}

finish() {  # finish STAGE: archive $RES (the summary with it) as $OUT/STAGE.tar.gz
  local stage=$1
  local out=${OUT:-$ROOT/out}
  cp "$SUMMARY" "$RES/summary.txt"
  tar -C "$(dirname "$RES")" -czf "$out/$stage.tar.gz" "$(basename "$RES")"
  log "$stage done ($out/$stage.tar.gz)"
  if grep -q FAIL "$SUMMARY"; then FAILED=1; fi
}

# ----------------------------------------------------------------------------------------------------------------
# diagnose: what the first GPU run (2026-12-04, H200) left open, measured in about two minutes. There the device
# global solve, spreading, interpolation and membrane tests passed, DeviceCells' two list compares failed, and the
# local single layer, a full step, the resident step, the double layer and the viscosity-ratio steps ran past 25 s
# each (the embedded demo past 470 s for strain 0.1) without finishing. For each of those: one test alone, under
# GOMP_DEBUG=1 (libgomp's nvptx plugin prints each kernel's launch and end: the last launch without an end is the
# kernel that hangs or crawls), with the GPU's utilisation read 15 s in (busy: a kernel runs; idle: the host waits).
diagnose() {
  unpack
  device_env
  local LIMIT=${CAPSFLOW_DEVICE_DIAGNOSE_LIMIT:-25}
  begin diagnose
  local cases=(
    "cells_element test_device_cells Backends/DeviceCells.ElementListEqualsTheHostList/device"
    "cells_node test_device_cells Backends/DeviceCells.NodeListAndClosestPairEqualTheHost/device"
    "local_single_layer test_local_single_layer Backends/LocalSingleLayerBackends.MatchSerial/device"
    "double_layer test_double_layer Backends/DoubleLayerBackends.ApplyMatchesSerial/device"
    "full_step test_simulation Backends/StepBackends.OneFullStepMatchesSerial/device")
  local c name exe filter
  for c in "${cases[@]}"; do
    read -r name exe filter <<<"$c"
    local sampler=
    if command -v nvidia-smi >/dev/null; then
      ( sleep 15; nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv,noheader 2>&1 |
          sed "s/^/    at 15 s: gpu utilisation, memory used: /" >"$RES/$name.smi" ) &
      sampler=$!
    fi
    # GOMP_DEBUG: libgomp's trace (GCC build); LIBOMPTARGET_INFO=16: each kernel launch (clang build).
    run_logged "$name" GOMP_DEBUG=1 LIBOMPTARGET_INFO=16 "$BIN/$exe" --gtest_filter="$filter"
    if [ -n "$sampler" ]; then kill "$sampler" 2>/dev/null || true; wait "$sampler" 2>/dev/null || true; fi
    cat "$RES/$name.smi" 2>/dev/null | note || true
    # The kernels launched and the last lines of the plugin's trace (the launch that never ended, if one hung).
    grep -cE 'kernel .*: launch|Launching kernel' "$RES/$name.log" | sed 's/^/    kernel launches: /' | note || true
    grep -E 'kernel .*: (launch|finished)|Launching kernel' "$RES/$name.log" | tail -3 | cut -c1-300 |
      sed 's/^/    /' | note || true
    # The log can be large: keep its head and tail.
    { head -c 200000 "$RES/$name.log"; echo "[...]"; tail -c 400000 "$RES/$name.log"; } >"$RES/$name.trace"
    rm -f "$RES/$name.log"
  done
  # compute-sanitizer's memcheck on the local sums (seen working on this workplace's H200 machines): a kernel that
  # faults is named with the faulting access, where GOMP_DEBUG shows only that the launch did not end.
  local sanitizer
  sanitizer=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -1 || true)
  if [ -n "$sanitizer" ] && [ "${CAPSFLOW_DEVICE_CHECK_HOST:-0}" != 1 ]; then
    run_logged memcheck_local_single_layer "$sanitizer" --tool memcheck --print-limit 5 \
      "$BIN/test_local_single_layer" --gtest_filter='Backends/LocalSingleLayerBackends.MatchSerial/device'
    grep -m 8 -E '^========= (Invalid|Address|Program hit|Saved host|ERROR SUMMARY)|at .*\$_omp_fn' \
      "$RES/memcheck_local_single_layer.log" | cut -c1-300 | sed 's/^/    /' | note || true
  fi
  # The smallest real run: one level-1 capsule (320 elements) for a few steps. Steps that finish here but not at set
  # A's size point at a slow kernel; none finishing at a hang.
  mkdir -p "$RES/isolated"
  run_logged isolated_steps "$BIN/capsflow" run "$ROOT/examples/presets/isolated.toml" --backend device \
    --set capsules.mesh_level=1 --end 0.05 --output "$RES/isolated/iso.h5" --progress 1
  grep -E 'reached|per step|step [0-9]' "$RES/isolated_steps.log" | tail -4 | note || true
  rm -f "$RES"/isolated/*.h5
  finish diagnose
}

smoke() {
  unpack
  device_env
  begin smoke
  cp "$DIR/MANIFEST" "$RES/"
  echo "libraries: $LINKMODE" | note
  { uname -a; nproc; free -g; command -v nvidia-smi >/dev/null && nvidia-smi; } >"$RES/machine.txt" 2>&1 || true
  { ls -l /usr/local/cuda*/lib64/libcufft* 2>&1; echo "CAPSFLOW_CUFFT_LIBRARY=${CAPSFLOW_CUFFT_LIBRARY:-}"; } \
    >"$RES/cufft.txt" 2>&1 || true
  # The device global solve first (cuFFT on device pointers, the per-mode kernels), then the solver on top of it.
  run_logged slit_plan_device "$BIN/test_slit_stokes_plan_device" --gtest_filter='*/device' --gtest_brief=0
  grep -E 'OK|FAILED|SKIPPED|relative difference' "$RES/slit_plan_device.log" | head -8 | note >/dev/null || true
  ldd "$BIN/capsflow" "$BIN/test_ggem_solver" "$DIR/lib/libgomp-plugin-nvptx.so.1" >"$RES/ldd.txt" 2>&1 || true
  run_logged info "$BIN/capsflow" info
  grep -E '^(devices|default|gpu|fallback)' "$RES/info.log" | note || true
  if [ "${CAPSFLOW_DEVICE_CHECK_HOST:-0}" != 1 ] && ! grep -qE '^gpu +[0-9]' "$RES/info.log"; then
    echo "info_names_gpu                     FAIL (capsflow info names no GPU)" | note
  fi
  run_logged ggem_solver_device "$BIN/test_ggem_solver" --gtest_filter='*/device' --gtest_brief=0
  grep -E 'OK|FAILED|SKIPPED' "$RES/ggem_solver_device.log" | head -5 | note >/dev/null || true
  mkdir -p "$RES/steps"
  run_logged demo_steps_device "$BIN/capsflow" run --backend device --end 0.1 --output "$RES/steps/demo.h5" \
    --progress 0
  grep -E 'reached|per step' "$RES/demo_steps_device.log" | note || true
  rm -f "$RES"/steps/*.h5
  finish smoke
}

full() {
  local t_stage=$SECONDS
  unpack
  device_env
  begin full
  mkdir -p "$RES/tests" "$RES/bench"
  # Every device test, with a junit XML each.
  for t in "${TESTS[@]}"; do
    if [ $((SECONDS - t_stage)) -gt "${CAPSFLOW_DEVICE_TESTS_UNTIL:-180}" ]; then
      echo "$t: not run (time budget)" | note
      continue
    fi
    run_logged "$t" "$BIN/$t" --gtest_filter='*/device' --gtest_output="xml:$RES/tests/$t.xml"
    grep -hE '^\s*(set A step|  device vs serial|  device)' "$RES/$t.log" | head -4 | note >/dev/null || true
  done
  grep -h 'SKIPPED \]' "$RES"/*.log | sort -u | sed 's/^/skipped: /' | note >/dev/null || true
  # The set-A compare (two steps, device vs serial; prints the relative difference).
  run_logged set_a_compare CAPSFLOW_TEST_SET_A=1 "$BIN/test_simulation" --gtest_filter='*StepBackends.SetA*/device'
  grep -E 'set A step' "$RES/set_a_compare.log" | note || true
  # Where two device steps do not finish, the demo, the restart and the benchmarks would each run into the limit.
  if grep -qE '^set_a_compare +FAIL \(timeout' "$SUMMARY"; then
    echo "demo, restart and benchmarks: not run (the set-A device steps did not finish)" | note
    finish full
    return
  fi
  if [ "${CAPSFLOW_DEVICE_CHECK_QUICK:-0}" != 1 ]; then
    # The embedded demo on the device against the serial run made at pack time; the compare needs python3 + h5py.
    PY=python3
    for p in python3 /usr/bin/python3 /opt/torch/.venv/bin/python3; do
      if env -u LD_LIBRARY_PATH "$p" -c 'import h5py' >/dev/null 2>&1; then PY=$p; break; fi
    done
    mkdir -p "$RES/demo"
    run_logged demo_device "$BIN/capsflow" run --backend device --end "$DEMO_END" --output "$RES/demo/demo_device.h5" \
      --progress 0
    grep -E 'reached|per step' "$RES/demo_device.log" | note || true
    run_logged demo_compare env -u LD_LIBRARY_PATH "$PY" "$ROOT/tools/device_compare.py" "$DIR/ref/demo_serial.h5" \
      "$RES/demo/demo_device.h5"
    cat "$RES/demo_compare.log" | note >/dev/null
    # A device restart halfway against the uninterrupted device run: round-off (atomics), not bit for bit.
    mkdir -p "$RES/restart"
    local half
    half=$(awk -v e="$DEMO_END" 'BEGIN {print e / 2}')
    run_logged restart_first_half "$BIN/capsflow" run --backend device --end "$half" --output "$RES/restart/demo.h5" \
      --progress 0 -q
    run_logged restart_second_half "$BIN/capsflow" run --restart "$RES/restart/demo.checkpoint.h5" --backend device \
      --end "$DEMO_END" --output "$RES/restart/demo.h5" --progress 0 -q
    run_logged restart_compare env -u LD_LIBRARY_PATH "$PY" "$ROOT/tools/device_compare.py" \
      "$RES/demo/demo_device.h5" "$RES/restart/demo.h5"
    cat "$RES/restart_compare.log" | note >/dev/null
    rm -f "$RES"/demo/*.checkpoint.h5 "$RES"/restart/*.checkpoint.h5
    if [ "${CAPSFLOW_DEVICE_SKIP_BENCH:-0}" = 1 ]; then finish full; return; fi
    # Benchmarks: the device first, then threads from 16 cores down, cut where the stage's time budget runs out
    # (CAPSFLOW_DEVICE_BENCH_UNTIL seconds into the stage), so both stages stay within 5 minutes. JSON in bench/.
    run_logged bench_step_device "$BIN/bench_step" --benchmark_filter='BM_SetAStep/2/' \
      --benchmark_out="$RES/bench/step_device.json"
    # Issue 34: a set-A step at lambda 1 and 5 on the device (the interface solve's GMRES stays on the host).
    run_logged bench_step_lambda_device "$BIN/bench_step" --benchmark_filter='BM_SetAStepViscosityRatioDevice/' \
      --benchmark_out="$RES/bench/step_lambda_device.json"
    [ -x "$BIN/bench_ggem" ] && run_logged bench_ggem_device "$BIN/bench_ggem" --benchmark_min_time=0.2 \
      --benchmark_filter='BM_(FullApply|LocalSum|Spread|GlobalSolve|Interpolate)/spheres:(50|618)/threads:2/' \
      --benchmark_out="$RES/bench/ggem_device.json"
    local cores n
    cores=$(nproc)
    for n in 16 8 4 2 1; do
      [ "$n" -le "$cores" ] || continue
      if [ $((SECONDS - t_stage)) -gt "${CAPSFLOW_DEVICE_BENCH_UNTIL:-200}" ]; then
        echo "bench sweep stopped before $n threads: time budget" | note
        break
      fi
      run_logged "bench_step_threads_$n" OMP_NUM_THREADS="$n" "$BIN/bench_step" \
        --benchmark_filter="BM_SetAStep/1/$([ "$n" = 16 ] && echo '|BM_SetAStepViscosityRatio/')" \
        --benchmark_out="$RES/bench/step_threads_$n.json"
      [ -x "$BIN/bench_ggem" ] && run_logged "bench_ggem_threads_$n" OMP_NUM_THREADS="$n" "$BIN/bench_ggem" \
        --benchmark_min_time=0.2 \
        --benchmark_filter='BM_(FullApply|LocalSum|Spread|GlobalSolve|Interpolate)/spheres:(50|618)/threads:1/' \
        --benchmark_out="$RES/bench/ggem_threads_$n.json"
    done
    grep -hE '^BM_' "$RES"/bench_*.log | sed 's/^/bench: /' | note >/dev/null || true
  fi
  finish full
}

# gpu: the whole check in one call that survives a hang (issue 48). Everything is written into $OUT/gpu/ as it runs,
# line-buffered, so a call cut short by its limit still brings back every line before the hang:
#   heartbeat.txt   every 5 s: seconds since the start, the command running, the GPU's utilisation and memory
#   summary.txt     a line per command: pass / FAIL (exit N) / FAIL (timeout after Ns), seconds
#   tests/*.log     each device test alone (GoogleTest's own list, filter */device), under its own limit
#   first-failure/  the first failing test that runs the local sums, again with the runtime's trace (LIBOMPTARGET_INFO,
#                   GOMP_DEBUG) and under compute-sanitizer's memcheck: a fault is named, a hang shows as the last
#                   launch without an end
#   then the set-A compare (two steps, device vs serial), the embedded demo against the serial run made at pack time,
#   a device restart halfway, and bench_step's BM_SetAStep/2 with the device memory in use.
# Budgets (seconds, environment): CAPSFLOW_GPU_TEST_LIMIT 20 per test, CAPSFLOW_GPU_TESTS_UNTIL 240 for all tests
# (after three timeouts the rest get 5 s each: a hang in one kernel hangs every test that runs it), and the stage
# stops starting new work at CAPSFLOW_GPU_UNTIL 500: one call of at most 560 s, inside the tool's 600.
heartbeat_loop() {  # heartbeat_loop FILE: until killed
  local t0=$SECONDS
  while :; do
    local smi=""
    command -v nvidia-smi >/dev/null &&
      smi=$(nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv,noheader 2>/dev/null | head -1)
    printf '%4ds  %s  gpu: %s\n' $((SECONDS - t0)) "$(cat "$GPU_OUT/current" 2>/dev/null)" "${smi:-n/a}" >>"$1"
    sleep 5
  done
}

# gpu_run NAME LIMIT [VAR=VALUE...] CMD...: CMD with its output line-buffered into $GPU_OUT/NAME.log.
gpu_run() {
  local name=$1 limit=$2
  shift 2
  local envs=()
  while [[ $# -gt 0 && $1 == [A-Z_]*=* ]]; do envs+=("$1"); shift; done
  local cmd=("$@")
  [[ ${cmd[0]} == "$BIN"/* ]] && cmd=("${RUN[@]}" "${cmd[@]}")
  mkdir -p "$(dirname "$GPU_OUT/$name.log")"
  echo "$name" >"$GPU_OUT/current"
  local t0=$SECONDS rc=0 verdict=pass
  timeout -k 5 "$limit" env "${envs[@]}" stdbuf -oL -eL "${cmd[@]}" >"$GPU_OUT/$name.log" 2>&1 || rc=$?
  if [ "$rc" = 124 ] || [ "$rc" = 137 ]; then verdict="FAIL (timeout after ${limit}s)"
  elif [ "$rc" != 0 ]; then verdict="FAIL (exit $rc)"; fi
  printf '%-72s %s  %3ds\n' "$name" "$verdict" $((SECONDS - t0)) >>"$GPU_OUT/summary.txt"
  printf '%-72s %s  %3ds\n' "$name" "$verdict" $((SECONDS - t0))
  if [ "$rc" != 0 ]; then
    { grep -E -A3 ': Failure$' "$GPU_OUT/$name.log" | head -12
      grep -m 4 -iE 'libgomp|libomptarget|cuda error|illegal|out of memory|terminate called' "$GPU_OUT/$name.log" |
        cut -c1-300; } | sed 's/^/    /' | tee -a "$GPU_OUT/summary.txt" || true
  fi
  return "$rc"
}

gpu() {
  local t_stage=$SECONDS
  unpack
  device_env
  GPU_OUT=${OUT:-$ROOT/out}/gpu
  rm -rf "$GPU_OUT"
  mkdir -p "$GPU_OUT/tests"
  : >"$GPU_OUT/summary.txt"
  cp "$DIR/MANIFEST" "$GPU_OUT/"
  echo "libraries: $LINKMODE; ${CAPSFLOW_CUFFT_LIBRARY:+cufft $CAPSFLOW_CUFFT_LIBRARY}" >>"$GPU_OUT/summary.txt"
  heartbeat_loop "$GPU_OUT/heartbeat.txt" &
  HEARTBEAT_PID=$!
  # However the stage ends: a heartbeat left running would keep the device tool's call open to its limit.
  trap 'kill "$HEARTBEAT_PID" 2>/dev/null || true' EXIT
  { uname -a; nproc; command -v nvidia-smi >/dev/null && nvidia-smi; } >"$GPU_OUT/machine.txt" 2>&1 || true
  gpu_run info 30 "$BIN/capsflow" info || true
  grep -E '^(devices|default|gpu|fallback)' "$GPU_OUT/info.log" >>"$GPU_OUT/summary.txt" || true

  # Each device test alone, in GoogleTest's order; local-sum suites last, so that what works is measured first.
  local limit=${CAPSFLOW_GPU_TEST_LIMIT:-20} timeouts=0 first_fail="" exe t
  local local_sums='LocalSingleLayer|DoubleLayer|StepBackends|ResidentStep|ViscosityRatio|SingleLayerPlan|Simulation'
  local ordered=()
  for exe in "${TESTS[@]}"; do
    [ -x "$BIN/$exe" ] || continue
    while read -r t; do ordered+=("$exe $t"); done < <("${RUN[@]}" "$BIN/$exe" --gtest_list_tests \
      --gtest_filter='*/device' 2>/dev/null | awk '/^[^ ]/ {s = $1} /^  / {print s $1}')
  done
  local sorted=() e
  for e in "${ordered[@]}"; do [[ $e =~ $local_sums ]] || sorted+=("$e"); done
  for e in "${ordered[@]}"; do [[ $e =~ $local_sums ]] && sorted+=("$e"); done
  echo "device tests: ${#sorted[@]}" >>"$GPU_OUT/summary.txt"
  for e in "${sorted[@]}"; do
    read -r exe t <<<"$e"
    if [ $((SECONDS - t_stage)) -gt "${CAPSFLOW_GPU_TESTS_UNTIL:-240}" ]; then
      echo "not run (tests' time budget): $exe $t" >>"$GPU_OUT/summary.txt"
      continue
    fi
    local rc=0
    gpu_run "tests/${t//\//_}" "$([ "$timeouts" -ge 3 ] && echo 5 || echo "$limit")" \
      "$BIN/$exe" --gtest_filter="$t" || rc=$?
    [ "$rc" = 124 ] || [ "$rc" = 137 ] && timeouts=$((timeouts + 1))
    if [ "$rc" != 0 ] && [ -z "$first_fail" ] && [[ $e =~ $local_sums ]]; then first_fail=$e; fi
  done
  local npass nfail
  npass=$(grep -c '^tests/.* pass ' "$GPU_OUT/summary.txt" || true)
  nfail=$(grep -c '^tests/.* FAIL' "$GPU_OUT/summary.txt" || true)
  echo "device tests: $npass passed, $nfail failed" | tee -a "$GPU_OUT/summary.txt"

  # The first failing local-sum test: the runtime's trace (the last launch without an end is the kernel that hangs or
  # crawls) and memcheck (a fault named with its access).
  if [ -n "$first_fail" ]; then
    read -r exe t <<<"$first_fail"
    echo "first failing local-sum test: $exe $t" >>"$GPU_OUT/summary.txt"
    gpu_run first-failure/trace 30 GOMP_DEBUG=1 LIBOMPTARGET_INFO=16 "$BIN/$exe" --gtest_filter="$t" || true
    grep -cE 'kernel .*: launch|Launching kernel' "$GPU_OUT/first-failure/trace.log" |
      sed 's/^/    kernel launches: /' >>"$GPU_OUT/summary.txt" || true
    local sanitizer
    sanitizer=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -1 || true)
    if [ -n "$sanitizer" ] && [ "${CAPSFLOW_DEVICE_CHECK_HOST:-0}" != 1 ]; then
      gpu_run first-failure/memcheck 90 "$sanitizer" --tool memcheck --print-limit 5 "$BIN/$exe" \
        --gtest_filter="$t" || true
      grep -m 8 -E '^========= (Invalid|Address|Program hit|ERROR SUMMARY)' "$GPU_OUT/first-failure/memcheck.log" |
        sed 's/^/    /' >>"$GPU_OUT/summary.txt" || true
    fi
  fi

  # The set-A compare: two steps, device against serial (1e-10).
  if [ $((SECONDS - t_stage)) -lt "${CAPSFLOW_GPU_UNTIL:-500}" ]; then
    gpu_run set_a_compare 90 CAPSFLOW_TEST_SET_A=1 "$BIN/test_simulation" \
      --gtest_filter='*StepBackends.SetAStepsMatchSerial/device' || true
    grep -E 'set A step' "$GPU_OUT/set_a_compare.log" >>"$GPU_OUT/summary.txt" || true
  fi
  # The embedded demo on the device against the serial run made at pack time, and a restart halfway.
  local PY=python3 p
  for p in python3 /usr/bin/python3; do
    if env -u LD_LIBRARY_PATH "$p" -c 'import h5py' >/dev/null 2>&1; then PY=$p; break; fi
  done
  if [ $((SECONDS - t_stage)) -lt "${CAPSFLOW_GPU_UNTIL:-500}" ]; then
    mkdir -p "$GPU_OUT/demo"
    # The compare goes as far as the shorter run: the rehearsal stops the demo early (the host device is slow).
    local demo_end=${CAPSFLOW_GPU_DEMO_END:-$DEMO_END}
    if gpu_run demo_device 120 "$BIN/capsflow" run --backend device --end "$demo_end" \
         --output "$GPU_OUT/demo/demo_device.h5" --progress 1; then
      gpu_run demo_compare 60 env -u LD_LIBRARY_PATH "$PY" "$ROOT/tools/device_compare.py" \
        "$DIR/ref/demo_serial.h5" "$GPU_OUT/demo/demo_device.h5" || true
      sed 's/^/    /' "$GPU_OUT/demo_compare.log" >>"$GPU_OUT/summary.txt"
      local half
      half=$(awk -v e="$demo_end" 'BEGIN {print e / 2}')
      mkdir -p "$GPU_OUT/restart"
      gpu_run restart_first_half 90 "$BIN/capsflow" run --backend device --end "$half" \
          --output "$GPU_OUT/restart/demo.h5" --progress 0 -q &&
        gpu_run restart_second_half 90 "$BIN/capsflow" run --restart "$GPU_OUT/restart/demo.checkpoint.h5" \
          --backend device --end "$demo_end" --output "$GPU_OUT/restart/demo.h5" --progress 0 -q &&
        gpu_run restart_compare 60 env -u LD_LIBRARY_PATH "$PY" "$ROOT/tools/device_compare.py" \
          "$GPU_OUT/demo/demo_device.h5" "$GPU_OUT/restart/demo.h5" || true
      [ -f "$GPU_OUT/restart_compare.log" ] && sed 's/^/    /' "$GPU_OUT/restart_compare.log" >>"$GPU_OUT/summary.txt"
    fi
    rm -f "$GPU_OUT"/demo/*.h5 "$GPU_OUT"/restart/*.h5
  fi
  # A set-A step on the card, with the memory in use while it runs (the heartbeat has it too).
  if [ $((SECONDS - t_stage)) -lt "${CAPSFLOW_GPU_UNTIL:-500}" ] && [ -x "$BIN/bench_step" ]; then
    gpu_run bench_step_device 120 "$BIN/bench_step" --benchmark_filter='BM_SetAStep/2/' \
      --benchmark_out="$GPU_OUT/bench_step_device.json" || true
    grep -hE '^BM_' "$GPU_OUT/bench_step_device.log" | sed 's/^/bench: /' >>"$GPU_OUT/summary.txt" || true
    grep -E 'gpu: [0-9]' "$GPU_OUT/heartbeat.txt" | tail -1 | sed 's/^/memory in use (last heartbeat): /' \
      >>"$GPU_OUT/summary.txt" || true
  fi
  echo "gpu stage: $((SECONDS - t_stage)) s" | tee -a "$GPU_OUT/summary.txt"
  kill "$HEARTBEAT_PID" 2>/dev/null || true
  rm -f "$GPU_OUT/current"
  if grep -q FAIL "$GPU_OUT/summary.txt"; then FAILED=1; fi
}

# rehearse: the gpu stage on LLVM's host offload device (the offload-host preset's pack: every mapped array a copy of
# its own, OMP_TARGET_OFFLOAD=MANDATORY as on a GPU; FFTW stands in for cuFFT). Checks the script, the pack and the
# data movement here; it must finish in under 3 minutes on an idle 2-core machine.
rehearse() {
  [ "$PRESET" = offload-host ] || { echo "rehearse needs CAPSFLOW_DEVICE_PRESET=offload-host (its pack)"; exit 2; }
  export CAPSFLOW_DEVICE_DIR CAPSFLOW_TEST_DEVICE_HOST_MEMORY=1 OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
  CAPSFLOW_DEVICE_DIR=$(mktemp -d)/capsflow-device
  OUT=${OUT:-$(mktemp -d)}
  # The host device runs a test 10-50x slower than a GPU would: the limits here are for the rehearsal's machine.
  export OUT CAPSFLOW_GPU_TEST_LIMIT=${CAPSFLOW_GPU_TEST_LIMIT:-60} CAPSFLOW_GPU_DEMO_END=${CAPSFLOW_GPU_DEMO_END:-0.4}
  gpu
  log "rehearsal's files in $OUT/gpu"
}

# Here: the smoke stage and the full stage's tests from the pack, on the host fallback. Checks the pack and the script,
# not the GPU.
selftest() {
  export CAPSFLOW_DEVICE_CHECK_HOST=1 CAPSFLOW_DEVICE_CHECK_QUICK=1 OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
  export CAPSFLOW_DEVICE_DIR
  CAPSFLOW_DEVICE_DIR=$(mktemp -d)/capsflow-device
  OUT=${OUT:-$(mktemp -d)}
  export OUT
  diagnose
  smoke
  full
  log "selftest archives in $OUT"
  ls -la "$OUT"
}

# What the device tool sends: the tracked files and the untracked ones git does not ignore.
travel_mib() {
  { git ls-files -z; git ls-files -z --others --exclude-standard; } | xargs -0 du -cb 2>/dev/null |
    awk 'END {print int($1 / 1048576)}'
}
# Left out of what the device tool sends (64 MiB with the pack; a clang pack is 54 MiB): the committed reproduction
# runs (~400 MB) and the study's figures and analyses (~9 MB). They leave the index, not the disk, until `restore`;
# a commit in between would delete them from the repository, so `light` installs a pre-commit hook that refuses any
# commit until `restore` removes it.
HEAVY=(docs/reproduction/runs docs/figures)
HOOK_MARK="capsflow device-check light"
light() {
  local h
  for h in "${HEAVY[@]}"; do
    if git ls-files --error-unmatch "$h" >/dev/null 2>&1; then
      git rm -r -q --cached "$h"
      grep -qxF "/$h/" .git/info/exclude 2>/dev/null || echo "/$h/" >>.git/info/exclude
    fi
  done
  local hook
  hook=$(git rev-parse --git-path hooks)/pre-commit
  if [ ! -e "$hook" ]; then
    printf '#!/bin/sh\n# %s\necho "tools/device-check.sh light is on (%s out of the index): run tools/device-check.sh restore before committing" >&2\nexit 1\n' \
      "$HOOK_MARK" "${HEAVY[*]}" >"$hook"
    chmod +x "$hook"
  fi
  log "travels: $(travel_mib) MiB of files, plus the pack ($(du -m "$PACK" 2>/dev/null | cut -f1) MiB); restore after the call"
}
restore() {
  local h hook
  for h in "${HEAVY[@]}"; do
    sed -i "\#^/$h/\$#d" .git/info/exclude
    git add "$h"
    log "$h tracked again; git status: $(git status --porcelain "$h" | wc -l) changed entries there"
  done
  hook=$(git rev-parse --git-path hooks)/pre-commit
  if grep -qF "$HOOK_MARK" "$hook" 2>/dev/null; then rm -f "$hook"; fi
}

FAILED=0
[ $# -gt 0 ] || { sed -n '2,31p' "$0"; exit 2; }
for stage in "$@"; do
  case $stage in
    pack | diagnose | smoke | full | gpu | rehearse | selftest | light | restore) "$stage" ;;
    *) echo "tools/device-check.sh: unknown stage '$stage' (pack | gpu | rehearse | selftest | light | diagnose | smoke | full | restore)"
       exit 2 ;;
  esac
done
exit $FAILED
