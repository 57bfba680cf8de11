#!/usr/bin/env python3
"""capsflow figures: draw the figures of Kumar & Graham's segregation study from `capsflow analyze` output.

    capsflow_figures.py ANALYSIS_DIR... --out FIGDIR [--force]

Reads ANALYSIS_DIR/analysis.h5 (layout: docs/usage.md, "capsflow figures") from each directory and writes
FIGDIR/figNN_<name>.png and .svg for every figure of ../shared/docs/analysis-spec.md section 5 that has data.
Usually run through `capsflow figures` (src/host/cli/figures_command.cpp), which finds this file and a python3
with matplotlib and h5py.

Which data go where:
  * Figures 2-10 and 13 show one set, the "main set": the set with the paper's set A parameters (Ca 0.2/0.5,
    phi 0.2, 2a/H 0.197) if one is present, otherwise the set with the most suspension groups (first given wins
    a tie). The paper's numbers are marked only when the main set is set A.
  * Figure 8a adds the isolated-capsule curves (/isolated) whose Ca is the main set's stiff or floppy Ca.
  * Figure 11 uses every pair group of every directory.
  * Figures 14-16 compare sets (/curves of every directory) that differ in one of 2a/H, phi and
    R = Ca_floppy/Ca_stiff and agree in the other two (and in the species' Ca for 14 and 15).

A figure or panel without data is skipped with one line on stdout ("fig13_fab: skipped: ..."); that is not an
error. Exit status: 0 (the summary lists what was written, possibly nothing); 2 bad input, one line
"capsflow: error: ..." on stderr, nothing written (a directory without analysis.h5, a file of another format,
an existing output file without --force); 1 a figure failed to draw (the others are still written).
Each file is written to a temporary name in FIGDIR and renamed, so a reader never sees half a figure.
"""

import argparse
import math
import os
import sys

FORMAT = "capsflow-analysis"
FORMAT_VERSION = 1
FIGURES = [
    "fig02_snapshots", "fig03_dbar_t", "fig04_dbar_xf", "fig05_n_hat", "fig06_phi_hat", "fig07_enrichment",
    "fig08_v_bar", "fig09_pdf", "fig10_v_prime", "fig11_pair_collisions", "fig13_fab", "fig14_confinement",
    "fig15_volume_fraction", "fig16_rigidity_ratio",
]
EXTENSIONS = ("png", "svg")

# The paper's set A (analysis-spec 1.4) and the numbers it states (analysis-spec 6.1).
SET_A = {"ca_stiff": 0.2, "ca_floppy": 0.5, "phi": 0.2, "two_a_over_H": 0.197}
PAPER_FAB_STIFF = [(0.0, 0.081), (0.8, 0.015)]
PAPER_FAB_FLOPPY = [(1.0, 0.083), (0.2, 0.1413)]

STIFF = "tab:blue"
FLOPPY = "tab:red"
OVERALL = "black"
SNAP_STIFF = "#8db6f0"   # the paper's snapshots: stiff light (blue), floppy dark (red)
SNAP_FLOPPY = "#9c1c1c"


class InputProblem(Exception):
    """Bad input the user can fix: exit 2 with one line."""


def fail(message):
    print("capsflow: error: " + " ".join(str(message).split()), file=sys.stderr)
    sys.exit(2)


try:
    import numpy as np
    import h5py
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Circle, FancyArrowPatch, Rectangle
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


# ---------------------------------------------------------------------------------------------------------------
# Drawing helpers

def is_xf(g, value):
    return abs(g.x_f - value) < 1e-6


def mixture(g):
    return 1e-6 < g.x_f < 1 - 1e-6


def xf_label(x):
    return r"$X_f = %g$" % round(x, 3)


def panel_letter(ax, letter):
    ax.text(-0.16, 1.03, "(%s)" % letter, transform=ax.transAxes, fontweight="bold", va="bottom")


