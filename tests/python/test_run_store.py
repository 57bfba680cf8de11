#!/usr/bin/env python3
"""tools/run_store.py (a long run's output kept as a base and append-only parts) on real runs of the built capsflow.

A tiny run (4 capsules of mesh level 1) goes to strain 0.3, 0.6 and 0.9 by restarts, saved into a store after each
stretch, once restored onto a fresh folder in between as on a new machine; the outputs are checked:
- the restored file equals the run's own output in every dataset, attribute and creation property (finished runs
  compress their series, a restart makes them plain again: the join follows both), its frame views included;
- a restart from the restored file continues the run: the series, frames and events of the stored-and-restored run
  equal, bit for bit, those of the same run made in one go (restart continuity through the store);
- each part holds only the records written since the previous save (the store grows by what the run added);
- `capsflow analyze` reads the restored file;
- refusals with exit 2 and one line: another run's output, an output behind the store, a running output (lock), a
  store with a missing part, a restore over an output that went on past the store (--force keeps it aside); a save
  with nothing new writes nothing; a changed number is found by the comparison.

    tests/python/test_run_store.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it (exit 77: skipped)
"""

import os
import shutil
import subprocess
import sys
import tempfile

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
TOOL = os.path.join(SOURCE_DIR, "tools", "run_store.py")
sys.path.insert(0, os.path.join(SOURCE_DIR, "tools"))

try:
    import numpy as np
    import h5py
    import run_store
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"SKIP: needs numpy and h5py ({e})")
    sys.exit(SKIP)

import tiny_run  # noqa: E402  (the shared tiny run, beside this file: never a reason to skip)

CONFIG = tiny_run.config(0.9, 0.02, 0.2, file="output.h5", output_extra="checkpoint_every = 0.1\n")

from tiny_run import capsflow, check, failures  # noqa: E402  (the shared helpers)


def tool(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)


def records(path):
    """The growing datasets' values (series, frames, events) of an output."""
    with h5py.File(path, "r") as f:
        return {p: f[p][...] for p in run_store.growing(f)}


