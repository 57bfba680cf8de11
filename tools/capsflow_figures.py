#!/usr/bin/env python3
"""capsflow figures: draw the figures of Kumar & Graham's segregation study from `capsflow analyze` output, and
the diagnostics of single runs from `capsflow run` output.

    capsflow_figures.py [--force] --out FIGDIR [--] INPUT...     INPUT: ANALYSIS_DIR or RUN.h5, mixed freely

Reads ANALYSIS_DIR/analysis.h5 (layout: docs/usage.md, "capsflow figures") from each directory and writes
FIGDIR/figNN_<name>.png and .svg for every figure of docs/analysis.md §13 that has data.
Every other INPUT must be a run output (an HDF5 file with /parameters/config and /capsules/species; a checkpoint
or an analysis.h5 is refused): for each, FIGDIR/<file stem>_run_diagnostics.png and .svg, one figure of six
panels against strain: (a) centre heights y_c/H of every capsule, (b) their Taylor deformation D, (c) the
largest volume drift |V/V0 - 1| of each species (log), (d) the step size, (e) what bound the steps
(/series/step_limits, format 4), (f) the contact corrections and events. A panel whose data the file's output
format does not hold says so ("not in this output (format 1): ..."). It replaces the
OUT.trajectories.svg that `capsflow run` drew by hand before (one plotting stack).
Usually run through `capsflow figures` (src/host/cli/figures_command.cpp), which finds this file and a python3
with matplotlib and h5py.

Which data go where:
  * Figures 2-10 and 13 show one set, the "main set": the set with the paper's set A parameters (Ca 0.2/0.5,
    phi 0.2, 2a/H 0.197) if one is present, otherwise the set with the most suspension groups (first given wins
    a tie).
  * Figure 8a adds the isolated-capsule curves (/isolated) whose Ca is the main set's stiff or floppy Ca.
  * Figure 11 uses every pair group of every directory.
  * Figures 14-16 compare sets (/curves of every directory) that differ in one of 2a/H, phi and
    R = Ca_floppy/Ca_stiff and agree in the other two (and in the species' Ca for 14 and 15).

The paper's numbers (the claims of docs/reproduction.md) are marked where the runs shown are the ones they are
about: the statements on mixtures and on X_f (figure 3c at X_f = 0.2, 7a, 8b, 13b) for set A only; the pure-species ones (figure 3b,
6a) on the pure curves whose Ca, phi and 2a/H are set A's, whatever the set's other Ca.

Every panel keeps its own tick labels and axis labels (units in the labels); time series mark the analysis window
and the steady value with a band of one standard error; profile curves say how many bins are masked and the caption
says why. A panel without data stays in its figure, labelled, with the reason ("no data: every bin of v-bar_p
masked (fewer than 200 samples in the bin)"); a figure whose panels are all without data is not written, with one
line on stdout naming each panel's reason ("fig08_v_bar: skipped: no data in any panel: (a) ...; (b) ..."); so is a
figure whose data are absent altogether ("fig13_fab: skipped: ..."). Neither is an error. Exit status: 0 (the
summary lists what was written, possibly nothing); 2 bad input, one line
"capsflow: error: ..." on stderr, nothing written (a directory without analysis.h5, a file of another format, a
checkpoint, two run files of the same stem, an existing output file without --force); 1 a figure failed to draw
(the others are still written).
Each file is written to a temporary name in FIGDIR, synced and renamed (tools/capsflow_atomic.py), so a reader never
sees half a figure; a write, sync or rename that fails (a full disk) stops the command at once with exit status 1 and
one line "capsflow: error: ..." naming the file and the system's reason, the file as it was and no temporary left.
"""

import argparse
import io
import math
import os
import re
import sys
import textwrap

FORMAT = "capsflow-analysis"
FORMAT_VERSION = 1
FIGURES = [
    "fig02_snapshots", "fig03_dbar_t", "fig04_dbar_xf", "fig05_n_hat", "fig06_phi_hat", "fig07_enrichment",
    "fig08_v_bar", "fig09_pdf", "fig10_v_prime", "fig11_pair_collisions", "fig13_fab", "fig14_confinement",
    "fig15_volume_fraction", "fig16_rigidity_ratio",
]
EXTENSIONS = ("png", "svg")

# The paper's set A (docs/analysis.md §2) and the numbers it states (docs/reproduction.md's claims).
SET_A = {"ca_stiff": 0.2, "ca_floppy": 0.5, "phi": 0.2, "two_a_over_H": 0.197}
PAPER_FAB_STIFF = [(0.0, 0.081), (0.8, 0.015)]
PAPER_FAB_FLOPPY = [(1.0, 0.083), (0.2, 0.1413)]

STIFF = "tab:blue"
FLOPPY = "tab:red"
OVERALL = "black"
# One palette for the species everywhere (the study's figures, the snapshots, a run's diagnostics and `capsflow render`):
# stiff (the smaller Ca) tab:blue, floppy (the larger) tab:red.
SNAP_STIFF = STIFF
SNAP_FLOPPY = FLOPPY


class InputProblem(Exception):
    """Bad input the user can fix: exit 2 with one line."""


def fail(message):
    print("capsflow: error: " + " ".join(str(message).split()), file=sys.stderr)
    sys.exit(2)


try:
    # The atomic writer shared with tools/run_store.py, beside this script (tools/, or share/capsflow once installed).
    from capsflow_atomic import WriteFailed, write_atomically
except ImportError as e:  # pragma: no cover - an incomplete installation
    fail("capsflow figures: capsflow_atomic.py is missing beside %s (%s): reinstall" % (__file__, e))

try:
    import numpy as np
    import h5py
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, FancyArrowPatch, Rectangle
    from matplotlib.ticker import MaxNLocator
except ImportError as e:  # pragma: no cover - depends on the machine
    fail("capsflow figures needs python3 with numpy, matplotlib and h5py (%s); on Debian: apt-get install "
         "python3-matplotlib python3-h5py" % e)

plt.rcParams.update({
    "svg.hashsalt": "capsflow",      # reproducible SVG ids
    "font.size": 9,
    "axes.titlesize": 9,
    "legend.fontsize": 7,
    "legend.frameon": False,
    "lines.linewidth": 1.2,
    "lines.markersize": 4,
})


# ---------------------------------------------------------------------------------------------------------------
# Reading analysis.h5

def _str(v):
    if isinstance(v, bytes):
        return v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.shape == ():
        return _str(v[()])
    return str(v)


def _float(v, default=math.nan):
    try:
        return float(v)
    except (TypeError, ValueError):
        return default


def close(a, b, rel=0.02):
    """Same parameter value within 2% (table values are rounded: 2a/H = 0.197 is 0.19695)."""
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)):
        return False
    return abs(a - b) <= rel * max(abs(a), abs(b), 1e-12)


class Node:
    """A group of analysis.h5 with safe access: a missing dataset is None ("no data")."""

    def __init__(self, h5group, source):
        self.g = h5group
        self.source = source            # the directory it came from (for messages)

    def attr(self, name, default=None):
        if name not in self.g.attrs:
            return default
        return self.g.attrs[name]

    def fattr(self, name):
        return _float(self.attr(name))

    def sattr(self, name, default=""):
        v = self.attr(name)
        return default if v is None else _str(v)

    def has(self, path):
        return path in self.g

    def data(self, path, dtype=float):
        """The dataset as a numpy array, or None when it is absent or empty."""
        if path not in self.g:
            return None
        obj = self.g[path]
        if not isinstance(obj, h5py.Dataset):
            return None
        a = np.asarray(obj[()], dtype=dtype)
        return a if a.size > 0 else None

    def child(self, path):
        if path not in self.g or not isinstance(self.g[path], h5py.Group):
            return None
        return Node(self.g[path], self.source)

    def children(self, path=None):
        g = self.g if path is None else (self.g[path] if path in self.g else None)
        if g is None or not isinstance(g, h5py.Group):
            return []
        return [(k, Node(g[k], self.source)) for k in sorted(g.keys()) if isinstance(g[k], h5py.Group)]


class Group(Node):
    @property
    def kind(self):
        return self.sattr("kind")

    @property
    def x_f(self):
        return self.fattr("x_f")

    @property
    def set(self):
        return self.sattr("set")

    @property
    def label(self):
        return self.sattr("label") or self.sattr("key")

    @property
    def window(self):
        return self.fattr("t1") - self.fattr("t0")


class Curve(Node):
    @property
    def set(self):
        return self.sattr("set")

    @property
    def R(self):
        return self.fattr("ca_floppy") / self.fattr("ca_stiff")

    def params(self):
        return {k: self.fattr(k) for k in ("ca_stiff", "ca_floppy", "phi", "two_a_over_H")}


class Analysis:
    """Every analysis.h5 given, merged."""

    def __init__(self, dirs):
        self.files = []
        self.groups = []      # Group, every directory
        self.curves = []      # Curve, one per set (the first directory that has the set wins)
        self.isolated = []    # Node of /isolated/caNNN
        self.notes = []
        for d in dirs:
            path = os.path.join(d, "analysis.h5")
            if not os.path.isdir(d):
                raise InputProblem("%s: not a directory (expected an analysis directory holding analysis.h5)" % d)
            if not os.path.isfile(path):
                raise InputProblem("%s: no analysis.h5 in this directory (write it with capsflow analyze)" % d)
            try:
                f = h5py.File(path, "r")
            except OSError as e:
                raise InputProblem("%s: cannot read as HDF5 (%s)" % (path, e))
            self.files.append(f)
            fmt = _str(f.attrs["format"]) if "format" in f.attrs else None
            if fmt != FORMAT:
                raise InputProblem("%s: not a capsflow analysis file (attribute format = %r, expected %r)"
                                   % (path, fmt, FORMAT))
            ver = int(f.attrs["format_version"]) if "format_version" in f.attrs else None
            if ver != FORMAT_VERSION:
                raise InputProblem("%s: format_version %s is not supported (this script reads %d)"
                                   % (path, ver, FORMAT_VERSION))
            root = Node(f, d)
            self.groups += [Group(n.g, d) for _, n in root.children("groups")]
            for _, n in root.children("curves"):
                c = Curve(n.g, d)
                dup = [o for o in self.curves if o.set == c.set]
                if dup:
                    self.notes.append("set '%s' is in both %s and %s: using %s" % (c.set, dup[0].source, d,
                                                                                  dup[0].source))
                    continue
                self.curves.append(c)
            self.isolated += [n for _, n in root.children("isolated")]

    def close(self):
        for f in self.files:
            f.close()

    def suspension(self, set_key):
        gs = [g for g in self.groups if g.kind == "suspension" and g.set == set_key and math.isfinite(g.x_f)]
        return sorted(gs, key=lambda g: g.x_f)

    def curve(self, set_key):
        for c in self.curves:
            if c.set == set_key:
                return c
        return None

    def main_set(self):
        """(set key, is the paper's set A); None when there is no suspension group and no curve."""
        keys = []
        for g in self.groups:
            if g.kind == "suspension" and g.set not in keys:
                keys.append(g.set)
        for c in self.curves:
            if c.set not in keys:
                keys.append(c.set)
        if not keys:
            return None, False

        def is_set_a(key):
            c = self.curve(key)
            if c is not None:
                p = c.params()
                return all(close(p[k], v) for k, v in SET_A.items())
            gs = self.suspension(key)
            if not gs:
                return False
            g = gs[0]
            return (close(g.fattr("ca_stiff"), SET_A["ca_stiff"]) and close(g.fattr("ca_floppy"), SET_A["ca_floppy"])
                    and close(2.0 / g.fattr("H"), SET_A["two_a_over_H"]))

        for k in keys:
            if is_set_a(k):
                return k, True
        best = max(keys, key=lambda k: (len(self.suspension(k)), -keys.index(k)))
        return best, False

    def set_params(self, key):
        """ca_stiff, ca_floppy, phi, two_a_over_H of a set: from its /curves entry, else from its first group (a = 1,
        N_p from the group key)."""
        c = self.curve(key)
        if c is not None:
            return c.params()
        gs = self.suspension(key)
        if not gs:
            return {}
        g = gs[0]
        H, Lx, Lz = g.fattr("H"), g.fattr("Lx"), g.fattr("Lz")
        m = re.search(r"\bNp=(\d+)", g.sattr("key"))
        phi = int(m.group(1)) * 4.0 / 3.0 * math.pi / (H * Lx * Lz) if m and H * Lx * Lz > 0 else math.nan
        return {"ca_stiff": g.fattr("ca_stiff"), "ca_floppy": g.fattr("ca_floppy"), "phi": phi,
                "two_a_over_H": 2.0 / H if H > 0 else math.nan}