def no_data(ax, text):
    ax.text(0.5, 0.5, "no data\n" + text, transform=ax.transAxes, ha="center", va="center", color="0.45",
            fontsize=8, wrap=True)
    ax.set_xticks([])
    ax.set_yticks([])


def shades(cmap_name, n, lo=0.35, hi=1.0):
    cmap = plt.get_cmap(cmap_name)
    if n <= 1:
        return [cmap(hi)]
    return [cmap(lo + (hi - lo) * i / (n - 1)) for i in range(n)]


def plot_err(ax, x, y, se=None, **kw):
    """A line with error bars (where an SE is given and finite)."""
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


def profile_axes(ax, ylabel):
    ax.set_xlabel(r"$y/H$ (wall $\leftarrow$, centreline $\rightarrow$)")
    ax.set_ylabel(ylabel)


class Figure:
    """Notes and panels of one figure; save() writes PNG and SVG atomically."""

    def __init__(self, name, out, log):
        self.name = name
        self.out = out
        self.log = log

    def note(self, text):
        self.log.append("%s: %s" % (self.name, text))
        print("%s: %s" % (self.name, text))

    def save(self, fig):
        written = []
        try:
            for ext in EXTENSIONS:
                final = os.path.join(self.out, "%s.%s" % (self.name, ext))
                tmp = os.path.join(self.out, ".%s.%s.tmp.%d" % (self.name, ext, os.getpid()))
                try:
                    meta = {"Date": None} if ext == "svg" else {"Software": None}
                    fig.savefig(tmp, format=ext, dpi=150, metadata=meta)
                    with open(tmp, "rb") as fh:
                        os.fsync(fh.fileno())
                    os.replace(tmp, final)
                finally:
                    if os.path.exists(tmp):
                        os.remove(tmp)
                written.append(final)
        finally:
            plt.close(fig)
        return written


# ---------------------------------------------------------------------------------------------------------------
# The figures. Each returns a matplotlib figure, or None after printing why it was skipped.

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
        draw_snapshot(ax, g, F)
    # Two lines: the set key alone is as wide as a one-panel figure.
    fig.suptitle("Snapshots in the shear plane (x-y): stiff light blue, floppy dark red\nset %s" % ctx.main,
                 fontsize=8)
    fig.tight_layout()
    return fig


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
        no_data(ax, "snapshot of %s unreadable" % g.label)
        F.note("%s: snapshot arrays malformed, panel left empty" % g.label)
        return
    if stiff is None or stiff.shape[0] != pos.shape[0]:
        stiff = np.zeros(pos.shape[0], dtype=np.int64)
        stiff[:] = 1 if is_xf(g, 0.0) else 0
        F.note("%s: no snapshot/node_species_stiff, species colours from X_f" % g.label)
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
    ax.set_xlabel(r"$x/a$")
    ax.set_ylabel(r"$y/a$")


