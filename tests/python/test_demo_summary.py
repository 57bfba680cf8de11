#!/usr/bin/env python3
"""The text the embedded demo (`capsflow run` without CONFIG, the README's first command) prints at its end, checked
against an independent computation from the file the run wrote.

The embedded demo is run for 3 strain units instead of 40 (`--set time.end=3`, about 110 steps, ~17 s on one core
of the shared 2-core machine) into WORKDIR.
From its output, with h5py and numpy: each species' mean of |y_c - H/2| over its capsules and the records of the
second half of the strain (time >= half the last record's), H from the stored configuration. The printed distances
(in a and in H) must equal these to the digits printed, both species must be named, the sentence naming the species
nearer the walls must name the one with the larger distance (or neither when they are level to the digits printed),
and the paths of the diagnostics figure, the snapshot figure and the render must be printed. With -q (a 0.2-strain
run) nothing is.

    tests/python/test_demo_summary.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it (exit 77: skipped)
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

SKIP = 77
try:
    import numpy as np
    import h5py
    MISSING = None
except ImportError as e:  # pragma: no cover - depends on the machine
    MISSING = str(e)

BINARY = None
WORKDIR = None
RUN = {}             # the demo's stdout and the file it wrote


def run_demo(*extra, end=3, out="demo.h5"):
    r = subprocess.run([BINARY, "run", "--set", "time.end=%g" % end, "--set", "output.every=0.05", "--threads", "1",
                        "--output", os.path.join(WORKDIR, out), "--force", *extra], cwd=WORKDIR,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    if r.returncode != 0:
        raise AssertionError("capsflow run (embedded demo): exit %d\n%s%s" % (r.returncode, r.stdout, r.stderr))
    return r.stdout


def independent_distances(path):
    """{species name: (capsules, mean |y_c - H/2| in a)}, H, records in the window: straight from the file."""
    with h5py.File(path, "r") as f:
        config = f["parameters/config"][()]
        config = config.decode() if isinstance(config, bytes) else config
        domain = config[config.index("[domain]"):]
        H = float(re.search(r"^H = ([0-9.eE+-]+)$", domain, re.M).group(1))
        t = f["series/time"][:]
        y = f["series/centroid"][:, :, 1]
        sp = f["capsules/species"][:]
        names = f["capsules/species"].attrs["names"]
        names = (names.decode() if isinstance(names, bytes) else names).split(",")
    keep = t >= 0.5 * t[-1]
    d = np.abs(y[keep] - 0.5 * H)
    return {n: (int((sp == k).sum()), float(d[:, sp == k].mean())) for k, n in enumerate(names)}, H, int(keep.sum())


class DemoSummary(unittest.TestCase):
    def test_numbers_equal_an_independent_computation_from_the_output(self):
        expect, H, records = independent_distances(RUN["file"])
        self.assertEqual(sorted(expect), ["floppy", "stiff"])
        out = RUN["stdout"]
        self.assertIn("H = %g a" % H, out)
        self.assertIn("%d records" % records, out)
        for name, (n, dist) in expect.items():
            m = re.search(r"^  %s +Ca [0-9.]+ +(\d+) capsules +([0-9.]+) a = ([0-9.]+) H$" % name, out, re.M)
            self.assertIsNotNone(m, "no line for %s in\n%s" % (name, out))
            self.assertEqual(int(m.group(1)), n)
            self.assertAlmostEqual(float(m.group(2)), dist, delta=0.0005 + 1e-12)     # printed %.3f
            self.assertAlmostEqual(float(m.group(3)), dist / H, delta=0.00005 + 1e-12)  # printed %.4f

    def test_the_species_nearer_the_walls_is_the_farther_from_the_centre(self):
        expect, _, _ = independent_distances(RUN["file"])
        out = RUN["stdout"]
        diff = expect["stiff"][1] - expect["floppy"][1]
        if abs(diff) < 0.0005:
            self.assertIn("sit equally far from the centreline", out)
        else:
            nearer = "stiff" if diff > 0 else "floppy"
            self.assertRegex(out, r"The %s capsules sit nearer the walls[^,]*, %.3f a" % (nearer, abs(diff)))

    def test_names_the_figures_and_the_render(self):
        for p in ("figures/demo_run_diagnostics.png", "figures/fig02_snapshots.png", "pictures/demo_species_f"):
            self.assertIn(os.path.join(WORKDIR, p), RUN["stdout"])

    def test_quiet_prints_nothing(self):
        self.assertEqual(run_demo("-q", end=0.2, out="quiet/demo.h5"), "")   # a few steps, its own file


def main(argv):
    global BINARY, WORKDIR
    if MISSING is not None:
        print("SKIP: needs numpy and h5py (%s)" % MISSING)
        return SKIP
    BINARY = os.path.abspath(argv[1])
    made = len(argv) < 3
    WORKDIR = tempfile.mkdtemp(prefix="capsflow-demo-summary-") if made else os.path.abspath(argv[2])
    shutil.rmtree(WORKDIR, ignore_errors=True)
    os.makedirs(WORKDIR)
    RUN["stdout"] = run_demo()
    RUN["file"] = os.path.join(WORKDIR, "demo.h5")
    print(RUN["stdout"])
    prog = unittest.main(argv=[argv[0]], exit=False, verbosity=2)
    if made:
        shutil.rmtree(WORKDIR, ignore_errors=True)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
