#!/usr/bin/env bash
# The device backend's check on a GPU machine (issue 12; docs/device.md), prepared here and run there in one call.
#
# Here (Debian 12 with gcc-12-offload-nvptx and CUDA 13 in /usr/local/cuda; no GPU needed), in the checkout the
# session runs from (the device tool sends that checkout, whichever worktree calls it):
#     tools/device-check.sh pack       # builds build/offload-gcc, writes .devpack/capsflow-device.tar.gz (< 60 MiB)
#     tools/device-check.sh selftest   # unpacks it and runs the smoke stage and the full stage's tests here, on the
#                                      # OpenMP host fallback: checks the pack (libraries, paths) and this script
# On the GPU machine, one call of the device tool (.devpack is git-ignored, so it travels through carry):
#     run(command="bash tools/device-check.sh smoke full", carry=[".devpack"], timeout_s=480)
# smoke -> $OUT/smoke.tar.gz: nvidia-smi, `capsflow info` (GPU name and memory), ldd of the binaries, the device
#          global solve's tests (cuFFT) and one GGEM device test, a few device steps of the embedded demo.  (< 1 min)
# full  -> $OUT/full.tar.gz: every device test with OMP_TARGET_OFFLOAD=MANDATORY (a silent host fallback fails), the
#          set-A two-step compare device vs serial (target 1e-10), the embedded demo on the device against the serial
#          run made here at pack time (how long the series stay together), a device restart halfway against the
#          uninterrupted device run, bench_step set A device vs threads at 16, 8, 4, 2, 1 threads, and bench_ggem's
#          set-A and 618-sphere cases likewise (the sweep stops at a time budget).                       (< 4 min)
# Each stage prints its summary (the run's output tail) and keeps its logs in its archive. Both together stay within
# 5 minutes, so a failed first try leaves time for a rerun in a 15-minute device budget.
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
PACKDIR=$ROOT/.devpack
PACK=$PACKDIR/capsflow-device.tar.gz
PRESET=${CAPSFLOW_DEVICE_PRESET:-offload-gcc}
BUILD=$ROOT/build/$PRESET
DEMO_END=${CAPSFLOW_DEVICE_DEMO_END:-2.0}  # strain of the demo compare (about 75 steps)
MAX_PACK_MIB=60                            # the device tool carries 64 MiB in all, the repository included

# Test executables with device instantiations, benchmarks.
TESTS=(test_backend_dispatch test_capsule_geometry test_single_layer_plan test_contact test_device_cells
       test_device_mirror test_double_layer test_ggem_exact test_ggem_solver test_local_single_layer
       test_membrane_forces test_resident_step test_simulation test_slit_cells test_slit_stokes_plan
       test_slit_stokes_plan_device test_spread_interp test_step_workspace test_viscosity_ratio)