def fig03_dbar_t(A, ctx, F):
    gs = A.suspension(ctx.main)
    pure_s = next((g for g in gs if is_xf(g, 0.0) and g.has("dbar_t/stiff")), None)
    pure_f = next((g for g in gs if is_xf(g, 1.0) and g.has("dbar_t/floppy")), None)
    mixes = [g for g in gs if mixture(g) and g.has("dbar_t/time")]
    mix = min(mixes, key=lambda g: abs(g.x_f - 0.2)) if mixes else None
    if pure_s is None and pure_f is None and mix is None:
        F.note("skipped: no d-bar(t) (dbar_t/*) in the suspension groups of set '%s'" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.6), gridspec_kw={"width_ratios": [0.8, 1, 1]})
    draw_d_schematic(axs[0])
    panel_letter(axs[0], "a")
    ax = axs[1]
    panel_letter(ax, "b")
    drawn = False
    for g, sp, col, lab in ((pure_s, "stiff", STIFF, "S"), (pure_f, "floppy", FLOPPY, "F")):
        if g is None:
            F.note("(b): no pure %s group (X_f = %d) with dbar_t/%s" % (sp, 0 if sp == "stiff" else 1, sp))
            continue
        t, d = g.data("dbar_t/time"), g.data("dbar_t/" + sp)
        if t is None or d is None or t.shape != d.shape:
            F.note("(b): %s: dbar_t/time and dbar_t/%s missing or of different lengths" % (g.label, sp))
            continue
        ax.plot(t, d, color=col, lw=0.8, label="%s (%s)" % (lab, xf_label(g.x_f)))
        drawn = True
    if drawn:
        ax.set_xlabel(r"$\dot\gamma_w t$")
        ax.set_ylabel(r"$\bar{d}/(H/2)$")
        ax.set_title("pure species")
        ax.legend()
    else:
        no_data(ax, "pure species d-bar(t)")
    ax = axs[2]
    panel_letter(ax, "c")
    if mix is None:
        no_data(ax, "no mixture with d-bar(t)")
        F.note("(c): no mixture group (0 < X_f < 1) with dbar_t")
    else:
        t = mix.data("dbar_t/time")
        for sp, col, lab in (("stiff", STIFF, "S"), ("floppy", FLOPPY, "F"), ("all", OVERALL, "overall")):
            d = mix.data("dbar_t/" + sp)
            if d is not None and t is not None and d.shape == t.shape:
                ax.plot(t, d, color=col, lw=0.8, label=lab)
        ax.set_xlabel(r"$\dot\gamma_w t$")
        ax.set_ylabel(r"$\bar{d}/(H/2)$")
        ax.set_title("mixture, " + xf_label(mix.x_f) + (" (runs: %d)" % len(mix.sattr("runs").split(","))
                                                        if mix.sattr("runs") else ""))
        ax.legend()
    fig.tight_layout()
    return fig


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
    ax.set_axis_off()
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
    series = [(n, col, lab, m) for n, col, lab, m in (("dbar_stiff", STIFF, "S", "o"), ("dbar_floppy", FLOPPY, "F", "s"),
                                                      ("dbar_all", OVERALL, "overall", "^"))]
    data = [(curve_series(c, n), col, lab, m) for n, col, lab, m in series]
    if all(d is None for d, *_ in data):
        F.note("skipped: set '%s' has no steady d-bar (dbar_stiff, dbar_floppy, dbar_all all absent or NaN)" % ctx.main)
        return None
    fig, ax = plt.subplots(figsize=(4.6, 3.6))
    for d, col, lab, m in data:
        if d is not None:
            plot_err(ax, d[0], d[1], d[2], color=col, marker=m, label=lab)
    ax.set_xlabel(r"$X_f$")
    ax.set_ylabel(r"$\bar{d}/(H/2)$ (steady, window $[t_0, t_1]$)")
    ax.set_xlim(-0.05, 1.05)
    ax.legend()
    ax.set_title("set '%s'" % ctx.main, fontsize=7)
    fig.tight_layout()
    return fig


