#!/usr/bin/env python3
"""tools/capsflow_figures.py on synthetic analyses: every panel readable, empty figures not written, causes named.

The analyses are written here with h5py in the layout `capsflow analyze` writes (docs/analysis.md): a complete one
(sets A, B, C, D, so that every figure has data), one where profiles are masked in every bin (as analyze leaves
them: all-NaN, or not written at all), and the embedded demo's shape (one mixture, nothing else). The script is run
as `capsflow figures` runs it; the checks read the SVG text: matplotlib writes each panel as a group `axes_N` with
its two axis groups, each tick label as a text group inside `xtick_K` / `ytick_K` (the label itself in an XML
comment) and the axis label as a text group of the axis.

    tests/python/test_figures_render.py [WORKDIR]          # as ctest runs it (exit 77: skipped)
    python3 -m unittest discover -s tests/python -p 'test_figures_render.py'
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
WORKDIR = None

try:
    import numpy as np
    import h5py
    if importlib.util.find_spec("matplotlib") is None:     # the script draws with it
        raise ImportError("No module named 'matplotlib'")
    MISSING = None
except ImportError as e:  # pragma: no cover - depends on the machine
    MISSING = str(e)

ALL_FIGURES = ["fig02_snapshots", "fig03_dbar_t", "fig04_dbar_xf", "fig05_n_hat", "fig06_phi_hat", "fig07_enrichment",
               "fig08_v_bar", "fig09_pdf", "fig10_v_prime", "fig11_pair_collisions", "fig13_fab",
               "fig14_confinement", "fig15_volume_fraction", "fig16_rigidity_ratio"]
BINS = 10
NAN = float("nan")

# (ca_stiff, ca_floppy, H, N_p): sets A-D of docs/analysis.md §2 (a cube of 10.155 except B).
SETS = {"A": (0.2, 0.5, 10.155, 50), "B": (0.2, 0.5, 6.6667, 50), "C": (0.2, 0.5, 10.155, 30),
        "D": (0.1, 0.6, 10.155, 30), "E": (0.2, 0.6, 10.155, 50)}     # E: set A's box and stiff Ca, not its floppy Ca


def set_key(name):
    ca_s, ca_f, H, n = SETS[name]
    L = 12.533 if name == "B" else H
    return "H=%g Lx=%g Lz=%g Np=%d Ca=%g/%g" % (H, L, L, n, ca_s, ca_f), H, L


def y_bins():
    return (np.arange(BINS) + 0.5) / (2 * BINS)


def write_root(f):
    f.attrs["capsflow_version"] = "test"
    f.attrs["format"] = "capsflow-analysis"
    f.attrs["format_version"] = 1
    f.attrs["bins"] = BINS


def write_profile(g, name, value, se=0.02):
    g["profiles/" + name] = np.asarray(value, float)
    g["profiles/%s_se" % name] = np.full(BINS, se)


def write_suspension(f, gid, set_name, xf, t1=200.0, masked=(), pdf=True, snapshot=True, dv_rel=True):
    """A suspension group; `masked` names profiles that analyze found undefined in every bin: "v_bar_stiff" is
    written all-NaN, "-v_bar_stiff" is left out (what analyze does), "dv_rel_*" likewise. dv_rel: the set has the
    pure groups that analyze needs as the reference of the relative change of v-bar_p."""
    key, H, L = set_key(set_name)
    ca_s, ca_f, _, n = SETS[set_name]
    g = f.create_group("groups/" + gid)
    for k, v in (("key", "suspension %s xf=%g" % (key, xf)), ("label", "Xf=%g (%s)" % (xf, key)),
                 ("kind", "suspension"), ("set", key), ("runs", "runs/%s_%g.h5" % (set_name, xf))):
        g.attrs[k] = v
    for k, v in (("x_f", xf), ("H", H), ("Lx", L), ("Lz", L), ("ca_stiff", ca_s), ("ca_floppy", ca_f),
                 ("t0", t1 / 2), ("t1", t1)):
        g.attrs[k] = float(v)
    stiff, floppy = xf < 1, xf > 0
    t = np.linspace(0.0, t1, 201)
    d = 0.4 - 0.05 * (1 - np.exp(-t / 30.0))
    g["dbar_t/time"] = t
    g["dbar_t/stiff"] = d + 0.01 if stiff else np.full_like(t, NAN)
    g["dbar_t/floppy"] = d - 0.01 if floppy else np.full_like(t, NAN)
    g["dbar_t/all"] = d
    y = y_bins()
    g["profiles/y_over_H"] = y
    shape = np.where(y < 0.1, 0.0, 1.0 + 0.8 * np.sin(8 * y))
    vel = np.where(y < 0.1, NAN, 0.02 * (0.5 - y))
    for sp, present in (("stiff", stiff), ("floppy", floppy)):
        if not present:
            continue
        for q, v in (("n_hat", shape), ("phi_hat", shape), ("v_bar", vel), ("v_prime", np.abs(vel) + 0.01)):
            name = "%s_%s" % (q, sp)
            if "-" + name in masked:
                continue
            write_profile(g, name, np.full(BINS, NAN) if name in masked else v)
        if stiff and floppy and dv_rel and "-dv_rel_" + sp not in masked:
            write_profile(g, "dv_rel_" + sp, np.where(y < 0.15, NAN, -0.3 + y), 0.05)
    if stiff and floppy:
        write_profile(g, "xf_hat", np.where(y < 0.1, NAN, 0.5 + 2 * y))
    if pdf and not (stiff and floppy):
        sp = "stiff" if stiff else "floppy"
        for y0 in (200, 500):
            p = g.create_group("pdf/%s/y%03d" % (sp, y0))
            edges = np.linspace(-0.1, 0.1, 21)
            mid = 0.5 * (edges[1:] + edges[:-1])
            p["edges"] = edges
            p["density"] = np.where(np.arange(20) == 0, 0.0, np.exp(-np.abs(mid) / 0.03) / 0.06)
            p.attrs["samples"] = 1000
            p.attrs["mean"] = 0.0
            p.attrs["stddev"] = 0.04
    if snapshot:
        # Two octahedra as capsules, one straddling x = Lx.
        oct_x = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
        oct_t = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
        pos = np.concatenate([oct_x + [3.0, 2.5, 4.0], oct_x * [1.1, 0.9, 1.0] + [L - 0.3, 6.0, 5.0]])
        g["snapshot/positions"] = pos
        g["snapshot/triangles"] = np.concatenate([oct_t, oct_t + 6]).astype(np.int32)
        g["snapshot/node_species_stiff"] = np.repeat([1 if stiff else 0, 0 if floppy else 1], 6).astype(np.int32)
        g["snapshot"].attrs["time"] = t1


def write_curve(f, cid, set_name, fab=True):
    key, H, L = set_key(set_name)
    ca_s, ca_f, _, n = SETS[set_name]
    c = f.create_group("curves/" + cid)
    c.attrs["set"] = key
    for k, v in (("ca_stiff", ca_s), ("ca_floppy", ca_f), ("H", H),
                 ("phi", n * 4.0 / 3.0 * np.pi / (H * L * L)), ("two_a_over_H", 2.0 / H)):
        c.attrs[k] = float(v)
    x = np.array([0.0, 0.5, 1.0])
    shift = {"A": 0.0, "B": -0.03, "C": 0.02, "D": 0.04}.get(set_name, 0.01)
    cols = {"x_f": x, "dbar_stiff": [0.30 + shift, 0.34 + shift, NAN], "dbar_floppy": [NAN, 0.33 + shift, 0.31 + shift],
            "dbar_all": [0.30 + shift, 0.335 + shift, 0.31 + shift], "E_s": [NAN, 1.2 + shift, NAN],
            "E_f": [NAN, 1.1 + shift, NAN]}
    if fab:
        cols.update({"fab_stiff": [0.08, 0.03, NAN], "fab_floppy": [NAN, 0.12, 0.085]})
    for k, v in cols.items():
        c[k] = np.asarray(v, float)
        if k != "x_f":
            c[k + "_se"] = np.full(3, 0.01)


def write_pair(f, gid, ca_top, ca_bottom):
    g = f.create_group("groups/" + gid)
    g.attrs["kind"] = "pair"
    g.attrs["label"] = "pair Ca %g|%g" % (ca_top, ca_bottom)
    g.attrs["x_f"] = NAN
    g.attrs["ca_top"] = ca_top
    g.attrs["ca_bottom"] = ca_bottom
    t = np.arange(20.0)
    g["time"] = t
    g["separation"] = t - 10.0
    for pos in ("top", "bottom"):
        g["disp_" + pos] = 0.2 * (1 + np.tanh((t - 10) / 3))
        g["uy_" + pos] = 0.2 / 3 / np.cosh((t - 10) / 3) ** 2


def write_isolated(f, ca):
    g = f.create_group("isolated/ca%03d" % round(1000 * ca))
    g.attrs["ca"] = ca
    g["y_over_H"] = np.array([0.15, 0.3, 0.5])
    g["V_S"] = np.array([0.02, 0.01, 0.0]) * (1 + ca)


def make_complete(d):
    """Set A with every kind of group (window 100: f_AB defined), and the curves of sets B, C, D in another
    directory: every figure has data."""
    os.makedirs(d + "/a", exist_ok=True)
    os.makedirs(d + "/bcd", exist_ok=True)
    with h5py.File(d + "/a/analysis.h5", "w") as f:
        write_root(f)
        for i, xf in enumerate((0.0, 0.5, 1.0)):
            write_suspension(f, "g%03d" % i, "A", xf)
        write_pair(f, "g003", 0.2, 0.2)
        write_pair(f, "g004", 0.2, 0.5)
        write_curve(f, "c000", "A")
        write_isolated(f, 0.2)
        write_isolated(f, 0.5)
    with h5py.File(d + "/bcd/analysis.h5", "w") as f:
        write_root(f)
        for i, s in enumerate("BCD"):
            write_curve(f, "c%03d" % i, s, fab=False)


def make_masked(d):
    """Set C (not set A) where analyze found masked bins: the pure-stiff v-bar_p and every v'_p undefined in every
    bin (left out, or written all-NaN), no relative change of v-bar_p for either species; no P(v_p) and no curves."""
    os.makedirs(d, exist_ok=True)
    with h5py.File(d + "/analysis.h5", "w") as f:
        write_root(f)
        write_suspension(f, "g000", "C", 0.0, masked=("-v_bar_stiff", "-v_prime_stiff"), pdf=False)
        write_suspension(f, "g001", "C", 0.5, masked=("v_prime_stiff", "-v_prime_floppy", "-dv_rel_stiff",
                                                      "-dv_rel_floppy"), pdf=False)
        write_suspension(f, "g002", "C", 1.0, masked=("v_prime_floppy",), pdf=False)


def make_pure_match(d):
    """Set E: set A's box, N_p and stiff Ca, another floppy Ca. Its pure-stiff suspension is set A's, so the
    pure-species marks apply to it; the mixture statements of set A do not."""
    os.makedirs(d, exist_ok=True)
    with h5py.File(d + "/analysis.h5", "w") as f:
        write_root(f)
        for i, xf in enumerate((0.0, 0.5, 1.0)):
            write_suspension(f, "g%03d" % i, "E", xf)
        write_curve(f, "c000", "E")


def make_demo_like(d):
    """The embedded demo's analysis: one mixture, X_f = 0.5, window 20 strain; no pure groups, no pairs."""
    os.makedirs(d, exist_ok=True)
    with h5py.File(d + "/analysis.h5", "w") as f:
        write_root(f)
        write_suspension(f, "g000", "D", 0.5, t1=40.0, masked=("v_bar_floppy",), dv_rel=False)
        write_curve(f, "c000", "D", fab=False)


