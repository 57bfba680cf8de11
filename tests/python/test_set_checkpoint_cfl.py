#!/usr/bin/env python3
"""tools/set_checkpoint_cfl.py (a checkpoint copied with another [time] cfl; docs/validation.md 9.8) on a real run.

A tiny run (4 capsules of mesh level 1) to strain 0.2 leaves a checkpoint; the tool writes a copy at cfl 0.25 and at
0.5 (the run's own value):
- the copy's stored configuration differs from the original in the cfl line only, and its state datasets are equal;
- `capsflow run --restart` on the 0.5 copy reproduces, bit for bit, the restart of the original (the copy is a
  checkpoint like any other), and the 0.25 copy takes about twice the steps to the same strain;
- refusals with exit 2 and one line, writing nothing: an existing destination without --force, a cfl that is not a
  positive number, a file that is no checkpoint; the source is never changed.

    tests/python/test_set_checkpoint_cfl.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it (exit 77: skipped)
"""

import hashlib
import os
import shutil
import subprocess
import sys

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
TOOL = os.path.join(SOURCE_DIR, "tools", "set_checkpoint_cfl.py")

try:
    import numpy as np
    import h5py
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"SKIP: needs numpy and h5py ({e})")
    sys.exit(SKIP)

import tiny_run  # noqa: E402  (the shared tiny run, beside this file: never a reason to skip)

from tiny_run import capsflow, check, failures  # noqa: E402  (the shared helpers)


def tool(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def config_text(path):
    with h5py.File(path, "r") as f:
        t = f["/parameters/config"][()]
    return t.decode() if isinstance(t, bytes) else str(t)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: test_set_checkpoint_cfl.py CAPSFLOW_BINARY WORKDIR")
    binary, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    with open(os.path.join(work, "run.toml"), "w") as f:  # [time] cfl: the default 0.5
        f.write(tiny_run.config(0.2, 0.02, 0.2, file="output.h5", output_extra="checkpoint_every = 0.1\n"))
    capsflow(binary, work, "run", "run.toml", "-q")
    ck = os.path.join(work, "output.checkpoint.h5")
    before = digest(ck)

    for cfl in ("0.5", "0.25"):
        r = tool(ck, os.path.join(work, f"c{cfl}.checkpoint.h5"), cfl)
        check(r.returncode == 0, f"cfl {cfl}: exit {r.returncode}: {r.stderr}")
    old, new = config_text(ck), config_text(os.path.join(work, "c0.25.checkpoint.h5"))
    diff = [(a, b) for a, b in zip(old.splitlines(), new.splitlines()) if a != b]
    check(len(old.splitlines()) == len(new.splitlines()) and len(diff) == 1, f"one changed line, got {diff}")
    check(diff and diff[0][1].strip() == "cfl = 0.25" and diff[0][0].strip() == "cfl = 0.5", f"the cfl line: {diff}")
    with h5py.File(ck, "r") as a, h5py.File(os.path.join(work, "c0.25.checkpoint.h5"), "r") as b:
        for name in a["/state"]:
            check(np.array_equal(a["/state"][name][()], b["/state"][name][()]), f"/state/{name} copied unchanged")

    # Restarts: the original and the 0.5 copy give the same bits; 0.25 about twice the steps.
    steps = {}
    for tag, src in (("orig", ck), ("c0.5", "c0.5.checkpoint.h5"), ("c0.25", "c0.25.checkpoint.h5")):
        shutil.copyfile(os.path.join(work, "output.h5"), os.path.join(work, f"{tag}.h5"))
        capsflow(binary, work, "run", "--restart", src, "--output", f"{tag}.h5", "--end", "0.4", "-q")
        with h5py.File(os.path.join(work, f"{tag}.h5"), "r") as f:
            steps[tag] = (f["/series/step"][()], f["/series/centroid"][()])
    check(np.array_equal(steps["orig"][0], steps["c0.5"][0]) and np.array_equal(steps["orig"][1], steps["c0.5"][1]),
          "the 0.5 copy restarts bit for bit as the original")
    with h5py.File(os.path.join(work, "output.h5"), "r") as f:
        k = len(f["/series/step"]) - 1  # the checkpoint's record: steps after it
    n05 = steps["c0.5"][0][-1] - steps["c0.5"][0][k]
    n025 = steps["c0.25"][0][-1] - steps["c0.25"][0][k]
    check(1.7 <= n025 / n05 <= 2.3, f"cfl 0.25 takes about twice the steps of 0.5 over [0.2, 0.4]: {n025} / {n05}")

    # Refusals: one line, exit 2, nothing written, the source unchanged.
    dst = os.path.join(work, "c0.5.checkpoint.h5")
    kept = digest(dst)
    for args, words in (((ck, dst, "0.3"), "exists"), ((ck, os.path.join(work, "x.h5"), "-1"), "cfl"),
                        ((ck, os.path.join(work, "y.h5"), "nan"), "cfl"),
                        ((os.path.join(work, "run.toml"), os.path.join(work, "z.h5"), "0.3"), "run.toml")):
        r = tool(*args)
        check(r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and words in r.stderr,
              f"refusal {args[1:]}: exit {r.returncode}: {r.stderr!r}")
    check(digest(dst) == kept, "a refused --force-less write left the existing copy as it was")
    check(not any(os.path.exists(os.path.join(work, n)) for n in ("x.h5", "y.h5", "z.h5")), "refusals wrote nothing")
    check(not any(n.startswith(".cfl-") for n in os.listdir(work)), "no temporary left behind")
    check(digest(ck) == before, "the source checkpoint unchanged")
    r = tool(ck, dst, "0.3", "--force")
    check(r.returncode == 0 and "cfl = 0.3" in config_text(dst), f"--force replaces: {r.stderr}")

    if failures:
        print(f"{len(failures)} failure(s)")
        sys.exit(1)
    print("set_checkpoint_cfl: all checks passed")


if __name__ == "__main__":
    main()