def profile_figure(A, ctx, F, qty, ylabel, guides=(0.2, 0.3), pure_extra=None, hline=None):
    """Figures 5, 6, 10: (a) pure species, (b) stiff at X_f in [0, 1), (c) floppy at X_f in (0, 1]."""
    gs = A.suspension(ctx.main)
    y_of = {id(g): g.data("profiles/y_over_H") for g in gs}
    pure = [(next((g for g in gs if is_xf(g, x) and g.has("profiles/%s_%s" % (qty, sp))
                   and y_of[id(g)] is not None), None), sp, col, lab)
            for x, sp, col, lab in ((0.0, "stiff", STIFF, "S"), (1.0, "floppy", FLOPPY, "F"))]
    per = {sp: [g for g in gs if g.has("profiles/%s_%s" % (qty, sp)) and y_of[id(g)] is not None]
           for sp in ("stiff", "floppy")}
    if all(p[0] is None for p in pure) and not per["stiff"] and not per["floppy"]:
        F.note("skipped: no profiles/%s_<species> with profiles/y_over_H in set '%s'" % (qty, ctx.main))
        return None
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.6), sharey=True)

    def one(ax, g, sp, **kw):
        y = y_of[id(g)]
        v = g.data("profiles/%s_%s" % (qty, sp))
        se = g.data("profiles/%s_%s_se" % (qty, sp))
        if v is None or v.shape != y.shape:
            F.note("%s: profiles/%s_%s has the wrong length, not drawn" % (g.label, qty, sp))
            return False
        plot_err(ax, y, v, se, **kw)
        return True

    ax = axs[0]
    panel_letter(ax, "a")
    drawn = False
    for g, sp, col, lab in pure:
        if g is None:
            F.note("(a): no pure %s group with profiles/%s_%s" % (sp, qty, sp))
            continue
        drawn |= one(ax, g, sp, color=col, marker="o" if sp == "stiff" else "s", ms=3, label=lab)
    if pure_extra is not None and drawn:
        pure_extra(ax)
    ax.set_title(r"pure species ($X_f = 0$ & $X_f = 1$)")
    if not drawn:
        no_data(ax, "pure species")
    else:
        ax.legend()
    for ax, sp, cmap, lab in ((axs[1], "stiff", "Blues", "b"), (axs[2], "floppy", "Reds", "c")):
        panel_letter(ax, lab)
        lst = [g for g in per[sp] if (g.x_f < 1 - 1e-6 if sp == "stiff" else g.x_f > 1e-6)]
        ax.set_title("%s particles vs $X_f$" % sp)
        if not lst:
            no_data(ax, "%s profiles" % sp)
            F.note("(%s): no group with profiles/%s_%s" % (lab, qty, sp))
            continue
        for g, col in zip(lst, shades(cmap, len(lst))):
            one(ax, g, sp, color=col, marker=".", label=xf_label(g.x_f))
        ax.legend()
    for ax in axs:
        if ax.has_data():
            y_guides(ax, guides)
            if hline is not None:
                ax.axhline(hline, color="0.6", lw=0.7, ls="--", zorder=0)
            profile_axes(ax, ylabel)
    fig.tight_layout()
    return fig


def fig05_n_hat(A, ctx, F):
    return profile_figure(A, ctx, F, "n_hat", r"$\hat{n}(y)$ (uniform = 1)", hline=1.0)


def fig06_phi_hat(A, ctx, F):
    def paper_mark(ax):
        if ctx.is_set_a:
            ax.plot([0.5], [2.0], marker="*", ms=10, color="k", ls="none", mfc="none", clip_on=False,
                    label=r"paper: $\hat\phi(0.5H) \approx 2$ ($\phi \approx 0.4$)")
    return profile_figure(A, ctx, F, "phi_hat", r"$\hat{\phi}(y)$ (uniform = 1)", pure_extra=paper_mark, hline=1.0)