# ---------------------------------------------------------------------------------------------------------------
# Drawing helpers

def is_xf(g, value):
    return abs(g.x_f - value) < 1e-6


def mixture(g):
    return 1e-6 < g.x_f < 1 - 1e-6


def xf_label(x):
    return r"$X_f = %g$" % round(x, 3)


def has_species(g, sp):
    """Whether a suspension group holds capsules of species sp (its X_f says so)."""
    return g.x_f < 1 - 1e-6 if sp == "stiff" else g.x_f > 1e-6


def panel_letter(ax, letter):
    ax.text(-0.16, 1.03, "(%s)" % letter, transform=ax.transAxes, fontweight="bold", va="bottom")


def shades(cmap_name, n, lo=0.35, hi=1.0):
    cmap = plt.get_cmap(cmap_name)
    if n <= 1:
        return [cmap(hi)]
    return [cmap(lo + (hi - lo) * i / (n - 1)) for i in range(n)]


def plot_err(ax, x, y, se=None, **kw):
    """A line with error bars of one standard error (where an SE is given and finite)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if se is not None:
        se = np.asarray(se, float)
        if se.shape != y.shape or not np.any(np.isfinite(se)):
            se = None
        else:
            se = np.where(np.isfinite(se), se, 0.0)
    return ax.errorbar(x, y, yerr=se, capsize=1.5, elinewidth=0.7, **kw)


def y_guides(ax, lines=(0.2, 0.3)):
    for v in lines:
        ax.axvline(v, color="0.5", ls=":", lw=0.8, zorder=0)
    ax.set_xlim(0.0, 0.5)


PROFILE_XLABEL = r"$y/H$ (wall $\leftarrow$, centreline $\rightarrow$)"
GUIDES_CAPTION = "dotted: y = 0.2H and 0.3H, where the paper discusses its profiles"

# Why capsflow analyze leaves a bin undefined (NaN), per profile (docs/analysis.md §7-§9). A
# profile whose bins are all undefined is not written at all.
MASK_RULE = {
    "n_hat": "no records in the window",
    "phi_hat": "no slab series or capsule volumes to compute it from",
    "v_bar": "fewer than 200 samples in the bin",
    "v_prime": "fewer than 200 samples in the bin",
    "xf_hat": "phi_s + phi_f < 1e-3 phi in the bin",
    "dv_rel": "v-bar_p or the pure reference v_r undefined, or |v_r| < 2 SE(v_r)",
}
QUANTITY_NAME = {"n_hat": "n-hat", "phi_hat": "phi-hat", "v_bar": "v-bar_p", "v_prime": "v'_p",
                 "xf_hat": "X_f-hat", "dv_rel": "(v-bar_p - v_r)/v_r"}


def finite_range(values):
    """(lo, hi) of the finite numbers in a list of arrays, or None."""
    v = [np.asarray(a, float).ravel() for a in values if a is not None]
    v = np.concatenate(v) if v else np.empty(0)
    v = v[np.isfinite(v)]
    return (float(v.min()), float(v.max())) if v.size else None


def padded(lo, hi, frac=0.06):
    if hi <= lo:
        d = max(abs(lo), 1.0) * 0.1
        return lo - d, hi + d
    d = (hi - lo) * frac
    return lo - d, hi + d


class Figure:
    """One figure being drawn: its panels' state, the notes, the caption lines; save() writes PNG and SVG
    atomically.

    A panel is either a data panel (`drawn`), an empty panel (`empty`: its axes keep ticks and labels and say
    "no data" with the reason) or a schematic (`schematic`: no axes, not data). finish() skips a figure whose
    panels are all empty or schematic with one line naming every panel's reason, and otherwise prints the notes
    and lays the figure out with its caption."""

    def __init__(self, name, out, log):
        self.name = name
        self.out = out
        self.log = log
        self.pending = []          # panel notes, printed by finish() when the figure is written
        self.data_panels = []
        self.empty_panels = []     # (letter, reason)
        self.caption = []

    def note(self, text):
        self.log.append("%s: %s" % (self.name, text))
        print("%s: %s" % (self.name, text))

    def panel_note(self, letter, text):
        self.pending.append("(%s): %s" % (letter, text) if letter else text)

    def drawn(self, letter):
        self.data_panels.append(letter)

    def add_caption(self, text):
        if text not in self.caption:
            self.caption.append(text)

    def empty(self, ax, letter, reason, xlabel, ylabel, xlim=None, ylim=None):
        """An empty panel that stays readable: axis labels, tick labels and the reason it is empty."""
        self.empty_panels.append((letter, reason))
        width = max(24, int(ax.get_position().width * ax.figure.get_figwidth() * 14))   # characters at 7 pt
        ax.text(0.5, 0.5, "no data:\n" + textwrap.fill(reason, width), transform=ax.transAxes, ha="center",
                va="center", color="0.35", fontsize=7)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if xlim is not None:
            ax.set_xlim(*xlim)
        if ylim is not None:
            ax.set_ylim(*ylim)

    def schematic(self, ax):
        ax.set_axis_off()
        ax.set_gid("schematic")   # its SVG group is not an "axes_N" panel

    def finish(self, fig):
        """The figure ready to save, or None (closed) when no panel shows data."""
        if not self.data_panels:
            plt.close(fig)
            reasons = "; ".join("(%s) %s" % (k, r) if k else r for k, r in self.empty_panels)
            self.note("skipped: no data in any panel%s" % (": " + reasons if reasons else ""))
            return None
        for letter, reason in self.empty_panels:
            self.note("(%s): no data: %s" % (letter, reason) if letter else "no data: %s" % reason)
        for n in self.pending:
            self.note(n)
        h = fig.get_size_inches()[1]
        if self.caption:
            text = "\n".join(self.caption)
            fig.text(0.01, 0.01, text, ha="left", va="bottom", fontsize=7, color="0.25")
            bottom = (0.14 * len(self.caption) + 0.06) / h
        else:
            bottom = 0.0
        fig.tight_layout(rect=(0, bottom, 1, 1))
        return fig

    def save(self, fig):
        """Each file drawn in memory, then written atomically (capsflow_atomic: a failed write raises WriteFailed,
        which stops the whole command)."""
        written = []
        try:
            for ext in EXTENSIONS:
                final = os.path.join(self.out, "%s.%s" % (self.name, ext))
                meta = {"Date": None} if ext == "svg" else {"Software": None}
                buf = io.BytesIO()
                fig.savefig(buf, format=ext, dpi=150, metadata=meta)
                write_atomically(final, buf.getvalue())
                written.append(final)
        finally:
            plt.close(fig)
        return written


def one_reason(reasons):
    """One message for a panel whose curves all failed: the common reason, or each curve's."""
    distinct = []
    for _, r in reasons:
        if r not in distinct:
            distinct.append(r)
    if len(distinct) == 1:
        return distinct[0]
    return "; ".join("%s: %s" % (who, r) for who, r in reasons)


PURE = ((0.0, "stiff", STIFF, "S", "o"), (1.0, "floppy", FLOPPY, "F", "s"))


def pure_groups(gs, reasons):
    """The pure-stiff (X_f = 0) and pure-floppy (X_f = 1) groups present, as (x, species, colour, label, marker,
    group); the absent ones are added to reasons as (who, why), both in one entry when both are absent."""
    found = [(x, sp, col, lab, m, next((g for g in gs if is_xf(g, x)), None)) for x, sp, col, lab, m in PURE]
    missing = [(sp, x) for x, sp, _, _, _, g in found if g is None]
    if len(missing) == 2:
        reasons.append(("pure species", "no pure-species group (X_f = 0 or 1) in the set"))
    elif missing:
        reasons.append(("pure " + missing[0][0], "no pure-%s group (X_f = %d) in the set" % (missing[0][0],
                                                                                          int(missing[0][1]))))
    return [f for f in found if f[-1] is not None]


# ---------------------------------------------------------------------------------------------------------------
# The paper's reference marks (docs/reproduction.md), each drawn only where the runs shown are the ones the paper's
# number is about: set A's mixtures (Ca 0.2/0.5, phi 0.2, 2a/H 0.197) for the X_f-dependent statements, a pure
# suspension at set A's phi and 2a/H of the same Ca for the pure-species ones (a pure run does not depend on the
# other species' Ca).

def matches_set_a(params):
    return all(close(params.get(k), v) for k, v in SET_A.items())


def matches_set_a_pure(params, species):
    key = "ca_stiff" if species == "stiff" else "ca_floppy"
    return (close(params.get(key), SET_A[key]) and close(params.get("phi"), SET_A["phi"])
            and close(params.get("two_a_over_H"), SET_A["two_a_over_H"]))


# ---------------------------------------------------------------------------------------------------------------
# Profiles: each curve with the cause of its absence

def profile_of(A, g, qty, sp=None):
    """(y/H, value, se, None) of profiles/<qty>[_<sp>] of group g, or (None, None, None, reason) naming why there is
    nothing to draw: no capsules of the species, every bin masked (with the masking rule), no pure reference."""
    name = qty if sp is None else "%s_%s" % (qty, sp)
    if sp is not None and not has_species(g, sp):
        return None, None, None, "no %s capsules at %s" % (sp, xf_label(g.x_f))
    y = g.data("profiles/y_over_H")
    v = g.data("profiles/" + name)
    if y is None:
        return None, None, None, "no profiles (profiles/y_over_H) in group %s" % g.label
    if v is None:
        if qty == "dv_rel":
            return None, None, None, dv_rel_cause(A, g, sp)
        return None, None, None, "every bin of %s masked (%s)" % (QUANTITY_NAME[qty], MASK_RULE[qty])
    if v.shape != y.shape:
        return None, None, None, "profiles/%s has %d bins, profiles/y_over_H %d" % (name, v.size, y.size)
    if not np.isfinite(v).any():
        return None, None, None, "every bin of %s masked (%s)" % (QUANTITY_NAME[qty], MASK_RULE[qty])
    se = g.data("profiles/%s_se" % name)
    return y, v, se if se is not None and se.shape == v.shape else None, None


def dv_rel_cause(A, g, sp):
    """Why mixture g has no dv_rel_<sp>: analyze writes it against the pure group of the set, and not at all when
    every bin is masked."""
    pure_x = 0.0 if sp == "stiff" else 1.0
    pure = next((p for p in A.suspension(g.set) if is_xf(p, pure_x)), None)
    if pure is None:
        return "no pure-%s group (X_f = %d) in the set to serve as the reference v_r" % (sp, int(pure_x))
    own = g.data("profiles/v_bar_" + sp)
    if own is None or not np.isfinite(own).any():
        return "every bin of the mixture's v-bar_p masked (%s)" % MASK_RULE["v_bar"]
    ref = pure.data("profiles/v_bar_" + sp)
    if ref is None or not np.isfinite(ref).any():
        return "every bin of the pure-%s reference v_r masked (%s)" % (sp, MASK_RULE["v_bar"])
    return "every bin masked (%s)" % MASK_RULE["dv_rel"]


class CurveSet:
    """Curves of one panel: draws the ones with data, remembers why the others are missing and which bins are
    masked, and gives the y values drawn (for a common y range)."""

    def __init__(self, A, F, ax, letter, qty):
        self.A, self.F, self.ax, self.letter, self.qty = A, F, ax, letter, qty
        self.reasons = []          # (who, reason)
        self.values = []
        self.count = 0

    def add(self, g, sp, who, label, **style):
        y, v, se, reason = profile_of(self.A, g, self.qty, sp)
        if reason is not None:
            self.reasons.append((who, reason))
            return False
        masked = int(np.count_nonzero(~np.isfinite(v)))
        if masked:
            label += " (%d of %d bins masked)" % (masked, v.size)
            self.F.add_caption("Bins without a point are masked: %s: %s."
                               % (QUANTITY_NAME[self.qty], MASK_RULE[self.qty]))
        plot_err(self.ax, y, v, se, label=label, **style)
        self.values += [v, v + (se if se is not None else 0.0), v - (se if se is not None else 0.0)]
        self.count += 1
        return True

    def finish(self):
        """Notes the missing curves (when others were drawn); True when something was drawn."""
        if self.count:
            for who, r in self.reasons:
                self.F.panel_note(self.letter, "%s: %s" % (who, r))
            return True
        return False

    def why_empty(self, default):
        return one_reason(self.reasons) if self.reasons else default


