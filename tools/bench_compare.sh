#!/usr/bin/env bash
# Two builds of bench_step, run alternately on the same machine (machines are noisy: compare in the same run).
#   tools/bench_compare.sh BASE_BUILD_DIR NEW_BUILD_DIR [ROUNDS]
# e.g. the issue-11 reference:  git worktree add ../base 8762204 && (cd ../base && cmake --preset release &&
#      cmake --build build/release --target bench_step);  tools/bench_compare.sh ../base/build/release build/release
# Prints one line per run (build, threads, real and CPU ms of one set-A step) and the ratio of the medians.
set -euo pipefail
base=$1 new=$2 rounds=${3:-4}
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for ((i = 0; i < rounds; ++i)); do
  for b in "$base" "$new"; do
    for t in 2 1; do
      arg=$([ "$t" = 2 ] && echo 1 || echo 0)
      OMP_NUM_THREADS=$t "$b/bench/bench_step" --benchmark_filter="BM_SetAStep/$arg/" --benchmark_format=json \
        2>/dev/null | python3 -c "
import json, sys
b = json.load(sys.stdin)['benchmarks'][0]
print('$b', $t, round(b['real_time'], 1), round(b['cpu_time'], 1))" | tee -a "$out"
    done
  done
done
python3 - "$out" "$base" "$new" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
for t in ("2", "1"):
    med = {b: statistics.median(float(r[2]) for r in rows if r[0] == b and r[1] == t) for b in sys.argv[2:4]}
    print(f"threads {t}: base {med[sys.argv[2]]:.1f} ms, new {med[sys.argv[3]]:.1f} ms, "
          f"ratio {med[sys.argv[2]] / med[sys.argv[3]]:.2f}")
PY