def fig07_enrichment(A, ctx, F):
    gs = [g for g in A.suspension(ctx.main) if mixture(g) and g.has("profiles/xf_hat")
          and g.has("profiles/y_over_H")]
    c = A.curve(ctx.main)
    es = curve_series(c, "E_s") if c is not None else None
    ef = curve_series(c, "E_f") if c is not None else None
    if not gs and es is None and ef is None:
        F.note("skipped: set '%s' has no profiles/xf_hat and no E_s, E_f in /curves" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.6))
    ax = axs[0]
    panel_letter(ax, "a")
    if gs:
        for g, col in zip(gs, shades("viridis", len(gs), 0.0, 0.85)):
            y, v = g.data("profiles/y_over_H"), g.data("profiles/xf_hat")
            if v is None or y is None or v.shape != y.shape:
                continue
            plot_err(ax, y, v, g.data("profiles/xf_hat_se"), color=col, marker=".", label=xf_label(g.x_f))
        ax.axhline(1.0, color="k", lw=0.8, ls="-", zorder=0, label=r"$\hat{X}_f = 1$")
        ax.axvline(0.25, color="0.4", lw=0.8, ls=":", zorder=0,
                   label=r"paper: $\hat{X}_f = 1$ at $y \approx H/4$" if ctx.is_set_a else r"$y = H/4$")
        ax.set_xlim(0, 0.5)
        profile_axes(ax, r"$\hat{X}_f(y)$")
        ax.legend()
    else:
        no_data(ax, "no profiles/xf_hat")
        F.note("(a): no mixture group with profiles/xf_hat")
    ax = axs[1]
    panel_letter(ax, "b")
    if es is None and ef is None:
        no_data(ax, "no E_s, E_f")
        F.note("(b): no E_s, E_f in /curves of set '%s'" % ctx.main)
    else:
        if ef is not None:
            plot_err(ax, ef[0], ef[1], ef[2], color=FLOPPY, marker="s", label="F ($E_f$)")
        if es is not None:
            plot_err(ax, es[0], es[1], es[2], color=STIFF, marker="o", label="S ($E_s$)")
        ax.axhline(1.0, color="0.6", lw=0.7, ls="--", zorder=0)
        ax.set_xlim(0, 1)
        ax.set_xlabel(r"$X_f$")
        ax.set_ylabel(r"enrichment factor $E$ ($\geq 1$)")
        ax.legend()
    fig.tight_layout()
    return fig


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
    iso = [(isolated_curve(A, ca), ca, col, lab) for ca, col, lab in ((ca_s, STIFF, "S*"), (ca_f, FLOPPY, "F*"))]

    def isolated(ax):
        drawn = False
        for cur, ca, col, lab in iso:
            if cur is None:
                F.note("(a): no /isolated curve for Ca = %g (%s)" % (ca, lab))
                continue
            ax.plot(cur[0], cur[1], color=col, ls="--", marker="D", mfc="white", ms=3.5,
                    label="%s (isolated, Ca = %g)" % (lab, ca))
            drawn = True
        return drawn

    has_v = any(g.has("profiles/v_bar_stiff") or g.has("profiles/v_bar_floppy") for g in gs)
    has_rel = any(mixture(g) and (g.has("profiles/dv_rel_stiff") or g.has("profiles/dv_rel_floppy")) for g in gs)
    if not has_v and not has_rel and all(i[0] is None for i in iso):
        F.note("skipped: set '%s' has no profiles/v_bar_*, profiles/dv_rel_* and no isolated curves" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.6))
    ax = axs[0]
    panel_letter(ax, "a")
    drawn = False
    for x, sp, col, lab in ((0.0, "stiff", STIFF, "S"), (1.0, "floppy", FLOPPY, "F")):
        g = next((g for g in gs if is_xf(g, x) and g.has("profiles/v_bar_" + sp)), None)
        if g is None:
            F.note("(a): no pure %s group with profiles/v_bar_%s" % (sp, sp))
            continue
        y, v = g.data("profiles/y_over_H"), g.data("profiles/v_bar_" + sp)
        if y is None or v is None or y.shape != v.shape:
            continue
        plot_err(ax, y, v, g.data("profiles/v_bar_%s_se" % sp), color=col, marker="o" if sp == "stiff" else "s",
                 ms=3, label="%s (%s)" % (lab, xf_label(x)))
        drawn = True
    drawn |= isolated(ax)
    ax.set_title("pure species and isolated capsules")
    if drawn:
        ax.axhline(0, color="0.6", lw=0.7, zorder=0)
        y_guides(ax)
        profile_axes(ax, r"$\bar{v}_p/(\dot\gamma_w a)$")
        ax.legend()
    else:
        no_data(ax, "v-bar_p")
    for ax, sp, cmap, lab in ((axs[1], "stiff", "Blues", "b"), (axs[2], "floppy", "Reds", "c")):
        panel_letter(ax, lab)
        ax.set_title("%s particles: change against pure %s" % (sp, sp))
        lst = [g for g in gs if mixture(g) and g.has("profiles/dv_rel_" + sp)]
        if not lst:
            no_data(ax, "no profiles/dv_rel_%s\n(needs the pure-%s reference)" % (sp, sp))
            F.note("(%s): no mixture group with profiles/dv_rel_%s" % (lab, sp))
            continue
        for g, col in zip(lst, shades(cmap, len(lst))):
            y, v = g.data("profiles/y_over_H"), g.data("profiles/dv_rel_" + sp)
            if y is None or v is None or y.shape != v.shape:
                continue
            plot_err(ax, y, v, g.data("profiles/dv_rel_%s_se" % sp), color=col, marker=".", label=xf_label(g.x_f))
        ax.axhline(0, color="0.6", lw=0.7, zorder=0)
        if sp == "stiff" and ctx.is_set_a:
            ax.axhline(-0.5, color="k", lw=0.7, ls="-.", zorder=0, label=r"paper: up to $\approx -50\%$")
        y_guides(ax)
        profile_axes(ax, r"$\Delta\bar{v}_p/v_r$")
        ax.legend()
    fig.tight_layout()
    return fig