def render(jobs):
    """Runs the script on each {case: (analysis dirs, figure dir)} as `capsflow figures` does, all at once (each
    takes 10-20 s of one core); {case: its stdout}."""
    procs = {}
    for case, (dirs, out) in jobs.items():
        shutil.rmtree(out, ignore_errors=True)
        procs[case] = subprocess.Popen([sys.executable, "-B", SCRIPT, "--out", out, "--", *dirs],
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    outputs = {}
    for case, p in procs.items():
        stdout, stderr = p.communicate()
        if p.returncode != 0:
            raise AssertionError("capsflow_figures.py (%s): exit status %d\n%s%s" % (case, p.returncode, stdout,
                                                                                   stderr))
        outputs[case] = stdout
    return outputs


def lines_of(stdout, name):
    return [l for l in stdout.splitlines() if l.startswith(name + ":")]


def comment_text(g):
    """The text a matplotlib SVG text group stands for (kept in an XML comment)."""
    for node in g.iter():
        if node.tag is ET.Comment and node.text and node.text.strip():
            return node.text.strip()
    return ""


def svg_panels(path):
    """For each panel (group axes_N) of an SVG: [(tick labels, axis label) of its x axis, same of its y axis]."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    root = ET.parse(path, parser=parser).getroot()
    ns = "{http://www.w3.org/2000/svg}g"
    panels = {}
    for g in root.iter(ns):
        gid = g.get("id", "")
        if not re.fullmatch(r"axes_\d+", gid):
            continue
        axes = []
        for axis in g.findall(ns):
            if not axis.get("id", "").startswith("matplotlib.axis_"):
                continue
            ticks = [comment_text(t) for t in axis.findall(ns) if re.fullmatch(r"[xy]tick_\d+", t.get("id", ""))]
            label = [comment_text(t) for t in axis.findall(ns) if t.get("id", "").startswith("text_")]
            axes.append(([t for t in ticks if t], label[0] if label else ""))
        panels[gid] = axes
    return panels


def svg_text(path):
    with open(path, encoding="utf-8") as fh:
        return fh.read()


class Figures(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if MISSING is not None:
            raise unittest.SkipTest("needs numpy, h5py and matplotlib (%s)" % MISSING)
        cls.work = WORKDIR or tempfile.mkdtemp(prefix="capsflow-figures-")
        cls.own = WORKDIR is None
        make_complete(cls.work + "/complete")
        make_masked(cls.work + "/masked")
        make_demo_like(cls.work + "/demo")
        make_pure_match(cls.work + "/pure-match")
        w = cls.work
        cls.out = render({"complete": ([w + "/complete/a", w + "/complete/bcd"], w + "/figs-complete"),
                          "masked": ([w + "/masked"], w + "/figs-masked"),
                          "demo": ([w + "/demo"], w + "/figs-demo"),
                          "pure-match": ([w + "/pure-match"], w + "/figs-pure-match")})

    @classmethod
    def tearDownClass(cls):
        if getattr(cls, "own", False):
            shutil.rmtree(cls.work, ignore_errors=True)

    def figdir(self, case):
        return os.path.join(self.work, "figs-" + case)

    def written(self, case):
        return sorted(n[:-4] for n in os.listdir(self.figdir(case)) if n.endswith(".svg"))

    def assert_readable(self, case):
        """Every panel of every SVG written: tick labels and a label on both axes."""
        names = self.written(case)
        self.assertTrue(names)
        for name in names:
            panels = svg_panels(os.path.join(self.figdir(case), name + ".svg"))
            self.assertTrue(panels, name)
            for gid, axes in panels.items():
                self.assertEqual(len(axes), 2, "%s %s: expected an x and a y axis" % (name, gid))
                for which, (ticks, label) in zip("xy", axes):
                    self.assertGreaterEqual(len(ticks), 2, "%s %s: %s tick labels %s" % (name, gid, which, ticks))
                    self.assertTrue(label, "%s %s: no %s axis label" % (name, gid, which))
            self.assertTrue(os.path.isfile(os.path.join(self.figdir(case), name + ".png")), name)

    def assertInSvg(self, needle, path, present=True):
        """Whether the text `needle` is in the SVG (texts are kept in comments); the message names the file only."""
        found = needle in svg_text(path)
        if found != present:
            self.fail("%r %s in %s" % (needle, "not found" if present else "found", path))

    def assert_counted(self, case):
        n = len(self.written(case))
        self.assertIn("wrote %d figure%s (%d files)" % (n, "" if n == 1 else "s", 2 * n), self.out[case])

    def test_complete_analysis_draws_every_figure_readably(self):
        self.assertEqual(self.written("complete"), ALL_FIGURES)
        self.assert_readable("complete")
        self.assert_counted("complete")
        self.assertNotIn("skipped", self.out["complete"])

    def test_paper_marks_on_set_a(self):
        d = self.figdir("complete")
        self.assertInSvg("paper (S, set A): 0.081 to 0.015", d + "/fig13_fab.svg")
        self.assertInSvg("(set A, pure)", d + "/fig06_phi_hat.svg")
        self.assertInSvg("at $y \\approx H/4$ (set A)", d + "/fig07_enrichment.svg")
        self.assertInSvg("(set A)", d + "/fig08_v_bar.svg")
        # The windows end at 200 strain: the marks at 500, 600 and 800 strain are not drawn (they would stretch
        # the axis beyond the data).
        self.assertInSvg("paper: steady after about 500", d + "/fig03_dbar_t.svg", present=False)

    def test_time_series_mark_the_window_and_the_standard_error(self):
        path = self.figdir("complete") + "/fig03_dbar_t.svg"
        self.assertInSvg("analysis window [100, 200]", path)
        self.assertInSvg("1 SE over the window", path)

    def test_no_paper_marks_outside_set_a(self):
        for case in ("masked", "demo"):
            for name in self.written(case):
                text = svg_text(os.path.join(self.figdir(case), name + ".svg"))
                self.assertFalse("paper" in text.replace("where the paper discusses", ""), (case, name))

    def test_pure_species_marks_follow_the_pure_runs(self):
        d = self.figdir("pure-match")
        self.assert_readable("pure-match")
        self.assertInSvg("(set A, pure)", d + "/fig06_phi_hat.svg")       # its pure-stiff run is set A's
        self.assertInSvg("paper", d + "/fig13_fab.svg", present=False)     # f_AB numbers: set A's mixtures
        self.assertInSvg("(set A)", d + "/fig08_v_bar.svg", present=False)
        self.assertInSvg("(set A)", d + "/fig07_enrichment.svg", present=False)

    def test_masked_bins_are_named_as_the_cause(self):
        out = self.out["masked"]
        self.assert_readable("masked")
        self.assert_counted("masked")
        fig08 = lines_of(out, "fig08_v_bar")
        b = [l for l in fig08 if l.startswith("fig08_v_bar: (b)")]
        c = [l for l in fig08 if l.startswith("fig08_v_bar: (c)")]
        self.assertEqual(len(b), 1, out)
        self.assertIn("reference v_r masked", b[0])            # the pure-stiff group is there, its v-bar_p is not
        self.assertEqual(len(c), 1, out)
        self.assertIn("every bin masked", c[0])
        self.assertIn("|v_r| < 2 SE(v_r)", c[0])
        for line in b + c:
            self.assertNotIn("no pure", line)
        a = [l for l in fig08 if l.startswith("fig08_v_bar: (a)")]
        self.assertTrue(any("every bin of v-bar_p masked (fewer than 200 samples in the bin)" in l for l in a), out)
        path = self.figdir("masked") + "/fig08_v_bar.svg"
        self.assertInSvg("no data:", path)                       # panel (b) stays, saying why it is empty
        # Curves with some masked bins say so, and the caption says why.
        self.assertInSvg("bins masked)", path)
        self.assertInSvg("Bins without a point are masked: v-bar_p: fewer than 200 samples in the bin", path)

    def test_a_figure_masked_everywhere_is_skipped_in_one_line(self):
        out = self.out["masked"]
        self.assertNotIn("fig10_v_prime", self.written("masked"))
        self.assertFalse(os.path.exists(self.figdir("masked") + "/fig10_v_prime.png"))
        lines = lines_of(out, "fig10_v_prime")
        self.assertEqual(len(lines), 1, out)
        self.assertTrue(lines[0].startswith("fig10_v_prime: skipped: no data in any panel: (a) "), lines[0])
        self.assertIn("every bin of v'_p masked", lines[0])
        summary = [l for l in out.splitlines() if l.startswith("capsflow figures: wrote")]
        self.assertEqual(len(summary), 1)
        self.assertIn("fig10_v_prime", summary[0].split("skipped:")[1])

    def test_a_figure_without_its_data_is_not_written(self):
        out = self.out["masked"]
        self.assertNotIn("fig09_pdf", self.written("masked"))
        self.assertEqual(len(lines_of(out, "fig09_pdf")), 1)
        self.assertIn("fig09_pdf: skipped: ", out)

    def test_demo_like_analysis(self):
        """One mixture: fig08 has nothing in any panel (no pure reference, no isolated runs) and is not written;
        the profile figures keep their empty panel (a) readable, with tick labels of their own."""
        out = self.out["demo"]
        self.assertNotIn("fig08_v_bar", self.written("demo"))
        lines = lines_of(out, "fig08_v_bar")
        self.assertEqual(len(lines), 1, out)
        self.assertIn("no pure-stiff group (X_f = 0) in the set to serve as the reference v_r", lines[0])
        for name in ("fig05_n_hat", "fig06_phi_hat", "fig10_v_prime"):
            self.assertIn(name, self.written("demo"))
            self.assertIn("%s: (a): no data: no pure-species group (X_f = 0 or 1) in the set" % name, out)
        self.assert_readable("demo")
        self.assert_counted("demo")
        self.assertInSvg("no data:", self.figdir("demo") + "/fig05_n_hat.svg")


def main(argv):
    global WORKDIR
    if MISSING is not None:
        print("SKIP: the figure tests need numpy, h5py and matplotlib (%s)" % MISSING)
        return SKIP
    if len(argv) >= 2:
        WORKDIR = os.path.abspath(argv[1])
        os.makedirs(WORKDIR, exist_ok=True)
    prog = unittest.main(argv=[argv[0]], exit=False, verbosity=2)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