def common_ylim(axes, ranges, include=(), floor=None):
    """One y range for several panels of one quantity, so that they compare at a glance."""
    r = finite_range([np.array(x) for x in ranges] + [np.array(include, float)])
    if r is None:
        return None
    lo, hi = padded(*r)
    if floor is not None and r[0] >= floor:
        lo = floor
    for ax in axes:
        ax.set_ylim(lo, hi)
    return lo, hi


# ---------------------------------------------------------------------------------------------------------------
# The figures. Each returns a matplotlib figure, or None after printing one line saying why it was skipped.

def fig02_snapshots(A, ctx, F):
    gs = [g for g in A.suspension(ctx.main) if g.has("snapshot/positions") and g.has("snapshot/triangles")]
    if not gs:
        F.note("skipped: no suspension group of set '%s' has snapshot/positions and snapshot/triangles" % ctx.main)
        return None
    n = len(gs)
    ncol = 2 if n > 1 else 1
    nrow = (n + ncol - 1) // ncol
    g0 = gs[0]
    H, Lx = g0.fattr("H"), g0.fattr("Lx")
    aspect = H / (1.5 * Lx) if H > 0 and Lx > 0 else 0.7
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.2 * ncol, 5.2 * aspect * nrow + 0.6), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for ax, g in zip(axes.flat, gs):
        if draw_snapshot(ax, g, F):
            F.drawn(g.label)
    # Two lines: the set key alone is as wide as a one-panel figure.
    fig.suptitle("Snapshots in the shear plane (x-y): stiff blue, floppy red\nset %s" % ctx.main,
                 fontsize=8)
    return F.finish(fig)


def capsule_labels(tri, nn):
    """Connected components of the mesh (one per capsule), by label propagation over the triangles."""
    lab = np.arange(nn)
    while True:
        m = lab[tri].min(axis=1)
        new = lab.copy()
        for k in range(3):
            np.minimum.at(new, tri[:, k], m)
        new = new[new]                      # pointer jumping speeds up convergence
        if np.array_equal(new, lab):
            break
        lab = new
    _, comp = np.unique(lab, return_inverse=True)
    return comp


def draw_snapshot(ax, g, F):
    H, Lx, Lz = g.fattr("H"), g.fattr("Lx"), g.fattr("Lz")
    pos = g.data("snapshot/positions")
    tri = g.data("snapshot/triangles", dtype=np.int64)
    stiff = g.data("snapshot/node_species_stiff", dtype=np.int64)
    if pos is None or tri is None or pos.ndim != 2 or pos.shape[1] != 3 or tri.ndim != 2 or tri.shape[1] != 3 \
            or tri.min() < 0 or tri.max() >= pos.shape[0]:
        F.empty(ax, None, "snapshot of %s unreadable (snapshot/positions, snapshot/triangles malformed)" % g.label,
                r"$x/a$", r"$y/a$", (0, 1.5 * Lx), (0, H))
        return False
    if stiff is None or stiff.shape[0] != pos.shape[0]:
        stiff = np.zeros(pos.shape[0], dtype=np.int64)
        stiff[:] = 1 if is_xf(g, 0.0) else 0
        F.panel_note(None, "%s: no snapshot/node_species_stiff, species colours from X_f" % g.label)
    comp = capsule_labels(tri, pos.shape[0])
    ncap = comp.max() + 1
    cnt = np.bincount(comp, minlength=ncap)
    cx = np.bincount(comp, weights=pos[:, 0], minlength=ncap) / cnt
    cz = np.bincount(comp, weights=pos[:, 2], minlength=ncap) / cnt
    shift = np.floor(cx / Lx) * Lx if Lx > 0 else np.zeros(ncap)        # centroids into [0, Lx)
    zw = cz - (np.floor(cz / Lz) * Lz if Lz > 0 else 0.0)
    x = pos[:, 0] - shift[comp]
    tcap = comp[tri[:, 0]]
    # Shading by the z component of each triangle's normal, so capsules read as 3D bodies.
    p0, p1, p2 = pos[tri[:, 0]], pos[tri[:, 1]], pos[tri[:, 2]]
    nrm = np.cross(p1 - p0, p2 - p0)
    nz = np.abs(nrm[:, 2]) / np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)
    shade = 0.55 + 0.45 * nz
    base = np.where(stiff[tri[:, 0]][:, None] > 0, np.array(matplotlib.colors.to_rgb(SNAP_STIFF)),
                    np.array(matplotlib.colors.to_rgb(SNAP_FLOPPY)))
    colours = np.clip(base * shade[:, None], 0, 1)
    xmin, xmax = 0.0, 1.5 * Lx
    xt = np.stack([x[tri[:, 0]], x[tri[:, 1]], x[tri[:, 2]]], axis=1)
    yt = np.stack([pos[tri[:, 0], 1], pos[tri[:, 1], 1], pos[tri[:, 2], 1]], axis=1)
    idx, offs = [], []
    for k in (-1, 0, 1, 2):                 # periodic copies that reach into [0, 1.5 Lx]
        sel = np.nonzero((xt.max(axis=1) + k * Lx >= xmin) & (xt.min(axis=1) + k * Lx <= xmax))[0]
        idx.append(sel)
        offs.append(np.full(sel.size, k * Lx))
    idx, offs = np.concatenate(idx), np.concatenate(offs)
    if idx.size:
        # Painter's algorithm over all copies: far capsules (small z) first, each capsule's triangles by z.
        tz = (p0[:, 2] + p1[:, 2] + p2[:, 2]) / 3.0
        order = np.lexsort((tz[idx], zw[tcap[idx]]))
        idx, offs = idx[order], offs[order]
        polys = np.stack([xt[idx] + offs[:, None], yt[idx]], axis=2)
        # Rasterized inside the SVG too: a snapshot has 10^4 to 10^5 triangles.
        ax.add_collection(PolyCollection(polys, facecolors=colours[idx], edgecolors=colours[idx], linewidths=0.15,
                                         rasterized=True))
    ax.axhline(0.0, color="k", lw=2)
    ax.axhline(H, color="k", lw=2)
    ax.axvline(Lx, color="0.6", lw=0.6, ls="--")
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(-0.03 * H, 1.03 * H)
    ax.set_aspect("equal")
    snap = g.child("snapshot")
    t = snap.fattr("time") if snap is not None else math.nan
    title = xf_label(g.x_f) + ("" if not math.isfinite(t) else r", $\dot\gamma_w t = %g$" % round(t, 1))
    ax.set_title(title)
    ax.set_xlabel(r"$x/a$ (dashed: $x = L_x$)")
    ax.set_ylabel(r"$y/a$ (walls at 0 and $H$)")
    return True


def steady_band(ax, A, g, sp, col, label):
    """The steady d-bar/(H/2) of species sp in group g (/curves) as a line over the window with a band of one SE."""
    c = A.curve(g.set)
    if c is None:
        return None
    x, v, se = c.data("x_f"), c.data("dbar_" + sp), c.data("dbar_%s_se" % sp)
    if x is None or v is None:
        return None
    i = np.flatnonzero(np.abs(x - g.x_f) < 1e-9)
    if i.size == 0 or not math.isfinite(v[i[0]]):
        return None
    val = float(v[i[0]])
    err = float(se[i[0]]) if se is not None and math.isfinite(se[i[0]]) else 0.0
    t0, t1 = g.fattr("t0"), g.fattr("t1")
    if not (math.isfinite(t0) and math.isfinite(t1)):
        return None
    ax.fill_between([t0, t1], [val - err] * 2, [val + err] * 2, color=col, alpha=0.25, lw=0)
    ax.plot([t0, t1], [val, val], color=col, lw=1.6, ls="--", label=label)
    return [val - err, val + err]


def mark_window(ax, groups):
    seen = []
    for g in groups:
        w = (g.fattr("t0"), g.fattr("t1"))
        if all(math.isfinite(v) for v in w) and w not in seen:
            ax.axvspan(w[0], w[1], color="0.9", zorder=0, lw=0,
                       label="analysis window [%.4g, %.4g]" % w if not seen else None)
            seen.append(w)


def paper_time_mark(ax, t, text, tmax, style=":"):
    """A vertical mark at strain t (a number the paper states), only where the series reaches it."""
    if tmax is not None and t <= tmax:
        ax.axvline(t, color="k", lw=0.9, ls=style, zorder=1, label=text)
        return True
    return False


def fig03_dbar_t(A, ctx, F):
    gs = A.suspension(ctx.main)
    mixes = [g for g in gs if mixture(g) and g.has("dbar_t/time")]
    mix = min(mixes, key=lambda g: abs(g.x_f - 0.2)) if mixes else None
    if not any(g.has("dbar_t/time") for g in gs):
        F.note("skipped: no d-bar(t) (dbar_t/*) in the suspension groups of set '%s'" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.9), gridspec_kw={"width_ratios": [0.8, 1, 1]})
    draw_d_schematic(axs[0])
    F.schematic(axs[0])
    panel_letter(axs[0], "a")
    xlabel, ylabel = r"$\dot\gamma_w t$ (strain)", r"$\bar{d}/(H/2)$"
    ranges, tmax_all, times = [], [], []
    band = "steady value $\\pm$ 1 SE over the window"

    ax = axs[1]
    panel_letter(ax, "b")
    ax.set_title("pure species")
    drawn, why = [], []
    for _, sp, col, lab, _, g in pure_groups(gs, why):
        t, d = g.data("dbar_t/time"), g.data("dbar_t/" + sp)
        if t is None or d is None or t.shape != d.shape or not np.isfinite(d).any():
            why.append((g.label, "dbar_t/time and dbar_t/%s missing, of different lengths or all NaN" % sp))
            continue
        ax.plot(t, d, color=col, lw=0.8, label="%s (%s)" % (lab, xf_label(g.x_f)))
        ranges += [d, steady_band(ax, A, g, sp, col, None)]
        tmax_all.append(float(np.nanmax(t)))
        times.append(t)
        drawn.append((g, sp))
    if drawn:
        F.drawn("b")
        mark_window(ax, [g for g, _ in drawn])
        ax.plot([], [], color="0.4", lw=1.6, ls="--", label=band)
        if all(matches_set_a_pure(ctx.params, sp) for _, sp in drawn):
            paper_time_mark(ax, 500.0, "paper: steady after about 500 (set A)", max(tmax_all))
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.legend(loc="best")
        for who, w in why:
            F.panel_note("b", "%s: %s" % (who, w))
    else:
        F.empty(ax, "b", one_reason(why), xlabel, ylabel)

    ax = axs[2]
    panel_letter(ax, "c")
    drawn_c = False
    if mix is None:
        F.empty(ax, "c", "no mixture group (0 < X_f < 1) with dbar_t in the set", xlabel, ylabel)
    else:
        t = mix.data("dbar_t/time")
        for sp, col, lab in (("stiff", STIFF, "S"), ("floppy", FLOPPY, "F"), ("all", OVERALL, "overall")):
            d = mix.data("dbar_t/" + sp)
            if d is None or t is None or d.shape != t.shape or not np.isfinite(d).any():
                F.panel_note("c", "%s: dbar_t/%s missing, of another length than dbar_t/time or all NaN"
                             % (mix.label, sp))
                continue
            ax.plot(t, d, color=col, lw=0.8, label=lab)
            ranges += [d, steady_band(ax, A, mix, sp, col, None)]
            times.append(t)
            drawn_c = True
        runs = len(mix.sattr("runs").split(",")) if mix.sattr("runs") else 0
        ax.set_title("mixture, " + xf_label(mix.x_f) + (" (average of %d runs)" % runs if runs > 1 else
                                                         " (1 run)" if runs == 1 else ""))
        if drawn_c:
            F.drawn("c")
            mark_window(ax, [mix])
            ax.plot([], [], color="0.4", lw=1.6, ls="--", label=band)
            if matches_set_a(ctx.params) and is_xf(mix, 0.2):
                tmax = float(np.nanmax(t))
                paper_time_mark(ax, 600.0, "paper: S turns toward the walls after about 600", tmax)
                paper_time_mark(ax, 800.0, "paper: overall nearly steady after 800", tmax, "-.")
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.legend(loc="best")
        else:
            F.empty(ax, "c", "no d-bar(t) of any species in %s" % mix.label, xlabel, ylabel)
    # (b) and (c) on the same axes: the pure species and the mixture compare at a glance.
    common_ylim([axs[1], axs[2]], [r for r in ranges if r is not None])
    tr = finite_range(times)
    if tr is not None:
        for ax in axs[1:]:
            ax.set_xlim(*padded(*tr, frac=0.02))
    F.add_caption("d-bar(t): mean over the capsules of a species (and over the runs of a group at equal record "
                  "index); grey: the analysis window; dashed line and band: the steady d-bar ± 1 block SE over it.")
    return F.finish(fig)