def fig09_pdf(A, ctx, F):
    gs = A.suspension(ctx.main)
    panels = []
    for x, sp, lab in ((0.0, "stiff", "a"), (1.0, "floppy", "b")):
        g = next((g for g in gs if is_xf(g, x) and g.child("pdf/" + sp) is not None), None)
        panels.append((g, sp, lab, x))
    if all(p[0] is None for p in panels):
        F.note("skipped: no pure-species group of set '%s' has pdf/<species>" % ctx.main)
        return None
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    for ax, (g, sp, lab, x) in zip(axs, panels):
        panel_letter(ax, lab)
        ax.set_title("pure %s (%s)" % (sp, xf_label(x)))
        if g is None:
            no_data(ax, "pdf/%s" % sp)
            F.note("(%s): no group at X_f = %g with pdf/%s" % (lab, x, sp))
            continue
        ys = sorted(g.children("pdf/" + sp), key=lambda kv: kv[0])
        ys = [(k, n) for k, n in ys if k.startswith("y") and k[1:].isdigit()]
        drawn = False
        for (k, n), col in zip(ys, shades("viridis", len(ys), 0.0, 0.85)):
            e, d = n.data("edges"), n.data("density")
            if e is None or d is None or e.shape[0] != d.shape[0] + 1:
                F.note("(%s): pdf/%s/%s: edges/density missing or inconsistent" % (lab, sp, k))
                continue
            mid = 0.5 * (e[1:] + e[:-1])
            ok = d > 0
            nsamp = n.attr("samples")
            ax.semilogy(mid[ok], d[ok], color=col, marker=".", ms=2, lw=0.8,
                        label=r"$y/H = %g$%s" % (int(k[1:]) / 1000.0,
                                                 "" if nsamp is None else " (%d samples)" % int(nsamp)))
            mean, sd = n.fattr("mean"), n.fattr("stddev")
            if math.isfinite(mean) and math.isfinite(sd) and sd > 0 and ok.any():
                vv = np.linspace(mid[ok].min(), mid[ok].max(), 200)
                gauss = np.exp(-0.5 * ((vv - mean) / sd) ** 2) / (sd * math.sqrt(2 * math.pi))
                keep = gauss >= d[ok].min() * 0.5
                ax.semilogy(vv[keep], gauss[keep], color=col, lw=0.6, ls="--")
            drawn = True
        if not drawn:
            no_data(ax, "pdf/%s" % sp)
            continue
        ax.set_xlabel(r"$v_p/(\dot\gamma_w a)$")
        ax.set_ylabel(r"$P(v_p)$")
        ax.plot([], [], color="0.5", lw=0.6, ls="--", label="Gaussian, same mean and s.d.")
        ax.legend()
    fig.tight_layout()
    return fig