def main(binary, work):
    if not os.access(binary, os.X_OK):
        print(f"SKIP: no capsflow executable at {binary}")
        return SKIP
    shutil.rmtree(work, ignore_errors=True)
    a, b, c, ref, store = (os.path.join(work, n) for n in ("a", "b", "c", "ref", "store"))
    for d in (a, ref):
        os.makedirs(d)
        with open(os.path.join(d, "run.toml"), "w") as fh:
            fh.write(CONFIG)
    capsflow(binary, ref, "run", "run.toml", "-q")                       # the run in one go, to 0.9

    # Stretch 1 (0 -> 0.3), saved: the base.
    capsflow(binary, a, "run", "run.toml", "--end", "0.3", "-q")
    r = tool("save", a, store)
    check(r.returncode == 0 and "the base" in r.stdout, f"first save: {r.returncode} {r.stdout}{r.stderr}")
    # Stretch 2 (0.3 -> 0.6) in place, saved: part 1, only the new records.
    capsflow(binary, a, "run", "--restart", "output.checkpoint.h5", "--end", "0.6", "-q")
    r = tool("save", a, store)
    check(r.returncode == 0 and os.path.isfile(os.path.join(store, "output.part-001.h5")),
          f"second save: {r.returncode} {r.stdout}{r.stderr}")
    with h5py.File(os.path.join(store, "output.h5"), "r") as base, \
            h5py.File(os.path.join(store, "output.part-001.h5"), "r") as p1, h5py.File(os.path.join(a, "output.h5")) as o:
        n0, n1, n = base["series/time"].shape[0], p1["series/time"].shape[0], o["series/time"].shape[0]
        check(n0 > 0 and n1 > 0 and n0 + n1 == n, f"part 1 holds the records since the base: {n0} + {n1} != {n}")
        check(int(p1["_store"].attrs["series/time"]) == n0, "part 1 starts at the base's record count")
    r = tool("save", a, store)
    check(r.returncode == 0 and "nothing new" in r.stdout
          and not os.path.exists(os.path.join(store, "output.part-002.h5")),
          f"a save with nothing new writes nothing: {r.returncode} {r.stdout}{r.stderr}")

    # A new machine: the store restored onto a fresh folder equals the run's output, and analyze reads it.
    r = tool("restore", store, b)
    check(r.returncode == 0, f"restore: {r.returncode} {r.stderr}")
    check(run_store.describe_differences(os.path.join(a, "output.h5"), os.path.join(b, "output.h5")) == [],
          "the restored output equals the run's: " +
          "; ".join(run_store.describe_differences(os.path.join(a, "output.h5"), os.path.join(b, "output.h5"))))
    for name in ("output.checkpoint.h5", "run.toml"):
        shutil.copy(os.path.join(a, name), os.path.join(b, name))
    capsflow(binary, b, "analyze", "output.h5", "--out", "analysis", "-q")
    check(os.path.isfile(os.path.join(b, "analysis", "summary.json")), "analyze reads the restored output")

    # Stretch 3 (0.6 -> 0.9) from the restored output, saved: part 2; restored again onto another folder.
    capsflow(binary, b, "run", "--restart", "output.checkpoint.h5", "--end", "0.9", "-q")
    r = tool("save", b, store)
    check(r.returncode == 0 and os.path.isfile(os.path.join(store, "output.part-002.h5")),
          f"third save: {r.returncode} {r.stdout}{r.stderr}")
    r = tool("restore", store, c)
    check(r.returncode == 0, f"second restore: {r.returncode} {r.stderr}")
    diffs = run_store.describe_differences(os.path.join(b, "output.h5"), os.path.join(c, "output.h5"))
    check(diffs == [], "the restored output equals the continued run's: " + "; ".join(diffs))
    got, want = records(os.path.join(c, "output.h5")), records(os.path.join(ref, "output.h5"))
    check(sorted(got) == sorted(want), f"same growing datasets as the run in one go: {sorted(got)} {sorted(want)}")
    for p in sorted(set(got) & set(want)):
        same = got[p].shape == want[p].shape and np.array_equal(got[p], want[p], equal_nan=got[p].dtype.kind == "f")
        check(same, f"/{p}: stored-and-restored run equals the run in one go (shapes {got[p].shape} {want[p].shape})")
    with h5py.File(os.path.join(c, "output.h5"), "r") as f:
        frames = f["frames/time"].shape[0]
        views = sorted(int(k) for k in f["xdmf/positions"].keys())
        check(views == list(range(frames)), f"a view per frame: {views} for {frames} frames")
        check(np.array_equal(f["xdmf/positions"][str(frames - 1)][...], f["frames/positions"][frames - 1]),
              "the last frame's view shows the last frame")

    # Refusals (exit 2, one line naming the file), and nothing written by them.
    before = sorted(os.listdir(store))
    r = tool("save", a, store)     # a is at 0.6, the store at 0.9
    check(r.returncode == 2 and "caught up" in r.stderr and len(r.stderr.strip().splitlines()) == 1,
          f"an output behind the store: {r.returncode} {r.stderr}")
    r = tool("save", ref, store)   # another run
    check(r.returncode == 2 and "another run" in r.stderr, f"another run's output: {r.returncode} {r.stderr}")
    open(os.path.join(b, "output.lock"), "w").close()
    r = tool("save", b, store)
    check(r.returncode == 2 and "output.lock" in r.stderr, f"a running output: {r.returncode} {r.stderr}")
    os.remove(os.path.join(b, "output.lock"))
    check(sorted(os.listdir(store)) == before, "refused saves write nothing")
    gap = os.path.join(work, "gap")
    shutil.copytree(store, gap)
    os.remove(os.path.join(gap, "output.part-001.h5"))
    r = tool("restore", gap, os.path.join(work, "d"))
    check(r.returncode == 2 and "part 1 is missing" in r.stderr, f"a store with a gap: {r.returncode} {r.stderr}")
    check(not os.path.exists(os.path.join(work, "d", "output.h5")), "a refused restore writes no output")

    # A restore never goes backwards (issue 52, 1): c continued past the store (0.9 -> 1.2) is refused, both counts
    # and strains named, the output untouched; --force replaces it and keeps it aside.
    for name in ("output.checkpoint.h5", "run.toml"):
        shutil.copy(os.path.join(b, name), os.path.join(c, name))
    capsflow(binary, c, "run", "--restart", "output.checkpoint.h5", "--end", "1.2", "-q")
    with open(os.path.join(c, "output.h5"), "rb") as fh:
        newer = fh.read()
    r = tool("restore", store, c)
    check(r.returncode == 2 and "newer work" in r.stderr and "to strain" in r.stderr
          and len(r.stderr.strip().splitlines()) == 1, f"a restore over newer work: {r.returncode} {r.stderr}")
    with open(os.path.join(c, "output.h5"), "rb") as fh:
        check(fh.read() == newer, "a refused restore leaves the newer output as it was")
    r = tool("restore", store, c, "--force")
    kept = [n for n in os.listdir(c) if n.startswith("output.replaced-")]
    check(r.returncode == 0 and len(kept) == 1, f"restore --force: {r.returncode} {r.stderr} {kept}")
    if kept:
        with open(os.path.join(c, kept[0]), "rb") as fh:
            check(fh.read() == newer, "restore --force keeps the output it replaced, bit for bit")
    diffs = run_store.describe_differences(os.path.join(b, "output.h5"), os.path.join(c, "output.h5"))
    check(diffs == [], "restore --force gives the store's output: " + "; ".join(diffs))

    # The comparison behind the save's self-check sees one changed number.
    changed = os.path.join(work, "changed.h5")
    shutil.copy(os.path.join(c, "output.h5"), changed)
    with h5py.File(changed, "r+") as f:
        f["series/centroid"][3, 1, 1] += 1e-12
    diffs = run_store.describe_differences(os.path.join(c, "output.h5"), changed)
    check(diffs == ["/series/centroid: values differ"], f"a changed number found: {diffs}")

    print("run_store:", "FAILED" if failures else "passed")
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print("usage: test_run_store.py CAPSFLOW_BINARY WORKDIR", file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