def draw_d_schematic(ax):
    ax.set_xlim(0, 1.6)
    ax.set_ylim(-0.08, 1.08)
    ax.axhline(0, color="k", lw=2)
    ax.axhline(1, color="k", lw=2)
    ax.axhline(0.5, color="0.4", lw=0.8, ls="--")
    ys = np.linspace(0, 1, 9)
    for y in ys[1:-1]:
        u = 4 * y * (1 - y) * 0.45
        ax.add_patch(FancyArrowPatch((0.08, y), (0.08 + u, y), arrowstyle="-|>", mutation_scale=7, color="0.6",
                                     lw=0.7))
    yy = np.linspace(0, 1, 50)
    ax.plot(0.08 + 4 * yy * (1 - yy) * 0.45, yy, color="0.6", lw=0.7)
    ax.add_patch(Circle((1.05, 0.8), 0.1, facecolor=SNAP_STIFF, edgecolor="k", lw=0.6))
    ax.add_patch(FancyArrowPatch((1.05, 0.5), (1.05, 0.8), arrowstyle="<|-|>", mutation_scale=8, color="k",
                                 lw=0.8))
    ax.text(1.1, 0.64, r"$d = |y_c - H/2|$", fontsize=8)
    ax.text(1.3, 0.44, "centreline", fontsize=7, color="0.4")
    ax.text(0.6, 1.02, "wall $y = H$", fontsize=7)
    ax.text(0.6, -0.07, "wall $y = 0$", fontsize=7)
    ax.set_title("definition of $d$")


def curve_series(c, name):
    """(x_f, value, se) of /curves/cNNN/<name>, with the NaN points dropped; None if absent or all NaN."""
    x, v = c.data("x_f"), c.data(name)
    if x is None or v is None or x.shape != v.shape:
        return None
    se = c.data(name + "_se")
    if se is None or se.shape != v.shape:
        se = np.full_like(v, np.nan)
    ok = np.isfinite(x) & np.isfinite(v)
    if not ok.any():
        return None
    return x[ok], v[ok], se[ok]


def fig04_dbar_xf(A, ctx, F):
    c = A.curve(ctx.main)
    if c is None:
        F.note("skipped: no /curves entry for set '%s'" % ctx.main)
        return None
    series = (("dbar_stiff", STIFF, "S", "o"), ("dbar_floppy", FLOPPY, "F", "s"), ("dbar_all", OVERALL, "overall",
                                                                                   "^"))
    data = [(curve_series(c, n), col, lab, m) for n, col, lab, m in series]
    if all(d is None for d, *_ in data):
        F.note("skipped: set '%s' has no steady d-bar (dbar_stiff, dbar_floppy, dbar_all all absent or NaN)" % ctx.main)
        return None
    fig, ax = plt.subplots(figsize=(4.6, 3.8))
    for d, col, lab, m in data:
        if d is not None:
            plot_err(ax, d[0], d[1], d[2], color=col, marker=m, label=lab)
    F.drawn("")
    ax.set_xlabel(r"$X_f$ (number fraction of floppy capsules)")
    ax.set_ylabel(r"steady $\bar{d}/(H/2)$")
    ax.set_xlim(-0.05, 1.05)
    ax.legend(loc="best")
    ax.set_title("set '%s'" % ctx.main, fontsize=7)
    F.add_caption("Steady d-bar/(H/2): mean over the analysis window, error bars 1 block SE.")
    return F.finish(fig)


def profile_figure(A, ctx, F, qty, ylabel, pure_mark=None, hline=None, floor=None):
    """Figures 5, 6, 10: (a) pure species, (b) stiff at X_f in [0, 1), (c) floppy at X_f in (0, 1]."""
    gs = A.suspension(ctx.main)
    if not gs:
        F.note("skipped: no suspension groups in set '%s'" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.9))
    sets = []

    ax = axs[0]
    panel_letter(ax, "a")
    ax.set_title(r"pure species ($X_f = 0$ and $X_f = 1$)")
    cs = CurveSet(A, F, ax, "a", qty)
    for x, sp, col, lab, m, g in pure_groups(gs, cs.reasons):
        if cs.add(g, sp, "pure %s" % sp, "%s (%s)" % (lab, xf_label(x)), color=col, marker=m, ms=3) and \
                pure_mark is not None and matches_set_a_pure(ctx.params, sp):
            pure_mark(ax, sp)
    sets.append(cs)
    for ax, sp, cmap, letter in ((axs[1], "stiff", "Blues", "b"), (axs[2], "floppy", "Reds", "c")):
        panel_letter(ax, letter)
        ax.set_title("%s particles vs $X_f$" % sp)
        cs = CurveSet(A, F, ax, letter, qty)
        lst = [g for g in gs if has_species(g, sp)]
        if not lst:
            cs.reasons.append(("", "no group with %s capsules in the set" % sp))
        for g, col in zip(lst, shades(cmap, len(lst))):
            cs.add(g, sp, xf_label(g.x_f), xf_label(g.x_f), color=col, marker=".")
        sets.append(cs)
    lim = common_ylim(axs, [v for cs in sets for v in cs.values], () if hline is None else (hline,), floor)
    for cs in sets:
        if cs.finish():
            F.drawn(cs.letter)
            y_guides(cs.ax)
            if hline is not None:
                cs.ax.axhline(hline, color="0.6", lw=0.7, ls="--", zorder=0)
            cs.ax.set_xlabel(PROFILE_XLABEL)
            cs.ax.set_ylabel(ylabel)
            cs.ax.legend(loc="best")
        else:
            F.empty(cs.ax, cs.letter, cs.why_empty("no curves"), PROFILE_XLABEL, ylabel, (0.0, 0.5), lim)
    F.add_caption("Error bars: 1 SE (jackknife over blocks of the window); " + GUIDES_CAPTION +
                  ("; dashed: uniform = 1" if hline == 1.0 else "") + ".")
    return F.finish(fig)


def fig05_n_hat(A, ctx, F):
    return profile_figure(A, ctx, F, "n_hat", r"$\hat{n}(y)$ (uniform = 1)", hline=1.0, floor=0.0)


def fig06_phi_hat(A, ctx, F):
    marked = []

    def paper_mark(ax, sp):
        # docs/analysis.md §7: phi-hat(0.5H) ~ 2 in set A's pure suspensions (phi ~ 0.4 at the centreline).
        if ax not in marked:
            ax.plot([0.5], [2.0], marker="*", ms=10, color="k", ls="none", mfc="none", clip_on=False,
                    label=r"paper: $\hat\phi(0.5H) \approx 2$ (set A, pure)")
            marked.append(ax)
    return profile_figure(A, ctx, F, "phi_hat", r"$\hat{\phi}(y)$ (uniform = 1)", pure_mark=paper_mark, hline=1.0,
                          floor=0.0)


def fig07_enrichment(A, ctx, F):
    gs = [g for g in A.suspension(ctx.main) if mixture(g)]
    c = A.curve(ctx.main)
    es = curve_series(c, "E_s") if c is not None else None
    ef = curve_series(c, "E_f") if c is not None else None
    if not gs and es is None and ef is None:
        F.note("skipped: set '%s' has no mixture groups (0 < X_f < 1) and no E_s, E_f in /curves" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.9))
    ax = axs[0]
    panel_letter(ax, "a")
    ylabel = r"$\hat{X}_f(y)$ (floppy share / $X_f$)"
    cs = CurveSet(A, F, ax, "a", "xf_hat")
    if not gs:
        cs.reasons.append(("", "no mixture group (0 < X_f < 1) in the set"))
    for g, col in zip(gs, shades("viridis", len(gs), 0.0, 0.85)):
        cs.add(g, None, xf_label(g.x_f), xf_label(g.x_f), color=col, marker=".")
    if cs.finish():
        F.drawn("a")
        ax.axhline(1.0, color="k", lw=0.8, ls="-", zorder=0, label=r"$\hat{X}_f = 1$")
        if matches_set_a(ctx.params):
            ax.axvline(0.25, color="0.4", lw=0.8, ls=":", zorder=0,
                       label=r"paper: $\hat{X}_f = 1$ at $y \approx H/4$ (set A)")
        ax.set_xlim(0, 0.5)
        ax.set_xlabel(PROFILE_XLABEL)
        ax.set_ylabel(ylabel)
        ax.legend(loc="best")
    else:
        F.empty(ax, "a", cs.why_empty("no X_f-hat"), PROFILE_XLABEL, ylabel, (0.0, 0.5))
    ax = axs[1]
    panel_letter(ax, "b")
    ylabel = r"enrichment factor $E$ ($\geq 1$)"
    if es is None and ef is None:
        F.empty(ax, "b", "no E_s, E_f in /curves of the set (E is defined for mixtures only)",
                r"$X_f$", ylabel, (-0.05, 1.05))
    else:
        F.drawn("b")
        if ef is not None:
            plot_err(ax, ef[0], ef[1], ef[2], color=FLOPPY, marker="s", label="F ($E_f$)")
        if es is not None:
            plot_err(ax, es[0], es[1], es[2], color=STIFF, marker="o", label="S ($E_s$)")
        ax.axhline(1.0, color="0.6", lw=0.7, ls="--", zorder=0)
        ax.set_xlim(0, 1)
        ax.set_xlabel(r"$X_f$ (number fraction of floppy capsules)")
        ax.set_ylabel(ylabel)
        ax.legend(loc="best")
    F.add_caption("Error bars: 1 SE (jackknife over blocks of the window).")
    return F.finish(fig)


def isolated_curve(A, ca):
    for n in A.isolated:
        if close(n.fattr("ca"), ca, 1e-3):
            y, v = n.data("y_over_H"), n.data("V_S")
            if y is not None and v is not None and y.shape == v.shape:
                return y, v
    return None


def fig08_v_bar(A, ctx, F):
    gs = A.suspension(ctx.main)
    c0 = gs[0] if gs else A.curve(ctx.main)
    ca_s = c0.fattr("ca_stiff") if c0 is not None else math.nan
    ca_f = c0.fattr("ca_floppy") if c0 is not None else math.nan
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.9))
    ylabel_a, ylabel_rel = r"$\bar{v}_p/(\dot\gamma_w a)$ (toward the centreline > 0)", r"$\Delta\bar{v}_p/v_r$"

    ax = axs[0]
    panel_letter(ax, "a")
    ax.set_title("pure species and isolated capsules")
    cs = CurveSet(A, F, ax, "a", "v_bar")
    for x, sp, col, lab, m, g in pure_groups(gs, cs.reasons):
        cs.add(g, sp, "pure %s" % sp, "%s (%s)" % (lab, xf_label(x)), color=col, marker=m, ms=3)
    no_iso = [ca for ca in (ca_s, ca_f) if isolated_curve(A, ca) is None]
    if no_iso:
        cs.reasons.append(("isolated", "no isolated pinned runs (/isolated) with Ca = %s"
                           % " or ".join("%g" % ca for ca in no_iso)))
    for ca, col, lab in ((ca_s, STIFF, "S*"), (ca_f, FLOPPY, "F*")):
        cur = isolated_curve(A, ca)
        if cur is None:
            continue
        ax.plot(cur[0], cur[1], color=col, ls="--", marker="D", mfc="white", ms=3.5,
                label="%s (isolated, Ca = %g)" % (lab, ca))
        cs.values.append(cur[1])
        cs.count += 1
    lim_a = common_ylim([ax], cs.values, (0.0,))
    if cs.finish():
        F.drawn("a")
        ax.axhline(0, color="0.6", lw=0.7, zorder=0)
        y_guides(ax)
        ax.set_xlabel(PROFILE_XLABEL)
        ax.set_ylabel(ylabel_a)
        ax.legend(loc="best")
    else:
        F.empty(ax, "a", cs.why_empty("no v-bar_p"), PROFILE_XLABEL, ylabel_a, (0.0, 0.5), lim_a)

    rel = []
    for ax, sp, cmap, letter in ((axs[1], "stiff", "Blues", "b"), (axs[2], "floppy", "Reds", "c")):
        panel_letter(ax, letter)
        ax.set_title("%s particles: change against pure %s" % (sp, sp))
        cs = CurveSet(A, F, ax, letter, "dv_rel")
        lst = [g for g in gs if mixture(g)]
        if not lst:
            cs.reasons.append(("", "no mixture group (0 < X_f < 1) in the set"))
        for g, col in zip(lst, shades(cmap, len(lst))):
            cs.add(g, sp, xf_label(g.x_f), xf_label(g.x_f), color=col, marker=".")
        rel.append(cs)
    # The paper's -50 % (set A, stiff) stays inside the range, so that its mark is seen.
    lim = common_ylim([cs.ax for cs in rel], [v for cs in rel for v in cs.values],
                      (0.0, -0.5) if matches_set_a(ctx.params) and rel[0].count else (0.0,))
    for cs in rel:
        if cs.finish():
            F.drawn(cs.letter)
            cs.ax.axhline(0, color="0.6", lw=0.7, zorder=0)
            if cs.letter == "b" and matches_set_a(ctx.params):
                cs.ax.axhline(-0.5, color="k", lw=0.7, ls="-.", zorder=0, label=r"paper: down to $\approx -50\%$ "
                                                                                r"(set A)")
            y_guides(cs.ax)
            cs.ax.set_xlabel(PROFILE_XLABEL)
            cs.ax.set_ylabel(ylabel_rel)
            cs.ax.legend(loc="best")
        else:
            F.empty(cs.ax, cs.letter, cs.why_empty("no (v-bar_p - v_r)/v_r"), PROFILE_XLABEL, ylabel_rel, (0.0, 0.5), lim)
    F.add_caption("v_r: v-bar_p of the pure suspension of the same species (X_f = 0 for S, 1 for F); error bars "
                  "1 SE; " + GUIDES_CAPTION + ".")
    return F.finish(fig)


