#!/usr/bin/env python3
"""tools/capsflow_figures.py on run outputs: the run-diagnostics figure of a real run, its refusals.

A tiny run (4 capsules of mesh level 1, two species, to strain 1; one capsule starts 0.08a from a wall, so that
contact control acts: about 2 s on one core) is made with the built capsflow. The script is run on it directly, as
`capsflow figures` runs it (python3 capsflow_figures.py --out FIGDIR -- INPUT...), together with two copies edited
with h5py: one made a format-1 output (no format_version, none of the later datasets), one whose configuration
source is the embedded demo's "<embedded demo>". The checks read the SVG text as tests/python/test_figures_render.py
does (each panel a group axes_N, each tick label and axis label a text group whose text is kept in an XML comment):
every panel has tick labels and a label on both axes, the legend names the species, the title names the source and
the run id, the numbers shown are the file's, a format-1 output says what it lacks; the files written are exactly
FIGDIR/<stem>_run_diagnostics.png and .svg per run. A checkpoint, a file that is not a run output and an analysis
file are refused in one line with exit status 2 and nothing written; so are an existing figure without --force and
two runs of the same file name. An analysis directory and a run file are drawn in one call.

    tests/python/test_run_diagnostics.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it (exit 77: skipped)
    python3 -m unittest discover -s tests/python -p 'test_run_diagnostics.py'
                             # binary from $CAPSFLOW_BINARY, else build/release/capsflow; a temporary work dir
"""

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest
import xml.etree.ElementTree as ET

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
SCRIPT = os.path.join(SOURCE_DIR, "tools", "capsflow_figures.py")

try:
    import numpy as np
    import h5py
    if importlib.util.find_spec("matplotlib") is None:     # the script draws with it
        raise ImportError("No module named 'matplotlib'")
    MISSING = None
except ImportError as e:  # pragma: no cover - depends on the machine
    MISSING = str(e)

BINARY = os.environ.get("CAPSFLOW_BINARY") or os.path.join(SOURCE_DIR, "build", "release", "capsflow")
WORKDIR = None       # set by the command line, else a temporary directory

import tiny_run  # noqa: E402  (the shared tiny run: tests/python/tiny_run.py)

SPECIES = ["stiff", "floppy", "floppy", "stiff"]
CENTRES = [[1.5, 1.08, 1.5], [3.62, 1.5, 1.5], [1.5, 3.9, 4.5], [4.5, 4.4, 4.5]]
PANELS = 6           # (a) heights, (b) D, (c) volume drift, (d) step size, (e) step limits, (f) contacts
LATER_DATASETS = ("series/max_step_ratio", "series/profile", "series/flow_rate_ratio", "series/relative_viscosity",
                  "series/step_limits", "series/closest_gap", "series/wall_gap", "series/ab2_error", "events",
                  "xdmf")   # everything a format-1 output lacks (docs/output_format.md, "since")

CONFIG = tiny_run.config(1.0, 0.02, 0.5, species=SPECIES, centres=CENTRES)

_made = {}
DRAWN = {}           # the first drawing: returncode, stdout, stderr


def work(*names):
    return os.path.join(WORKDIR, *names)