def fig10_v_prime(A, ctx, F):
    return profile_figure(A, ctx, F, "v_prime", r"$v'_p/(\dot\gamma_w a)$")


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
    fig, axs = plt.subplots(2, 2, figsize=(9, 6.4), sharex="col")
    specs = [(axs[0, 0], "a", "disp", homo, r"$(y - y_i)/a$", "homogeneous: top particle"),
             (axs[0, 1], "b", "disp", hetero, r"$(y - y_i)/a$", "heterogeneous: stiff and floppy"),
             (axs[1, 0], "c", "uy", homo, r"$U_y/(\dot\gamma a)$", "homogeneous: top particle"),
             (axs[1, 1], "d", "uy", hetero, r"$U_y/(\dot\gamma a)$", "heterogeneous: stiff and floppy")]
    styles = ["-", "--", ":", "-."]
    for ax, lab, q, lst, ylabel, title in specs:
        panel_letter(ax, lab)
        ax.set_title(title)
        if not lst:
            no_data(ax, "no %s pair groups" % ("homogeneous" if lab in "ac" else "heterogeneous"))
            F.note("(%s): no %s pair groups" % (lab, "homogeneous" if lab in "ac" else "heterogeneous"))
            continue
        seen = {}
        if lab in "ac":
            for g, col in zip(lst, shades("viridis", len(lst), 0.0, 0.85)):
                t, v = g.data("time"), g.data(q + "_top")
                if t is None or v is None or t.shape != v.shape:
                    F.note("(%s): %s: time/%s_top missing or of different lengths" % (lab, g.label, q))
                    continue
                key = "Ca = %g" % g.fattr("ca_top")
                seen[key] = seen.get(key, 0) + 1
                ax.plot(t, v, color=col, label=key + ("" if seen[key] == 1 else " (%s)" % g.label))
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
                        F.note("(%s): %s: time/%s_%s missing or of different lengths" % (lab, g.label, q, pos_))
                        continue
                    ax.plot(t, v, color=col, ls=ls,
                            label="%s Ca = %g (%s), pair %g/%g" % (sp, ca, pos_, ca_s, ca_f))
        ax.axhline(0, color="0.6", lw=0.6, zorder=0)
        ax.set_ylabel(ylabel)
        if lab in "cd":
            ax.set_xlabel(r"$\dot\gamma t$")
        ax.legend()
    fig.text(0.5, 0.005, "bottom particle sign-flipped: both positive when the pair separates", ha="center",
             fontsize=7, color="0.4")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    return fig


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
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.6), gridspec_kw={"width_ratios": [0.7, 1]})
    ax = axs[0]
    panel_letter(ax, "a")
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
    ax.set_axis_off()
    ax.set_title("regions: A within 0.3H of a wall, B the rest")
    ax = axs[1]
    panel_letter(ax, "b")
    for d, col, lab, m in ((fs, STIFF, "S", "o"), (ff, FLOPPY, "F", "s")):
        if d is None:
            F.note("(b): no %s f_AB values" % ("stiff" if lab == "S" else "floppy"))
            continue
        plot_err(ax, d[0], d[1], d[2], color=col, marker=m, label=lab)
    if ctx.is_set_a:
        for pts, col, lab in ((PAPER_FAB_STIFF, STIFF, "paper (S): 0.081 to 0.015"),
                              (PAPER_FAB_FLOPPY, FLOPPY, "paper (F): 0.083 to 0.141")):
            ax.plot([p[0] for p in pts], [p[1] for p in pts], ls="none", marker="*", ms=9, mfc="none", mec=col,
                    label=lab)
    ax.set_xlim(-0.05, 1.05)
    ax.set_ylim(bottom=0)
    ax.set_xlabel(r"$X_f$")
    ax.set_ylabel(r"$f_{AB}$ (A $\to$ B within 100 strain)")
    ax.legend()
    fig.tight_layout()
    return fig


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
    fig, axs = plt.subplots(1, 3, figsize=(13, 3.6))
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
        for j, (q, col, sp) in enumerate((("dbar_stiff", STIFF, "S"), ("dbar_floppy", FLOPPY, "F"))):
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
    ylabels = (r"$\bar{d}/(H/2)$", r"$E_s$", r"$E_f$")
    for k, ax in enumerate(axs):
        panel_letter(ax, "abc"[k])
        ax.set_title(titles[k])
        if not drawn[k]:
            no_data(ax, ("d-bar", "E_s", "E_f")[k])
            F.note("(%s): no %s in the compared sets" % ("abc"[k], ("d-bar", "E_s", "E_f")[k]))
            continue
        ax.set_xlabel(r"$X_f$")
        ax.set_ylabel(ylabels[k])
        ax.set_xlim(-0.05, 1.05)
        if k:
            ax.axhline(1.0, color="0.6", lw=0.7, ls="--", zorder=0)
        ax.legend()
    if not any(drawn):
        plt.close(fig)
        F.note("skipped: the compared sets have no d-bar and no E values")
        return None
    fig.tight_layout()
    return fig


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
    def __init__(self, main, is_set_a):
        self.main = main
        self.is_set_a = is_set_a