def fig09_pdf(A, ctx, F):
    gs = A.suspension(ctx.main)
    panels = []
    for x, sp, letter in ((0.0, "stiff", "a"), (1.0, "floppy", "b")):
        g = next((g for g in gs if is_xf(g, x)), None)
        panels.append((g, sp, letter, x))
    if all(p[0] is None or p[0].child("pdf/" + p[1]) is None for p in panels):
        F.note("skipped: no pure-species group of set '%s' has pdf/<species>" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 2, figsize=(9, 4.6))
    xlabel, ylabel = r"$v_p/(\dot\gamma_w a)$ (toward the centreline > 0)", r"$P(v_p)$ (probability density)"
    xs, ys, data_axes = [], [], []
    for ax, (g, sp, letter, x) in zip(axs, panels):
        panel_letter(ax, letter)
        ax.set_title("pure %s (%s)" % (sp, xf_label(x)))
        if g is None:
            F.empty(ax, letter, "no pure-%s group (X_f = %d) in the set" % (sp, int(x)), xlabel, ylabel)
            continue
        heights = sorted((k, n) for k, n in g.children("pdf/" + sp) if k.startswith("y") and k[1:].isdigit())
        if not heights:
            F.empty(ax, letter, "%s: no pdf/%s (no samples near y/H = 0.2 ... 0.5)" % (g.label, sp), xlabel, ylabel)
            continue
        drawn = False
        for (k, n), col in zip(heights, shades("viridis", len(heights), 0.0, 0.85)):
            e, d = n.data("edges"), n.data("density")
            if e is None or d is None or e.shape[0] != d.shape[0] + 1:
                F.panel_note(letter, "pdf/%s/%s: edges/density missing or inconsistent" % (sp, k))
                continue
            mid = 0.5 * (e[1:] + e[:-1])
            ok = d > 0
            if not ok.any():
                F.panel_note(letter, "pdf/%s/%s: every bin empty" % (sp, k))
                continue
            nsamp = n.attr("samples")
            ax.semilogy(mid[ok], d[ok], color=col, marker=".", ms=2, lw=0.8,
                        label=r"$y/H = %g$%s" % (int(k[1:]) / 1000.0,
                                                 "" if nsamp is None else " (%d samples)" % int(nsamp)))
            xs.append(mid[ok])
            ys.append(d[ok])
            mean, sd = n.fattr("mean"), n.fattr("stddev")
            if math.isfinite(mean) and math.isfinite(sd) and sd > 0:
                vv = np.linspace(mid[ok].min(), mid[ok].max(), 200)
                gauss = np.exp(-0.5 * ((vv - mean) / sd) ** 2) / (sd * math.sqrt(2 * math.pi))
                keep = gauss >= d[ok].min() * 0.5
                ax.semilogy(vv[keep], gauss[keep], color=col, lw=0.6, ls="--")
            drawn = True
        if not drawn:
            F.empty(ax, letter, "%s: pdf/%s holds no samples" % (g.label, sp), xlabel, ylabel)
            continue
        F.drawn(letter)
        data_axes.append(ax)
        ax.plot([], [], color="0.5", lw=0.6, ls="--", label="Gaussian, same mean and s.d.")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        # Below the axes: inside, the legend covered the curves' tails.
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize=6.5)
    # The same axes on both panels, so the two species compare at a glance.
    if data_axes:
        xr, yr = finite_range(xs), finite_range([np.log10(y) for y in ys])
        for ax in axs:
            ax.set_yscale("log")
            ax.set_xlim(*padded(*xr, frac=0.04))
            ax.set_ylim(10 ** (yr[0] - 0.15), 10 ** (yr[1] + 0.25))
            ax.xaxis.set_major_locator(MaxNLocator(6))     # labels like -0.075 collide at the default density
    F.add_caption("Samples within 0.025H of each height; log scale: empty velocity bins are not drawn.")
    return F.finish(fig)


def fig10_v_prime(A, ctx, F):
    return profile_figure(A, ctx, F, "v_prime", r"$v'_p/(\dot\gamma_w a)$ (standard deviation)", floor=0.0)


def fig11_pair_collisions(A, ctx, F):
    pairs = [g for g in A.groups if g.kind == "pair" and g.has("time")]
    if not pairs:
        F.note("skipped: no pair groups (kind = pair) with a time series")
        return None
    homo = sorted([g for g in pairs if close(g.fattr("ca_top"), g.fattr("ca_bottom"), 1e-6)],
                  key=lambda g: g.fattr("ca_top"))
    hetero = sorted([g for g in pairs if g not in homo],
                    key=lambda g: max(g.fattr("ca_top"), g.fattr("ca_bottom")) /
                    max(min(g.fattr("ca_top"), g.fattr("ca_bottom")), 1e-300))
    fig, axs = plt.subplots(2, 2, figsize=(9, 6.6))
    specs = [(axs[0, 0], "a", "disp", homo, r"$(y - y_i)/a$", "homogeneous: top particle"),
             (axs[0, 1], "b", "disp", hetero, r"$(y - y_i)/a$", "heterogeneous: stiff and floppy"),
             (axs[1, 0], "c", "uy", homo, r"$U_y/(\dot\gamma a)$", "homogeneous: top particle"),
             (axs[1, 1], "d", "uy", hetero, r"$U_y/(\dot\gamma a)$", "heterogeneous: stiff and floppy")]
    styles = ["-", "--", ":", "-."]
    xlabel = r"$\dot\gamma t$ (strain)"
    for ax, lab, q, lst, ylabel, title in specs:
        panel_letter(ax, lab)
        ax.set_title(title)
        kind = "homogeneous" if lab in "ac" else "heterogeneous"
        drawn = False
        seen = {}
        if lab in "ac":
            for g, col in zip(lst, shades("viridis", len(lst), 0.0, 0.85)):
                t, v = g.data("time"), g.data(q + "_top")
                if t is None or v is None or t.shape != v.shape:
                    F.panel_note(lab, "%s: time/%s_top missing or of different lengths" % (g.label, q))
                    continue
                key = "Ca = %g" % g.fattr("ca_top")
                seen[key] = seen.get(key, 0) + 1
                ax.plot(t, v, color=col, label=key + ("" if seen[key] == 1 else " (%s)" % g.label))
                drawn = True
        else:
            for i, g in enumerate(lst):
                t = g.data("time")
                ca_t, ca_b = g.fattr("ca_top"), g.fattr("ca_bottom")
                stiff_pos = "top" if ca_t < ca_b else "bottom"
                floppy_pos = "bottom" if stiff_pos == "top" else "top"
                ca_s, ca_f = min(ca_t, ca_b), max(ca_t, ca_b)
                ls = styles[i % len(styles)]
                for pos_, col, sp, ca in ((stiff_pos, STIFF, "S", ca_s), (floppy_pos, FLOPPY, "F", ca_f)):
                    v = g.data("%s_%s" % (q, pos_))
                    if t is None or v is None or t.shape != v.shape:
                        F.panel_note(lab, "%s: time/%s_%s missing or of different lengths" % (g.label, q, pos_))
                        continue
                    ax.plot(t, v, color=col, ls=ls, label="%s Ca = %g (%s), pair %g/%g" % (sp, ca, pos_, ca_s, ca_f))
                    drawn = True
        if not drawn:
            F.empty(ax, lab, "no %s pair groups" % kind if not lst else "no readable %s pair series" % kind,
                    xlabel, ylabel)
            continue
        F.drawn(lab)
        ax.axhline(0, color="0.6", lw=0.6, zorder=0)
        ax.set_ylabel(ylabel)
        ax.set_xlabel(xlabel)
        ax.legend(loc="best")
    F.add_caption("Bottom particle sign-flipped: both positive when the pair separates.")
    return F.finish(fig)


def fig13_fab(A, ctx, F):
    c = A.curve(ctx.main)
    fs = curve_series(c, "fab_stiff") if c is not None else None
    ff = curve_series(c, "fab_floppy") if c is not None else None
    if fs is None and ff is None:
        gs = A.suspension(ctx.main)
        windows = [g.window for g in gs]
        if windows and all(math.isfinite(w) and w < 100 for w in windows):
            F.note("skipped: no suspension groups with a window >= 100")
        else:
            F.note("skipped: set '%s' has no f_AB values (fab_stiff, fab_floppy in /curves)" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.9), gridspec_kw={"width_ratios": [0.7, 1]})
    ax = axs[0]
    panel_letter(ax, "a")
    F.schematic(ax)
    ax.add_patch(Rectangle((0, 0), 1, 0.3, color="0.85", lw=0))
    ax.add_patch(Rectangle((0, 0.7), 1, 0.3, color="0.85", lw=0))
    for y in (0.3, 0.7):
        ax.axhline(y, color="0.3", ls=":", lw=0.8)
    ax.axhline(0, color="k", lw=2)
    ax.axhline(1, color="k", lw=2)
    ax.text(0.5, 0.15, "A", ha="center", va="center", fontsize=12)
    ax.text(0.5, 0.85, "A", ha="center", va="center", fontsize=12)
    ax.text(0.5, 0.5, "B", ha="center", va="center", fontsize=12)
    ax.text(1.02, 0.3, "0.3H", va="center", fontsize=7)
    ax.text(1.02, 0.7, "0.7H", va="center", fontsize=7)
    ax.set_xlim(0, 1.2)
    ax.set_ylim(-0.05, 1.05)
    ax.set_title("regions: A within 0.3H of a wall, B the rest")
    ax = axs[1]
    panel_letter(ax, "b")
    F.drawn("b")
    for d, col, lab, m in ((fs, STIFF, "S", "o"), (ff, FLOPPY, "F", "s")):
        if d is None:
            F.panel_note("b", "no %s f_AB values" % ("stiff" if lab == "S" else "floppy"))
            continue
        plot_err(ax, d[0], d[1], d[2], color=col, marker=m, label=lab)
    # docs/analysis.md §11: the paper's f_AB values are for set A (it computes f_AB for set A only).
    if matches_set_a(ctx.params):
        for pts, col, lab in ((PAPER_FAB_STIFF, STIFF, "paper (S, set A): 0.081 to 0.015"),
                              (PAPER_FAB_FLOPPY, FLOPPY, "paper (F, set A): 0.083 to 0.141")):
            ax.plot([p[0] for p in pts], [p[1] for p in pts], ls="none", marker="*", ms=9, mfc="none", mec=col,
                    label=lab)
    ax.set_xlim(-0.05, 1.05)
    ax.set_ylim(bottom=0)
    ax.set_xlabel(r"$X_f$ (number fraction of floppy capsules)")
    ax.set_ylabel(r"$f_{AB}$ (A $\to$ B within 100 strain)")
    ax.legend(loc="best")
    F.add_caption("Error bars: 1 SE (jackknife over 5 sub-windows of the time origins).")
    return F.finish(fig)