def capsflow_cmd(*args):
    r = subprocess.run([BINARY, *args], cwd=WORKDIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    if r.returncode != 0:
        raise AssertionError("capsflow %s: exit status %d\n%s%s" % (" ".join(args), r.returncode, r.stdout, r.stderr))
    return r


def figures(out, *inputs, force=False):
    """The script as `capsflow figures` runs it; (exit status, stdout, stderr)."""
    cmd = [sys.executable, "-B", SCRIPT, "--out", out] + (["--force"] if force else []) + ["--", *inputs]
    r = subprocess.run(cmd, cwd=WORKDIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    return r.returncode, r.stdout, r.stderr


def setUpModule():
    global WORKDIR
    if MISSING is not None:
        raise unittest.SkipTest("needs numpy, h5py and matplotlib (%s)" % MISSING)
    if not os.access(BINARY, os.X_OK):
        raise unittest.SkipTest("no capsflow executable at %s (set CAPSFLOW_BINARY)" % BINARY)
    if WORKDIR is None:
        WORKDIR = tempfile.mkdtemp(prefix="capsflow-run-diagnostics-")
        _made["tmp"] = WORKDIR
    os.makedirs(WORKDIR, exist_ok=True)
    with open(work("tiny.toml"), "w") as fh:
        fh.write(CONFIG)
    capsflow_cmd("run", "tiny.toml", "--threads", "1", "--force", "-q")
    shutil.copyfile(work("tiny.h5"), work("format1.h5"))
    with h5py.File(work("format1.h5"), "r+") as f:
        del f.attrs["format_version"]
        for name in LATER_DATASETS:
            if name in f:
                del f[name]
    shutil.copyfile(work("tiny.h5"), work("demo.h5"))
    with h5py.File(work("demo.h5"), "r+") as f:
        f["parameters"].attrs["source"] = "<embedded demo>"
    shutil.rmtree(work("figs"), ignore_errors=True)
    DRAWN["rc"], DRAWN["out"], DRAWN["err"] = figures("figs", "tiny.h5", "format1.h5", "demo.h5")


def tearDownModule():
    if "tmp" in _made:
        shutil.rmtree(_made["tmp"], ignore_errors=True)


def comment_text(g):
    """The text a matplotlib SVG text group stands for (kept in an XML comment)."""
    for node in g.iter():
        if node.tag is ET.Comment and node.text and node.text.strip():
            return node.text.strip()
    return ""


SVG_G = "{http://www.w3.org/2000/svg}g"


def svg_root(path):
    return ET.parse(path, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))).getroot()


def svg_panels(path):
    """{axes_N: {"x": (tick labels, axis label), "y": (...), "legend": [entries, a title first]}} of an SVG."""
    panels = {}
    for g in svg_root(path).iter(SVG_G):
        if not re.fullmatch(r"axes_\d+", g.get("id", "")):
            continue
        p = {"legend": []}
        for child in g.findall(SVG_G):
            cid = child.get("id", "")
            if cid.startswith("matplotlib.axis_"):
                ticks = [comment_text(t) for t in child.findall(SVG_G)
                         if re.fullmatch(r"[xy]tick_\d+", t.get("id", ""))]
                label = [comment_text(t) for t in child.findall(SVG_G) if t.get("id", "").startswith("text_")]
                p["y" if "x" in p else "x"] = ([t for t in ticks if t], label[0] if label else "")
            elif cid.startswith("legend_"):
                p["legend"] = [n.text.strip() for n in child.iter() if n.tag is ET.Comment and n.text.strip()]
        panels[g.get("id")] = p
    return panels


def svg_text(path):
    with open(path, encoding="utf-8") as fh:
        return fh.read()