BENCHES=(bench_step bench_ggem)

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

  # libgomp dlopens its plugin by name; ship it with its own dependencies.
  local plugin
  plugin=$(ldconfig -p | awk '/libgomp-plugin-nvptx.so.1 / && !found {print $NF; found = 1}')
  [ -n "$plugin" ] || { echo "libgomp-plugin-nvptx.so.1 not found (apt-get install libgomp-plugin-nvptx1)"; exit 2; }
  cp -L "$plugin" "$stage/lib/"
  # Everything ldd resolves, except the driver (the GPU machine's). glibc goes to lib/glibc and the C++ runtime to
  # lib/compat, used there only when the machine's own do not run the binaries (unpack below): a newer system
  # libstdc++ is better than ours, an older glibc than 2.36 needs ours and its loader.
  local glibc='^(ld-linux-x86-64|libc|libm|libdl|libpthread|librt|libresolv|libutil)\.so'
  mkdir -p "$stage/lib/glibc" "$stage/lib/compat"
  { for f in "$stage"/bin/* "$stage/lib/$(basename "$plugin")"; do ldd "$f"; done; } |
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
  tar -C "$stage" -czf "$PACK" .
  local mib
  mib=$(( ($(stat -c %s "$PACK") + 1048575) / 1048576 ))
  log "pack $PACK: ${mib} MiB (limit ${MAX_PACK_MIB} MiB); contents:"
  du -sh "$stage/bin" "$stage/lib" "$stage/ref"
  if [ "$mib" -gt "$MAX_PACK_MIB" ]; then echo "pack too large"; exit 2; fi
}

# ----------------------------------------------------------------------------------------------------------------
# Unpacks into $CAPSFLOW_DEVICE_DIR (default /tmp/capsflow-device) once per machine.
unpack() {
  [ -f "$PACK" ] || { echo "no pack at $PACK: run tools/device-check.sh pack here first, then carry .devpack"; exit 2; }
  DIR=${CAPSFLOW_DEVICE_DIR:-/tmp/capsflow-device}
  if [ ! -f "$DIR/MANIFEST" ]; then
    mkdir -p "$DIR"
    tar -C "$DIR" -xzf "$PACK"
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
# it) with its output in $RES/NAME.log, and notes pass/fail and seconds in $RES/summary.txt.
run_logged() {
  local name=$1
  shift
  local envs=()
  while [[ $# -gt 0 && $1 == [A-Z_]*=* ]]; do envs+=("$1"); shift; done
  local cmd=("$@")
  [[ ${cmd[0]} == "$BIN"/* ]] && cmd=("${RUN[@]}" "${cmd[@]}")
  local t0=$SECONDS rc=0
  env "${envs[@]}" "${cmd[@]}" >"$RES/$name.log" 2>&1 || rc=$?
  printf '%-34s %s  %3ds\n' "$name" "$([ $rc = 0 ] && echo pass || echo "FAIL (exit $rc)")" $((SECONDS - t0)) |
    tee -a "$RES/summary.txt"
  return 0
}

finish() {  # finish STAGE: archive $RES as $OUT/STAGE.tar.gz and print the summary
  local stage=$1
  local out=${OUT:-$ROOT/out}
  mkdir -p "$out"
  tar -C "$(dirname "$RES")" -czf "$out/$stage.tar.gz" "$(basename "$RES")"
  log "$stage summary ($out/$stage.tar.gz)"
  cat "$RES/summary.txt"
  if grep -q FAIL "$RES/summary.txt"; then FAILED=1; fi
}

# ----------------------------------------------------------------------------------------------------------------
smoke() {
  unpack
  device_env
  RES=$(mktemp -d)/smoke
  mkdir -p "$RES"
  cp "$DIR/MANIFEST" "$RES/"
  echo "libraries: $LINKMODE" >"$RES/summary.txt"
  { uname -a; nproc; free -g; command -v nvidia-smi >/dev/null && nvidia-smi; } >"$RES/machine.txt" 2>&1 || true
  { ls -l /usr/local/cuda*/lib64/libcufft* 2>&1; echo "CAPSFLOW_CUFFT_LIBRARY=${CAPSFLOW_CUFFT_LIBRARY:-}"; } \
    >"$RES/cufft.txt" 2>&1 || true
  # The device global solve first (cuFFT on device pointers, the per-mode kernels), then the solver on top of it.
  run_logged slit_plan_device "$BIN/test_slit_stokes_plan_device" --gtest_filter='*/device' --gtest_brief=0
  grep -E 'OK|FAILED|SKIPPED|relative difference' "$RES/slit_plan_device.log" | head -8 >>"$RES/summary.txt" || true
  ldd "$BIN/capsflow" "$BIN/test_ggem_solver" "$DIR/lib/libgomp-plugin-nvptx.so.1" >"$RES/ldd.txt" 2>&1 || true
  run_logged info "$BIN/capsflow" info
  grep -E '^(devices|default|gpu|fallback)' "$RES/info.log" | tee -a "$RES/summary.txt" || true
  if [ "${CAPSFLOW_DEVICE_CHECK_HOST:-0}" != 1 ] && ! grep -qE '^gpu +[0-9]' "$RES/info.log"; then
    echo "info_names_gpu                     FAIL (capsflow info names no GPU)" | tee -a "$RES/summary.txt"
  fi
  run_logged ggem_solver_device "$BIN/test_ggem_solver" --gtest_filter='*/device' --gtest_brief=0
  grep -E 'OK|FAILED|SKIPPED' "$RES/ggem_solver_device.log" | head -5 >>"$RES/summary.txt" || true
  mkdir -p "$RES/steps"
  run_logged demo_steps_device "$BIN/capsflow" run --backend device --end 0.1 --output "$RES/steps/demo.h5" \
    --progress 0
  grep -E 'reached|per step' "$RES/demo_steps_device.log" | tee -a "$RES/summary.txt" || true
  rm -f "$RES"/steps/*.h5
  finish smoke
}

full() {
  local t_stage=$SECONDS
  unpack
  device_env
  RES=$(mktemp -d)/full
  mkdir -p "$RES/tests" "$RES/bench"
  : >"$RES/summary.txt"
  # Every device test, with a junit XML each.
  for t in "${TESTS[@]}"; do
    run_logged "$t" "$BIN/$t" --gtest_filter='*/device' --gtest_output="xml:$RES/tests/$t.xml"
    grep -hE '^\s*(set A step|  device vs serial|  device)' "$RES/$t.log" | head -4 >>"$RES/summary.txt" || true
  done
  grep -h 'SKIPPED \]' "$RES"/*.log | sort -u | sed 's/^/skipped: /' >>"$RES/summary.txt" || true
  # The set-A compare (two steps, device vs serial; prints the relative difference).
  run_logged set_a_compare CAPSFLOW_TEST_SET_A=1 "$BIN/test_simulation" --gtest_filter='*StepBackends.SetA*/device'
  grep -E 'set A step' "$RES/set_a_compare.log" | tee -a "$RES/summary.txt" || true
  if [ "${CAPSFLOW_DEVICE_CHECK_QUICK:-0}" != 1 ]; then
    # The embedded demo on the device against the serial run made at pack time; the compare needs python3 + h5py.
    PY=python3
    for p in python3 /usr/bin/python3 /opt/torch/.venv/bin/python3; do
      if env -u LD_LIBRARY_PATH "$p" -c 'import h5py' >/dev/null 2>&1; then PY=$p; break; fi
    done
    mkdir -p "$RES/demo"
    run_logged demo_device "$BIN/capsflow" run --backend device --end "$DEMO_END" --output "$RES/demo/demo_device.h5" \
      --progress 0
    grep -E 'reached|per step' "$RES/demo_device.log" | tee -a "$RES/summary.txt" || true
    run_logged demo_compare env -u LD_LIBRARY_PATH "$PY" "$ROOT/tools/device_compare.py" "$DIR/ref/demo_serial.h5" \
      "$RES/demo/demo_device.h5"
    cat "$RES/demo_compare.log" >>"$RES/summary.txt"
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
    cat "$RES/restart_compare.log" >>"$RES/summary.txt"
    rm -f "$RES"/demo/*.checkpoint.h5 "$RES"/restart/*.checkpoint.h5
    if [ "${CAPSFLOW_DEVICE_SKIP_BENCH:-0}" = 1 ]; then finish full; return; fi
    # Benchmarks: the device first, then threads from 16 cores down, cut where the stage's time budget runs out
    # (CAPSFLOW_DEVICE_BENCH_UNTIL seconds into the stage), so both stages stay within 5 minutes. JSON in bench/.
    run_logged bench_step_device "$BIN/bench_step" --benchmark_filter='BM_SetAStep/2/' \
      --benchmark_out="$RES/bench/step_device.json"
    run_logged bench_ggem_device "$BIN/bench_ggem" --benchmark_min_time=0.2 \
      --benchmark_filter='BM_(FullApply|LocalSum|Spread|GlobalSolve|Interpolate)/spheres:(50|618)/threads:2/' \
      --benchmark_out="$RES/bench/ggem_device.json"
    local cores n
    cores=$(nproc)
    for n in 16 8 4 2 1; do
      [ "$n" -le "$cores" ] || continue
      if [ $((SECONDS - t_stage)) -gt "${CAPSFLOW_DEVICE_BENCH_UNTIL:-200}" ]; then
        echo "bench sweep stopped before $n threads: time budget" | tee -a "$RES/summary.txt"
        break
      fi
      run_logged "bench_step_threads_$n" OMP_NUM_THREADS="$n" "$BIN/bench_step" --benchmark_filter='BM_SetAStep/1/' \
        --benchmark_out="$RES/bench/step_threads_$n.json"
      run_logged "bench_ggem_threads_$n" OMP_NUM_THREADS="$n" "$BIN/bench_ggem" --benchmark_min_time=0.2 \
        --benchmark_filter='BM_(FullApply|LocalSum|Spread|GlobalSolve|Interpolate)/spheres:(50|618)/threads:1/' \
        --benchmark_out="$RES/bench/ggem_threads_$n.json"
    done
    grep -hE '^BM_' "$RES"/bench_*.log | sed 's/^/bench: /' >>"$RES/summary.txt" || true
  fi
  finish full
}

# Here: the smoke stage and the full stage's tests from the pack, on the host fallback. Checks the pack and the script,
# not the GPU.
selftest() {
  export CAPSFLOW_DEVICE_CHECK_HOST=1 CAPSFLOW_DEVICE_CHECK_QUICK=1 OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
  export CAPSFLOW_DEVICE_DIR
  CAPSFLOW_DEVICE_DIR=$(mktemp -d)/capsflow-device
  OUT=${OUT:-$(mktemp -d)}
  export OUT
  smoke
  full
  log "selftest archives in $OUT"
  ls -la "$OUT"
}

FAILED=0
[ $# -gt 0 ] || { sed -n '2,25p' "$0"; exit 2; }
for stage in "$@"; do
  case $stage in
    pack | smoke | full | selftest) "$stage" ;;
    *) echo "tools/device-check.sh: unknown stage '$stage' (pack | selftest | smoke | full)"; exit 2 ;;
  esac
done
exit $FAILED