# Figures 14-16: compare sets that differ in one parameter.
COMPARE = {
    "fig14_confinement": ("two_a_over_H", r"$2a/H$", ("ca_stiff", "ca_floppy", "phi")),
    "fig15_volume_fraction": ("phi", r"$\phi$", ("ca_stiff", "ca_floppy", "two_a_over_H")),
    "fig16_rigidity_ratio": ("R", r"$R$", ("phi", "two_a_over_H")),
}


def curve_param(c, name):
    return c.R if name == "R" else c.fattr(name)


def comparison_families(curves, varied, fixed):
    """Lists of curves that agree in every `fixed` parameter and hold >= 2 distinct values of `varied`."""
    families = []
    for c in curves:
        for fam in families:
            if all(close(curve_param(c, k), curve_param(fam[0], k)) for k in fixed):
                fam.append(c)
                break
        else:
            families.append([c])
    out = []
    for fam in families:
        distinct = []
        for c in fam:
            v = curve_param(c, varied)
            if math.isfinite(v) and not any(close(v, w) for w in distinct):
                distinct.append(v)
        if len(distinct) >= 2:
            out.append(sorted(fam, key=lambda c: curve_param(c, varied)))
    return out


def comparison_figure(name, A, ctx, F):
    varied, sym, fixed = COMPARE[name]
    fams = comparison_families(A.curves, varied, fixed)
    if not fams:
        vals = sorted({round(curve_param(c, varied), 4) for c in A.curves if math.isfinite(curve_param(c, varied))})
        F.note("skipped: needs two sets (/curves) that differ in %s and agree in %s; found %d set(s)%s"
               % (varied, ", ".join(fixed), len(A.curves), "" if not vals else " with %s = %s" % (
                   varied, ", ".join("%g" % v for v in vals))))
        return None
    curves = [c for fam in fams for c in fam]
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.9))
    markers = ["o", "s", "^", "D", "v", "P"]
    styles = ["-", "--", ":", "-."]

    def lab(c):
        s = "%s = %.3g" % (sym, curve_param(c, varied))
        if len(fams) > 1:
            s += " [" + ", ".join("%s %.3g" % (k, curve_param(c, k)) for k in fixed) + "]"
        return s

    drawn = [False, False, False]
    for i, c in enumerate(curves):
        m, ls = markers[i % len(markers)], styles[i % len(styles)]
        for q, col, sp in (("dbar_stiff", STIFF, "S"), ("dbar_floppy", FLOPPY, "F")):
            d = curve_series(c, q)
            if d is not None:
                plot_err(axs[0], d[0], d[1], d[2], color=col, marker=m, ls=ls, mfc="white" if i else col,
                         label="%s, %s" % (sp, lab(c)))
                drawn[0] = True
        for ax, k, q, col in ((axs[1], 1, "E_s", STIFF), (axs[2], 2, "E_f", FLOPPY)):
            d = curve_series(c, q)
            if d is not None:
                plot_err(ax, d[0], d[1], d[2], color=col, marker=m, ls=ls, mfc="white" if i else col, label=lab(c))
                drawn[k] = True
    titles = (r"steady $\bar{d}$", "stiff particles", "floppy particles")
    ylabels = (r"steady $\bar{d}/(H/2)$", r"$E_s$ (enrichment of stiff)", r"$E_f$ (enrichment of floppy)")
    xlabel = r"$X_f$ (number fraction of floppy capsules)"
    for k, ax in enumerate(axs):
        letter = "abc"[k]
        panel_letter(ax, letter)
        ax.set_title(titles[k])
        if not drawn[k]:
            F.empty(ax, letter, "no %s in the compared sets" % ("d-bar", "E_s", "E_f")[k], xlabel, ylabels[k],
                    (-0.05, 1.05))
            continue
        F.drawn(letter)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabels[k])
        ax.set_xlim(-0.05, 1.05)
        if k:
            ax.axhline(1.0, color="0.6", lw=0.7, ls="--", zorder=0)
        ax.legend(loc="best")
    F.add_caption("Error bars: 1 SE (block averaging for d-bar, jackknife for E).")
    return F.finish(fig)


DRAW = {
    "fig02_snapshots": fig02_snapshots,
    "fig03_dbar_t": fig03_dbar_t,
    "fig04_dbar_xf": fig04_dbar_xf,
    "fig05_n_hat": fig05_n_hat,
    "fig06_phi_hat": fig06_phi_hat,
    "fig07_enrichment": fig07_enrichment,
    "fig08_v_bar": fig08_v_bar,
    "fig09_pdf": fig09_pdf,
    "fig10_v_prime": fig10_v_prime,
    "fig11_pair_collisions": fig11_pair_collisions,
    "fig13_fab": fig13_fab,
}
NEEDS_MAIN_SET = set(DRAW) - {"fig11_pair_collisions"}


class Context:
    def __init__(self, main, is_set_a, params):
        self.main = main
        self.is_set_a = is_set_a
        self.params = params        # ca_stiff, ca_floppy, phi, two_a_over_H of the main set


# ---------------------------------------------------------------------------------------------------------------
# Run outputs: `capsflow run`'s OUT.h5 (docs/output_format.md), one figure of the run's diagnostics per file.
# Read with h5py here rather than with python/capsflow: `capsflow figures` runs a copy of this script alone
# (<exe dir>/share/capsflow), where the package is not on the path.

RUN_FORMAT_VERSION = 6           # the newest run output format read here (docs/output_format.md, "Format versions")
RUN_SUFFIX = "_run_diagnostics"  # FIGDIR/<run file stem>_run_diagnostics.png and .svg
RUN_REQUIRED = ("parameters/config", "capsules/species", "series/time")
RUN_WHAT = "expected a run output OUT.h5 of capsflow run, or a directory holding analysis.h5"
SINCE = {"series/max_step_ratio": 2, "series/step_limits": 4, "events/time": 2}   # others: format 1
STEP_LIMITS = ("membrane", "near-contact", "collision", "ratio cap", "paper gap")   # /series/step_limits columns
STEP_LIMIT_COLOURS = ("tab:blue", "tab:orange", "tab:red", "tab:purple", "0.55")
SPECIES_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown", "tab:pink",
                   "tab:olive", "tab:cyan", "tab:gray")    # stiff blue, floppy red, then any further species


def species_colours(R):
    """{species index: colour}: by Ca, as in the study's figures and `capsflow render`: the species of the smallest Ca
    STIFF, of the largest FLOPPY, the rest (a third species, or Ca unknown) the next colours of SPECIES_COLOURS; a run
    whose capsules show one Ca only keeps the species order (the presets list the stiff species first)."""
    ca = {}
    for s in range(len(R.species_names)):
        vals = R.ca[R.species == s]
        vals = vals[np.isfinite(vals)]
        if vals.size:
            ca[s] = float(np.min(vals))
    out = {}
    if len(set(ca.values())) >= 2:
        lo, hi = min(ca.values()), max(ca.values())
        for s, c in ca.items():
            if c == lo:
                out[s] = STIFF
            elif c == hi:
                out[s] = FLOPPY
    if not out:
        return {s: SPECIES_COLOURS[s % len(SPECIES_COLOURS)] for s in range(len(R.species_names))}
    rest = [c for c in SPECIES_COLOURS if c not in out.values()]
    others = [s for s in range(len(R.species_names)) if s not in out]
    for i, s in enumerate(others):
        out[s] = rest[i % len(rest)]
    return out
STRAIN = r"$\dot\gamma t$ (strain)"
MAX_POINTS = 2000                # records drawn per line (evenly spaced, first and last kept)
MAX_PANEL_POINTS = 200000        # over all capsule lines of one panel (fewer per line for many capsules)
RASTER_LINES = 100               # more capsule lines than this: rasterized inside the SVG too
DRIFT_FLOOR = 1e-16              # |V/V0 - 1| below this (round-off) is drawn at it on the log axis


def mathtext_safe(s):
    """Text shown as is: '$' would start matplotlib's mathtext, a leading '_' hides a legend entry."""
    s = str(s).replace("$", r"\$")
    return "\u200b" + s if s.startswith("_") else s


def _mini_toml(text):
    """The `key = number` and `key = "string"` pairs of the [section] tables of a TOML text (enough for
    /parameters/config where neither tomllib nor tomli is there); arrays of tables are left out."""
    out, sec = {}, None
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("[["):
            sec = None
            continue
        m = re.match(r"\[\s*([A-Za-z0-9_-]+)\s*\]", s)
        if m:
            sec = out.setdefault(m.group(1), {})
            continue
        m = re.match(r"([A-Za-z0-9_-]+)\s*=\s*(\"[^\"]*\"|[^#]*)", s)
        if m and sec is not None:
            v = m.group(2).strip()
            sec[m.group(1)] = v[1:-1] if v.startswith('"') else _float(v, v)
    return out


def parse_config(text):
    try:
        import tomllib as toml
    except ImportError:
        try:
            import tomli as toml
        except ImportError:
            return _mini_toml(text)
    try:
        return toml.loads(text)
    except Exception:
        return _mini_toml(text)