class RunDiagnostics(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if DRAWN["rc"] != 0:
            raise AssertionError("capsflow_figures.py: exit status %d\n%s%s" % (DRAWN["rc"], DRAWN["out"],
                                                                              DRAWN["err"]))
        cls.out = DRAWN["out"]
        with h5py.File(work("tiny.h5"), "r") as f:
            cls.run_id = f.attrs["run_id"]
            cls.run_id = cls.run_id.decode() if isinstance(cls.run_id, bytes) else str(cls.run_id)
            cls.steps = int(f["series/step"][-1] - f["series/step"][0])
            cls.limits = f["series/step_limits"][()].sum(axis=0)
            q = f["events/capsules"][:, 1]
            cls.wall_events, cls.pair_events = int(np.count_nonzero(q < 0)), int(np.count_nonzero(q >= 0))

    def svg(self, stem):
        return work("figs", stem + "_run_diagnostics.svg")

    def test_files_written(self):
        names = sorted(os.listdir(work("figs")))
        self.assertEqual(names, sorted("%s_run_diagnostics.%s" % (s, e) for s in ("tiny", "format1", "demo")
                                       for e in ("png", "svg")))
        for n in names:
            with open(work("figs", n), "rb") as fh:
                head = fh.read(8)
            self.assertEqual(head.startswith(b"\x89PNG"), n.endswith(".png"), n)
        self.assertIn("wrote 3 figures (6 files) to figs", self.out)
        self.assertEqual(DRAWN["err"], "")
        # Analysis figures are drawn only when an analysis directory is given: no "skipped" lines for them.
        self.assertNotIn("fig0", self.out)

    def test_every_panel_is_readable(self):
        for stem in ("tiny", "format1", "demo"):
            panels = svg_panels(self.svg(stem))
            self.assertEqual(len(panels), PANELS, stem)
            for gid, p in panels.items():
                for axis in "xy":
                    self.assertIn(axis, p, "%s %s: no %s axis" % (stem, gid, axis))
                    ticks, label = p[axis]
                    self.assertGreaterEqual(len(ticks), 2, "%s %s: %s tick labels %s" % (stem, gid, axis, ticks))
                    self.assertTrue(label, "%s %s: no %s axis label" % (stem, gid, axis))
                self.assertIn("strain", p["x"][1], "%s %s: x is not the strain" % (stem, gid))

    def test_legend_names_the_species(self):
        panels = svg_panels(self.svg("tiny"))
        for gid in ("axes_1", "axes_2"):      # (a) heights, (b) deformation: one line per capsule, species colours
            legend = panels[gid]["legend"]
            self.assertEqual(legend, ["stiff (Ca 0.2): 2 capsules", "floppy (Ca 0.8): 2 capsules"], gid)
        self.assertIn("y_c/H", panels["axes_1"]["y"][1])
        self.assertTrue(any(e.startswith("stiff: at most") for e in panels["axes_3"]["legend"]))

    def test_title_names_the_source_and_the_run(self):
        self.assertIn("tiny.toml, run %s" % self.run_id, svg_text(self.svg("tiny")))
        demo = svg_text(self.svg("demo"))
        self.assertIn("embedded demo, run %s" % self.run_id, demo)
        self.assertNotIn("&lt;embedded demo", demo)
        self.assertNotIn("<embedded demo", demo)

    def test_numbers_are_the_files(self):
        panels = svg_panels(self.svg("tiny"))
        self.assertIn("%d steps" % self.steps, panels["axes_4"]["legend"][0])
        shares = {e.rsplit(" ", 2)[0]: float(e.rsplit(" ", 2)[1]) for e in panels["axes_5"]["legend"]}
        self.assertEqual(list(shares), ["membrane", "near-contact", "collision", "ratio cap", "paper gap"])
        np.testing.assert_allclose(list(shares.values()), 100 * self.limits / self.limits.sum(), rtol=5e-3, atol=0)
        self.assertGreater(self.wall_events, 0, "the run was set up to make contact corrections")
        contacts = panels["axes_6"]["legend"]
        self.assertIn("events: walls (%d)" % self.wall_events, contacts)
        self.assertIn("events: capsule pairs (%d)" % self.pair_events, contacts)

    def test_older_format_says_what_it_lacks(self):
        path = self.svg("format1")
        self.assertIn("not in this output (format 1): /series/step_limits", svg_text(path))
        self.assertIn("contact events: not in this output (format 1)", svg_text(path))
        self.assertIn("format1_run_diagnostics: (e): no data: not in this output (format 1)", self.out)
        self.assertNotIn("not in this output", svg_text(self.svg("tiny")))


class Refusals(unittest.TestCase):
    def assertRefused(self, inputs, *parts, out="refused"):
        shutil.rmtree(work(out), ignore_errors=True)
        rc, stdout, stderr = figures(out, *inputs)
        self.assertEqual(rc, 2, (inputs, stdout, stderr))
        self.assertEqual(stdout, "", inputs)
        lines = stderr.splitlines()
        self.assertEqual(len(lines), 1, stderr)
        self.assertTrue(lines[0].startswith("capsflow: error: "), lines[0])
        for p in parts:
            self.assertIn(p, lines[0])
        self.assertFalse(os.path.exists(work(out)), "%s: written on a refusal" % out)
        return lines[0]

    def test_checkpoint(self):
        self.assertRefused(["tiny.checkpoint.h5"], "tiny.checkpoint.h5", "is a checkpoint", "tiny.h5")
        # With a good run beside it: nothing is drawn either.
        self.assertRefused(["tiny.h5", "tiny.checkpoint.h5"], "is a checkpoint")

    def test_not_a_run_output(self):
        self.assertRefused(["tiny.toml"], "tiny.toml", "not an HDF5 file")
        with h5py.File(work("other.h5"), "w") as f:
            f["x"] = np.arange(3)
        self.assertRefused(["other.h5"], "other.h5", "not a capsflow run output", "/capsules/species")
        os.makedirs(work("an"), exist_ok=True)
        with h5py.File(work("an", "analysis.h5"), "w") as f:
            f.attrs["format"] = "capsflow-analysis"
        self.assertRefused([os.path.join("an", "analysis.h5")], "analysis.h5", "analysis file",
                           "give the directory")
        self.assertRefused(["no-such.h5"], "no-such.h5", "no such file")

    def test_same_file_name_twice(self):
        os.makedirs(work("copy"), exist_ok=True)
        shutil.copyfile(work("tiny.h5"), work("copy", "tiny.h5"))
        self.assertRefused(["tiny.h5", os.path.join("copy", "tiny.h5")], "both would be drawn to tiny_run_diagnostics")

    def test_existing_figure_needs_force(self):
        d = work("figs-force")
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        for e in ("png", "svg"):
            with open(os.path.join(d, "tiny_run_diagnostics." + e), "w") as fh:
                fh.write("old")
        self.assertTrue(os.path.isdir(d))
        rc, stdout, stderr = figures(d, "tiny.h5")
        self.assertEqual(rc, 2, stderr)
        self.assertIn("already exists", stderr)
        self.assertIn("--force", stderr)
        for e in ("png", "svg"):
            self.assertEqual(svg_text(os.path.join(d, "tiny_run_diagnostics." + e)), "old")
        rc, stdout, stderr = figures(d, "tiny.h5", force=True)
        self.assertEqual(rc, 0, stderr)
        self.assertEqual(sorted(os.listdir(d)), ["tiny_run_diagnostics.png", "tiny_run_diagnostics.svg"])
        self.assertIn("tiny.toml, run", svg_text(os.path.join(d, "tiny_run_diagnostics.svg")))


class WithAnalysis(unittest.TestCase):
    def test_analysis_directory_and_run_file_in_one_call(self):
        capsflow_cmd("analyze", "tiny.h5", "--out", "analysis", "--force", "-q")
        shutil.rmtree(work("figs-both"), ignore_errors=True)
        rc, stdout, stderr = figures("figs-both", "analysis", "tiny.h5")
        self.assertEqual(rc, 0, stdout + stderr)
        names = os.listdir(work("figs-both"))
        svgs = sorted(n[:-4] for n in names if n.endswith(".svg"))
        self.assertIn("tiny_run_diagnostics", svgs)
        self.assertTrue(any(n.startswith("fig03_") for n in svgs), svgs)
        self.assertEqual(len(names), 2 * len(svgs))
        self.assertIn("wrote %d figures (%d files)" % (len(svgs), len(names)), stdout)


class Only(unittest.TestCase):
    def test_only_draws_the_named_study_figures_and_refuses_unknown_names(self):
        capsflow_cmd("analyze", "tiny.h5", "--out", "analysis-only", "--force", "-q")
        shutil.rmtree(work("figs-only"), ignore_errors=True)
        cmd = [sys.executable, "-B", SCRIPT, "--out", work("figs-only"), "--only", "fig02_snapshots", "--",
               work("analysis-only"), work("tiny.h5")]
        r = subprocess.run(cmd, cwd=WORKDIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertEqual(sorted(os.listdir(work("figs-only"))), ["fig02_snapshots.png", "fig02_snapshots.svg",
                                                                 "tiny_run_diagnostics.png",
                                                                 "tiny_run_diagnostics.svg"])
        cmd[cmd.index("fig02_snapshots")] = "fig02_snapshots,fig99_nothing"
        shutil.rmtree(work("figs-only"), ignore_errors=True)
        r = subprocess.run(cmd, cwd=WORKDIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("--only fig99_nothing: no such figure", r.stderr)
        self.assertFalse(os.path.exists(work("figs-only")))


def main(argv):
    global BINARY, WORKDIR
    if MISSING is not None:
        print("SKIP: the run-diagnostics figure tests need numpy, h5py and matplotlib (%s)" % MISSING)
        return SKIP
    if len(argv) >= 2:
        BINARY = os.path.abspath(argv[1])
    if len(argv) >= 3:
        WORKDIR = os.path.abspath(argv[2])
    if not os.access(BINARY, os.X_OK):
        print("capsflow executable not found: %s" % BINARY, file=sys.stderr)
        return 1
    prog = unittest.main(argv=[argv[0]], exit=False, verbosity=2)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
