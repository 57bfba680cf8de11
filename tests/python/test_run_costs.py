#!/usr/bin/env python3
"""tools/run_costs.py on a run.log of three attempts (issue 35): one row per finished attempt, the build named where
the attempt's header or the run's own header names it, steps per strain and seconds per strain from each attempt's own summary; an attempt still
running (no summary) gives no row; a missing run.log is refused with exit 2."""
import subprocess
import sys
import tempfile
from pathlib import Path

TOOL = Path(__file__).resolve().parents[2] / "tools" / "run_costs.py"

LOG = """== capsflow sweep s.toml --task 0 on vm at 2026-12-03 18:20:55Z: start
capsflow run: 50 capsules (8100 nodes, mesh level 2), H = 10.155, Lx = 10.155, Lz = 10.155, grid 84 x 84 x 129
  from strain 0 to 1000; output runs/x/output.h5
  build capsflow 0.1.0 (commit 1780dc957103)
  strain 1.573 / 1000 (0.2 %)  step 66  dt 0.0222  contacts 0 (total 0)  0.92 s/step  ETA 10 h 42 min
capsflow run: interrupted (SIGINT) at strain 200; continue with: capsflow run --restart runs/x/output.checkpoint.h5
capsflow run: strain 200 reached in 8000 steps (2 h 00 min, 0.9 s/step; 0 steps capped by max_step_ratio)
== capsflow sweep s.toml --task 0 on vm at 2026-12-04 03:26:45Z: continue from checkpoint (capsflow 0.1.0 (commit 69bf107aaaaa))
capsflow run: 50 capsules (8100 nodes, mesh level 2)
  continuing from strain 200 to 1000; output runs/x/output.h5
capsflow run: strain 250 reached in 2200 steps (55 min 00 s, 1.5 s/step; 0 steps capped by max_step_ratio)
== capsflow sweep s.toml --task 0 on vm at 2026-12-04 06:00:00Z: continue from checkpoint (capsflow 0.1.0 (commit 69bf107aaaaa-dirty))
  continuing from strain 250 to 1000; output runs/x/output.h5
  strain 251 / 1000 (25.1 %)  step 10244  dt 0.0229  contacts 0 (total 0)  1.2 s/step  ETA 9 h
"""


def main():
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "sweep" / "point-1"
        run.mkdir(parents=True)
        (run / "run.log").write_text(LOG)
        r = subprocess.run([sys.executable, str(TOOL), str(run)], capture_output=True, text=True)
        rows = [l for l in r.stdout.splitlines() if l.startswith("| sweep/point-1")]
        if r.returncode != 0:
            failures.append(f"exit {r.returncode}: {r.stderr}")
        if len(rows) != 2:
            failures.append(f"expected 2 rows (the running attempt has none), got {len(rows)}:\n{r.stdout}")
        else:
            cells = [[c.strip() for c in row.strip("|").split("|")] for row in rows]
            # run, began, build, strain, steps per strain, s per step, s per strain, wall
            expect = [["sweep/point-1", "2026-12-03 18:20:55Z", "1780dc957103", "0.0 -> 200.0", "40.0", "0.9", "36",
                       "2.00 h"],
                      ["sweep/point-1", "2026-12-04 03:26:45Z", "69bf107aaaaa", "200.0 -> 250.0", "44.0", "1.5", "66",
                       "0.92 h"]]
            for got, want in zip(cells, expect):
                if got != want:
                    failures.append(f"row {got} != {want}")
        missing = subprocess.run([sys.executable, str(TOOL), str(Path(tmp) / "nothing")], capture_output=True,
                                 text=True)
        if missing.returncode != 2 or "no run.log" not in missing.stderr:
            failures.append(f"a missing run.log: exit {missing.returncode}, {missing.stderr!r}")
    for f in failures:
        print("FAIL:", f)
    print("run_costs:", "FAILED" if failures else "passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