def record_sample(T, lines=1):
    """Indices of the records drawn: all of them up to MAX_POINTS per line (fewer when a panel holds many lines),
    else evenly spaced with the first and the last."""
    n = max(300, min(MAX_POINTS, MAX_PANEL_POINTS // max(lines, 1)))
    if T <= n:
        return np.arange(T)
    return np.unique(np.linspace(0, T - 1, n).round().astype(np.int64))


class RunFile:
    """An output of `capsflow run`, checked the way python/capsflow's open_run checks it; series cut to the whole
    records (a live run's file may hold one dataset a record ahead of another)."""

    def __init__(self, path):
        self.path = path
        self.stem = os.path.splitext(os.path.basename(os.path.normpath(path)))[0]
        self.name = self.stem + RUN_SUFFIX
        self.h5 = None

    def open(self):
        p = self.path
        if not os.path.exists(p):
            raise InputProblem("%s: no such file or directory (%s)" % (p, RUN_WHAT))
        if not os.path.isfile(p):
            raise InputProblem("%s: not a regular file (%s)" % (p, RUN_WHAT))
        try:
            hdf5 = h5py.is_hdf5(p)
        except OSError as e:
            raise InputProblem("%s: cannot read (%s)" % (p, e))
        if not hdf5:
            raise InputProblem("%s: not an HDF5 file (%s)" % (p, RUN_WHAT))
        try:
            try:
                # A live run holds an HDF5 file lock on its output: read without one (it flushes whole records).
                self.h5 = h5py.File(p, "r", locking=False)
            except TypeError:  # h5py < 3.5
                self.h5 = h5py.File(p, "r")
        except OSError as e:
            raise InputProblem("%s: cannot read as HDF5 (%s)" % (p, e))
        try:
            self._check_and_read_header()
        except InputProblem:
            self.close()
            raise
        except Exception as e:   # a dataset of another shape or type than a run output's
            self.close()
            raise InputProblem("%s: malformed run output (%s: %s)" % (p, type(e).__name__, e))
        return self

    def close(self):
        if self.h5 is not None:
            self.h5.close()
            self.h5 = None

    def _check_and_read_header(self):
        f, p = self.h5, self.path
        if "format" in f.attrs and _str(f.attrs["format"]) == FORMAT:
            raise InputProblem("%s: is a capsflow analysis file, not a run output; give the directory holding it "
                               "(capsflow figures %s --out FIGDIR)" % (p, os.path.dirname(p) or "."))
        if "state" in f and "output_file" in f.attrs:
            raise InputProblem("%s: is a checkpoint, not a run output; give the run output it belongs to (%s)"
                               % (p, _str(f.attrs["output_file"])))
        try:
            version = int(f.attrs.get("format_version", 1))
        except (TypeError, ValueError):
            raise InputProblem("%s: attribute format_version = %r is not an integer" % (p, f.attrs["format_version"]))
        if version < 1 or version > RUN_FORMAT_VERSION:
            raise InputProblem("%s: written in output format %d; this script reads run outputs of formats 1 to %d%s"
                               % (p, version, RUN_FORMAT_VERSION, " (a newer capsflow wrote it)" if version > 1
                                  else ""))
        missing = ["/" + n for n in RUN_REQUIRED if n not in f]
        if missing:
            raise InputProblem("%s: not a capsflow run output (no %s; %s)" % (p, ", ".join(missing), RUN_WHAT))
        self.version = version
        params = f["parameters"].attrs
        self.source = _str(params["source"]) if "source" in params else ""
        self.run_id = _str(f.attrs["run_id"]) if "run_id" in f.attrs else ""
        self.capsflow_version = _str(f.attrs["capsflow_version"]) if "capsflow_version" in f.attrs else ""
        self.config = parse_config(_str(f["parameters/config"][()]))
        dom = self.config.get("domain", {}) if isinstance(self.config.get("domain"), dict) else {}
        self.H = _float(dom.get("H"))
        if not (math.isfinite(self.H) and self.H > 0):
            raise InputProblem("%s: /parameters/config has no [domain] H > 0" % p)
        caps = self.config.get("capsules", {}) if isinstance(self.config.get("capsules"), dict) else {}
        self.radius = _float(f["capsules"].attrs.get("radius", caps.get("radius", 1.0)), 1.0)
        flow = self.config.get("flow", {}) if isinstance(self.config.get("flow"), dict) else {}
        self.flow = _str(flow.get("type", ""))
        self.species = np.asarray(f["capsules/species"][()], dtype=np.int64).ravel()
        names = f["capsules/species"].attrs.get("names")
        if names is not None:
            self.species_names = _str(names).split(",")
        else:
            sp = self.config.get("species", [])
            self.species_names = [_str(s.get("name", "")) for s in sp] if isinstance(sp, list) else []
        n_sp = int(self.species.max()) + 1 if self.species.size else 0
        self.species_names += ["species %d" % k for k in range(len(self.species_names), n_sp)]
        self.ca = np.asarray(f["capsules/ca"][()], float) if "capsules/ca" in f else np.full(self.species.size,
                                                                                               math.nan)
        self.pinned = (np.asarray(f["capsules/pinned"][()]).astype(bool) if "capsules/pinned" in f
                       else np.zeros(self.species.size, bool))
        extents = [f["series"][k].shape[0] for k in f["series"] if isinstance(f["series"][k], h5py.Dataset)
                   and f["series"][k].ndim >= 1]
        self.T = min(extents) if extents else 0
        ev = [f["events/" + k].shape[0] for k in ("time", "capsules", "gap_before", "dy") if "events/" + k in f]
        self.E = min(ev) if ev else 0

    @property
    def np(self):
        return int(self.species.size)

    def has(self, path):
        return path in self.h5 and isinstance(self.h5[path], h5py.Dataset)

    def series(self, name, column=None):
        """/series/<name> over the whole records (column: of the last axis), or None when absent."""
        path = "series/" + name
        if not self.has(path):
            return None
        ds = self.h5[path]
        if column is not None:
            if ds.ndim < 2 or ds.shape[-1] <= column:
                return None
            return np.asarray(ds[: self.T, ..., column], float)
        return np.asarray(ds[: self.T])

    def why_missing(self, path):
        since = SINCE.get(path, 1)
        if self.version < since:
            return "not in this output (format %d): /%s is written since format %d" % (self.version, path, since)
        return "/%s is missing (expected in output format %d)" % (path, self.version)

    def title(self):
        """The configuration's source and the run id; '<embedded demo>' as 'embedded demo'."""
        src = self.source.strip()
        if src.startswith("<") and src.endswith(">"):
            src = src[1:-1].strip()
        return "%s, run %s" % (mathtext_safe(src or self.stem), mathtext_safe(self.run_id or "(no run id recorded)"))


def species_groups(R):
    """(index, name, colour, capsule indices, legend label) of each species that has capsules."""
    out = []
    colours = species_colours(R)
    for s, name in enumerate(R.species_names):
        caps = np.flatnonzero(R.species == s)
        if caps.size == 0:
            continue
        cas = sorted({round(float(c), 6) for c in R.ca[caps] if math.isfinite(c)})
        label = "%s (Ca %s): %d capsule%s" % (mathtext_safe(name), "/".join("%g" % c for c in cas) or "?",
                                              caps.size, "" if caps.size == 1 else "s")
        npin = int(np.count_nonzero(R.pinned[caps]))
        if npin:
            label += ", %d pinned (dashed)" % npin
        out.append((s, name, colours[s], caps, label))
    return out


def caption_lines(F, text, width=175):
    """A long caption entry wrapped to the figure's width (one caption line each)."""
    for line in textwrap.wrap(text, width):
        F.add_caption(line)


def legend_above(ax, handles=None, ncol=None, **kw):
    """The panel's legend above its axes, right-aligned: it never hides data (the letter is on the left)."""
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    else:
        labels = [h.get_label() for h in handles]
    if not handles:
        return
    ax.legend(handles, labels, loc="lower right", bbox_to_anchor=(1.0, 1.01), borderaxespad=0.0,
              ncol=ncol or min(len(handles), 2), fontsize=6.5, handlelength=1.6, columnspacing=1.0, **kw)


def strain_range(t):
    """The strain axis' limits: the records' strain range (widened when there is one record only)."""
    if t.size and t[-1] > t[0]:
        return float(t[0]), float(t[-1])
    return padded(float(t[0]), float(t[0])) if t.size else (0.0, 1.0)


def strain_limits(ax, t):
    if t.size and t[-1] > t[0]:
        ax.set_xlim(t[0], t[-1])
    elif t.size:
        ax.set_xlim(*padded(t[0], t[0]))


def capsule_lines(ax, R, F, t, values, groups, scale=1.0):
    """One thin line per capsule in its species' colour (pinned capsules dashed), the species interleaved so that
    none hides another; the legend by species."""
    idx = record_sample(t.size, R.np)
    colour = {s: c for s, _, c, _, _ in groups}
    # Drawing order: each species' capsules spread evenly over the sequence.
    caps = [int(k) for _, k in sorted(((i + 0.5) / len(ks), k) for _, _, _, ks, _ in groups
                                      for i, k in enumerate(ks))]
    segs = [np.column_stack([t[idx], values[idx, k] / scale]) for k in caps]
    ax.add_collection(LineCollection(segs, colors=[colour[R.species[k]] for k in caps], linewidths=0.7,
                                     linestyles=["--" if R.pinned[k] else "-" for k in caps],
                                     rasterized=R.np > RASTER_LINES))
    if idx.size < t.size:
        F.add_caption("(a), (b) Every capsule, drawn at %d evenly spaced records of %d." % (idx.size, t.size))
    return [Line2D([], [], color=c, lw=1.2, label=label) for _, _, c, _, label in groups]


def run_panel_heights(ax, R, F, t, groups):
    yc = R.series("centroid", 1)
    ylabel = r"$y_c/H$ (centre height; walls at 0 and 1)"
    if yc is None or yc.ndim != 2 or yc.shape[1] != R.np:
        F.empty(ax, "a", R.why_missing("series/centroid"), STRAIN, ylabel, strain_range(t), (0, 1))
        return
    handles = capsule_lines(ax, R, F, t, yc, groups, R.H)
    F.drawn("a")
    strain_limits(ax, t)
    ax.set_ylim(0, 1)
    ax.axhline(0.5, color="0.6", lw=0.6, ls=":", zorder=0)
    ax.set_xlabel(STRAIN)
    ax.set_ylabel(ylabel)
    legend_above(ax, handles, ncol=1 if len(handles) > 2 else len(handles))


def run_panel_deformation(ax, R, F, t, groups):
    D = R.series("taylor_D")
    ylabel = r"$D = (L - B)/(L + B)$ (Taylor deformation)"
    if D is None or D.ndim != 2 or D.shape[1] != R.np:
        F.empty(ax, "b", R.why_missing("series/taylor_D"), STRAIN, ylabel, strain_range(t))
        return
    handles = capsule_lines(ax, R, F, t, D, groups)
    F.drawn("b")
    strain_limits(ax, t)
    r = finite_range([D])
    ax.set_ylim(0.0, padded(0.0, r[1] if r and r[1] > 0 else 0.1)[1])
    ax.set_xlabel(STRAIN)
    ax.set_ylabel(ylabel)
    legend_above(ax, handles, ncol=1 if len(handles) > 2 else len(handles))


def run_panel_volume(ax, R, F, t, groups):
    V = R.series("volume")
    ylabel = r"$\max\,|V/V_0 - 1|$ over the species' capsules"
    if V is None or V.ndim != 2 or V.shape[1] != R.np or V.shape[0] == 0:
        F.empty(ax, "c", R.why_missing("series/volume"), STRAIN, ylabel, strain_range(t))
        return
    if t.size < 2:
        F.empty(ax, "c", "one record only (the initial state)", STRAIN, ylabel, strain_range(t))
        return
    with np.errstate(divide="ignore", invalid="ignore"):
        drift = np.abs(V / V[0] - 1.0)
    drift = np.where(np.isfinite(drift), drift, -np.inf)
    idx = record_sample(t.size - 1) + 1      # record 0 holds V0 itself
    floored = False
    for _, name, colour, caps, _ in groups:
        per_record = drift[:, caps].max(axis=1)
        if not np.isfinite(per_record[1:]).any():
            F.panel_note("c", "%s: no finite volumes in /series/volume" % name)
            continue
        shown = np.maximum.reduceat(per_record, idx)     # each point the largest of the records it stands for
        floored = floored or bool(np.any(shown[np.isfinite(shown)] < DRIFT_FLOOR))
        ax.plot(t[idx], np.where(np.isfinite(shown), np.maximum(shown, DRIFT_FLOOR), np.nan), color=colour,
                lw=1.0, label="%s: at most %.2g" % (mathtext_safe(name), float(per_record[1:].max())))
    if not ax.lines:
        F.empty(ax, "c", "no finite volumes in /series/volume", STRAIN, ylabel, strain_range(t))
        return
    F.drawn("c")
    ax.set_yscale("log")
    lo, hi = ax.get_ylim()
    ax.set_ylim(min(lo, DRIFT_FLOOR / 3), max(hi, DRIFT_FLOOR * 100))
    strain_limits(ax, t)
    ax.set_xlabel(STRAIN)
    ax.set_ylabel(ylabel)
    legend_above(ax)
    if floored:
        F.add_caption("(c) Drifts below %g (round-off) are drawn at %g." % (DRIFT_FLOOR, DRIFT_FLOOR))


def run_panel_step(ax, R, F, t):
    dt, step = R.series("dt"), R.series("step")
    ylabel = r"$\dot\gamma\,\Delta t$ (step size, strain)"
    if dt is None or step is None:
        F.empty(ax, "d", R.why_missing("series/dt" if dt is None else "series/step"), STRAIN, ylabel,
                strain_range(t))
        return
    step = step.astype(float)
    idx = record_sample(t.size)
    idx = idx[idx > 0]                     # record 0 is the initial state: no step yet
    if idx.size == 0:
        F.empty(ax, "d", "no step recorded yet (one record: the initial state)", STRAIN, ylabel,
                strain_range(t))
        return
    F.drawn("d")
    ax.plot(t[idx], dt[idx], color="0.2", lw=0.9, label="last step before each record")
    prev = np.concatenate([[0], idx[:-1]])
    dn = step[idx] - step[prev]
    ok = dn > 0
    mean = np.full(idx.size, np.nan)
    mean[ok] = (t[idx] - t[prev])[ok] / dn[ok]
    ax.plot(t[idx], mean, color="tab:green", lw=0.9, ls="--", label="mean step over the interval before each point")
    positive = np.concatenate([dt[idx][dt[idx] > 0], mean[np.isfinite(mean) & (mean > 0)]])
    if positive.size and positive.max() > 100 * positive.min():     # two powers of ten at least: two labels
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0)
    strain_limits(ax, t)
    ax.set_xlabel(STRAIN)
    ax.set_ylabel(ylabel)
    steps, strain = step[-1] - step[0], t[-1] - t[0]
    legend_above(ax, title="%d steps%s" % (steps, ", %.3g per strain unit" % (steps / strain) if strain > 0 else ""))


def run_panel_step_limits(ax, R, F, t):
    ylabel = "share of the steps bound by"
    lim = R.series("step_limits")
    if lim is None:
        F.empty(ax, "e", R.why_missing("series/step_limits"), STRAIN, ylabel, strain_range(t), (0, 1))
        return
    if lim.ndim != 2 or lim.shape[1] != len(STEP_LIMITS):
        F.empty(ax, "e", "/series/step_limits has shape %s, expected [T, %d]" % (lim.shape, len(STEP_LIMITS)),
                STRAIN, ylabel, strain_range(t), (0, 1))
        return
    lim = lim.astype(float)
    if t.size < 2 or lim[1:].sum() <= 0:
        F.empty(ax, "e", "no steps counted in /series/step_limits", STRAIN, ylabel, strain_range(t), (0, 1))
        return
    F.drawn("e")
    # Records 1..T-1 hold the steps of (t[i-1], t[i]]; at most 60 bars, each over consecutive records.
    chunks = np.array_split(np.arange(1, t.size), min(60, t.size - 1))
    left = np.array([t[c[0] - 1] for c in chunks])
    width = np.array([t[c[-1]] for c in chunks]) - left
    counts = np.array([lim[c].sum(axis=0) for c in chunks])
    total = counts.sum(axis=1)
    keep = total > 0
    frac = counts[keep] / total[keep, None]
    left, width = left[keep], width[keep]
    share = lim[1:].sum(axis=0) / lim[1:].sum()
    bottom = np.zeros(frac.shape[0])
    for k, (name, colour) in enumerate(zip(STEP_LIMITS, STEP_LIMIT_COLOURS)):
        ax.bar(left, frac[:, k], width=width, bottom=bottom, align="edge", color=colour, linewidth=0,
               label="%s %.3g %%" % (name, 100 * share[k]))
        bottom += frac[:, k]
    ax.set_ylim(0, 1)
    strain_limits(ax, t)
    ax.set_xlabel(STRAIN)
    ax.set_ylabel(ylabel)
    legend_above(ax, ncol=3)
    caption_lines(F, "(e) What set the size of the steps, per record interval (/series/step_limits): membrane: the "
                     "membrane rule (or the paper's rule with h inside a capsule); near-contact: the membrane rule "
                     "times near_contact_factor; collision: the cap on closing gaps; ratio cap: max_step_ratio; "
                     "paper gap: the paper's rule with h between capsules. The legend gives the shares over the run.")


def run_panel_contacts(ax, R, F, t):
    ylabel = "contact corrections (cumulative count)"
    cc = R.series("contact_corrections")
    have_events = R.has("events/time") and R.has("events/capsules")
    if cc is None and not have_events:
        F.empty(ax, "f", R.why_missing("series/contact_corrections"), STRAIN, ylabel, strain_range(t))
        return
    F.drawn("f")
    top = 0.0
    if cc is not None:
        ax.plot(t, cc, color="0.7", lw=2.4, drawstyle="steps-post", label="pushes (iterations counted)")
        top = max(top, float(np.max(cc)) if cc.size else 0.0)
    else:
        F.panel_note("f", R.why_missing("series/contact_corrections"))
    if have_events:
        et = np.asarray(R.h5["events/time"][: R.E], float)
        pq = np.asarray(R.h5["events/capsules"][: R.E], np.int64).reshape(-1, 2)
        order = np.argsort(et, kind="stable")
        et, pq = et[order], pq[order]
        for sel, colour, label in ((pq[:, 1] >= 0, "tab:purple", "events: capsule pairs"),
                                   (pq[:, 1] < 0, "tab:brown", "events: walls")):
            n = int(np.count_nonzero(sel))
            x = np.concatenate([[t[0] if t.size else 0.0], et[sel], [t[-1] if t.size else 0.0]])
            y = np.concatenate([[0], np.arange(1, n + 1), [n]])
            ax.plot(x, y, color=colour, lw=1.0, drawstyle="steps-post", label="%s (%d)" % (label, n))
            top = max(top, n)
    else:
        reason = R.why_missing("events/time")
        ax.text(0.02, 0.96, "contact events: " + reason, transform=ax.transAxes, va="top", fontsize=6.5,
                color="0.35", wrap=True)
        F.panel_note("f", "contact events: " + reason)
    if top == 0:
        ax.text(0.5, 0.5, "no contact corrections in this run", transform=ax.transAxes, ha="center",
                va="center", fontsize=7, color="0.35")
    ax.set_ylim(0, max(1.0, top * 1.08))
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    strain_limits(ax, t)
    ax.set_xlabel(STRAIN)
    ax.set_ylabel(ylabel)
    legend_above(ax, ncol=3 if have_events else 1)


def run_figure(R, F):
    """The diagnostics of one run: (a) centre heights, (b) Taylor deformation, (c) volume drift, (d) step size,
    (e) what bound the steps, (f) contact corrections."""
    t = np.asarray(R.series("time"), float)
    groups = species_groups(R)
    fig, axs = plt.subplots(3, 2, figsize=(10.5, 11.5))
    for ax, letter in zip(axs.flat, "abcdef"):
        panel_letter(ax, letter)
    if t.size == 0:
        for ax, letter in zip(axs.flat, "abcdef"):
            F.empty(ax, letter, "no records in /series/time", STRAIN, "")
        return F.finish(fig)
    run_panel_heights(axs[0, 0], R, F, t, groups)
    run_panel_deformation(axs[0, 1], R, F, t, groups)
    run_panel_volume(axs[1, 0], R, F, t, groups)
    run_panel_step(axs[1, 1], R, F, t)
    run_panel_step_limits(axs[2, 0], R, F, t)
    run_panel_contacts(axs[2, 1], R, F, t)
    counts = ", ".join("%s %d" % (mathtext_safe(name), caps.size) for _, name, _, caps, _ in groups)
    detail = "%d capsule%s (%s), H = %.4g a, %s flow; strain %.4g to %.4g, %d record%s; output format %d%s" % (
        R.np, "" if R.np == 1 else "s", counts, R.H / R.radius, mathtext_safe(R.flow or "?"), t[0], t[-1], t.size,
        "" if t.size == 1 else "s", R.version, ", capsflow " + mathtext_safe(R.capsflow_version)
        if R.capsflow_version else "")
    fig.suptitle(R.title() + "\n" + detail, fontsize=9)
    return F.finish(fig)


def draw_run(R, out, log):
    """Draws one run's figure; the files written."""
    F = Figure(R.name, out, log)
    fig = run_figure(R, F)
    return [] if fig is None else F.save(fig)


# ---------------------------------------------------------------------------------------------------------------

def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="capsflow figures",
        description="Draw the figures of the segregation study (PNG and SVG) from capsflow analyze output, and "
                    "the diagnostics of runs from capsflow run output.")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="a directory holding analysis.h5 (capsflow analyze), or a run output OUT.h5 (capsflow run)")
    p.add_argument("--out", required=True, metavar="FIGDIR", help="directory for the figures (created)")
    p.add_argument("--force", action="store_true", help="replace existing figure files")
    p.add_argument("--only", metavar="NAMES", default="",
                   help="the study's figures to draw, comma-separated (e.g. fig02_snapshots); default: all")

    def error(message):
        fail("%s (run 'capsflow figures --help')" % message)
    p.error = error
    return p.parse_args(argv)