# ---------------------------------------------------------------------------------------------------------------

def parse_args(argv):
    p = argparse.ArgumentParser(
        prog="capsflow figures",
        description="Draw the figures of the segregation study (PNG and SVG) from capsflow analyze output.")
    p.add_argument("dirs", nargs="+", metavar="ANALYSIS_DIR", help="directory holding analysis.h5")
    p.add_argument("--out", required=True, metavar="FIGDIR", help="directory for the figures (created)")
    p.add_argument("--force", action="store_true", help="replace existing figure files")

    def error(message):
        fail("%s (run 'capsflow figures --help')" % message)
    p.error = error
    return p.parse_args(argv)


def check_output(out, force):
    if os.path.exists(out) and not os.path.isdir(out):
        raise InputProblem("--out %s: exists and is not a directory" % out)
    if force or not os.path.isdir(out):
        return
    for name in FIGURES:
        for ext in EXTENSIONS:
            p = os.path.join(out, "%s.%s" % (name, ext))
            if os.path.lexists(p):
                raise InputProblem("%s: output file already exists; figures are replaced only on request "
                                   "(capsflow figures --force)" % p)


def main(argv):
    args = parse_args(argv)
    try:
        check_output(args.out, args.force)
        A = Analysis(args.dirs)
    except InputProblem as e:
        fail(e)
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as e:
        fail("--out %s: cannot create the directory (%s)" % (args.out, e.strerror or e))
    if not os.access(args.out, os.W_OK | os.X_OK):
        fail("--out %s: directory is not writable" % args.out)

    for n in A.notes:
        print("note: " + n)
    main_set, is_set_a = A.main_set()
    ctx = Context(main_set, is_set_a)
    if main_set is not None:
        print("main set (figures 2-10, 13): '%s'%s" % (main_set, " (the paper's set A: its numbers are marked)"
                                                       if is_set_a else " (not the paper's set A: no paper marks)"))
    log, written, skipped, failed = [], [], [], []
    for name in FIGURES:
        F = Figure(name, args.out, log)
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
        except Exception as e:  # a figure that fails must not stop the others
            plt.close("all")
            failed.append(name)
            print("capsflow figures: %s: failed: %s: %s" % (name, type(e).__name__, " ".join(str(e).split())),
                  file=sys.stderr)
    A.close()
    nfig = len(written) // len(EXTENSIONS)
    print("capsflow figures: wrote %d figure%s (%d files) to %s%s%s" % (
        nfig, "" if nfig == 1 else "s", len(written), args.out,
        "; skipped: " + ", ".join(skipped) if skipped else "",
        "; failed: " + ", ".join(failed) if failed else ""))
    for w in written:
        print("  " + w)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