def split_inputs(inputs):
    """(analysis directories, RunFile of each other input, not yet opened): a directory is an analysis, anything
    else must be a run output. Two run files that would write the same figure are refused."""
    dirs, runs, seen = [], [], {}
    for path in inputs:
        if os.path.isdir(path):
            dirs.append(path)
            continue
        if not os.path.lexists(path):
            raise InputProblem("%s: no such file or directory (%s)" % (path, RUN_WHAT))
        R = RunFile(path)
        other = seen.get(R.name)
        if other is not None:
            if os.path.realpath(other) == os.path.realpath(path):
                raise InputProblem("%s: run output given twice" % path)
            raise InputProblem("%s and %s: both would be drawn to %s.png and .svg (one --out per run name)"
                               % (other, path, R.name))
        seen[R.name] = path
        runs.append(R)
    return dirs, runs


def check_output(out, force, names):
    """Refuses an --out that is not a directory, and any of the figure files `names` would be written to that
    exists (without --force)."""
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputProblem("--out %s: exists and is not a directory" % out)
    if force or not os.path.isdir(out):
        return
    for name in names:
        for ext in EXTENSIONS:
            p = os.path.join(out, "%s.%s" % (name, ext))
            if os.path.lexists(p):
                raise InputProblem("%s: output file already exists; figures are replaced only on request "
                                   "(capsflow figures --force)" % p)


def study_figures(only):
    """The study's figures to draw: all, or those named in --only (in FIGURES' order); an unknown name is refused."""
    if not only:
        return list(FIGURES)
    names = [n.strip() for n in only.split(",") if n.strip()]
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise InputProblem("--only %s: no such figure (the study's figures: %s)" % (", ".join(unknown),
                                                                                    ", ".join(FIGURES)))
    return [n for n in FIGURES if n in names]


def draw_study(dirs, out, names):
    """The study's figures `names` from the analysis directories: (written files, skipped names, failed names)."""
    A = Analysis(dirs)
    for n in A.notes:
        print("note: " + n)
    main_set, is_set_a = A.main_set()
    ctx = Context(main_set, is_set_a, A.set_params(main_set) if main_set is not None else {})
    if main_set is not None:
        print("main set (figures 2-10, 13): '%s'%s" % (
            main_set, " (the paper's set A: its numbers are marked)" if is_set_a else
            " (not the paper's set A: the paper's numbers are marked only on pure-species curves of set A's Ca, "
            "phi and 2a/H)"))
    log, written, skipped, failed = [], [], [], []
    for name in names:
        F = Figure(name, out, log)
        try:
            if name in COMPARE:
                fig = comparison_figure(name, A, ctx, F)
            elif name in NEEDS_MAIN_SET and main_set is None:
                F.note("skipped: no suspension groups and no curves in the input")
                fig = None
            else:
                fig = DRAW[name](A, ctx, F)
            if fig is None:
                skipped.append(name)
                continue
            written += F.save(fig)
        except WriteFailed:
            raise  # a full disk or a failing one: nothing further can be written (main)
        except Exception as e:  # a figure that fails must not stop the others
            plt.close("all")
            failed.append(name)
            print("capsflow figures: %s: failed: %s: %s" % (name, type(e).__name__, " ".join(str(e).split())),
                  file=sys.stderr)
    A.close()
    return written, skipped, failed


def main(argv):
    args = parse_args(argv)
    runs = []
    try:
        names = study_figures(args.only)  # first: a bad --only is named before the inputs are opened
        dirs, runs = split_inputs(args.inputs)
        check_output(args.out, args.force, (names if dirs else []) + [R.name for R in runs])
        for R in runs:     # every input checked before anything is written
            R.open()
        if dirs:
            Analysis(dirs).close()
    except InputProblem as e:
        for R in runs:
            R.close()
        fail(e)
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as e:
        fail("--out %s: cannot create the directory (%s)" % (args.out, e.strerror or e))
    if not os.access(args.out, os.W_OK | os.X_OK):
        fail("--out %s: directory is not writable" % args.out)

    try:
        return draw_all(dirs, runs, args.out, names)
    except WriteFailed as e:
        # One line with the file and the system's reason, as capsflow says it; the files already written stay (each
        # is complete), the one being written is as it was.
        print("capsflow: error: " + " ".join(str(e).split()), file=sys.stderr)
        return 1


def draw_all(dirs, runs, out, names):
    """The study's figures (those named) and each run's; the exit status (1: a figure failed to draw)."""
    written, skipped, failed = draw_study(dirs, out, names) if dirs else ([], [], [])
    for R in runs:
        try:
            files = draw_run(R, out, [])
            if files:
                written += files
            else:
                skipped.append(R.name)
        except WriteFailed:
            raise
        except Exception as e:  # one run's figure that fails must not stop the others
            plt.close("all")
            failed.append(R.name)
            print("capsflow figures: %s: failed: %s: %s" % (R.name, type(e).__name__, " ".join(str(e).split())),
                  file=sys.stderr)
        finally:
            R.close()
    nfig = len(written) // len(EXTENSIONS)
    print("capsflow figures: wrote %d figure%s (%d files) to %s%s%s" % (
        nfig, "" if nfig == 1 else "s", len(written), out,
        "; skipped: " + ", ".join(skipped) if skipped else "",
        "; failed: " + ", ".join(failed) if failed else ""))
    for w in written:
        print("  " + w)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
