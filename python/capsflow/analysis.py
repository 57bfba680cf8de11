"""The output of `capsflow analyze` (DIR/analysis.h5 and DIR/summary.json) as named numpy arrays.

Layout: docs/analysis.md ("analysis.h5 layout"); definitions: docs/analysis.md §1-§14. Units: y/H and
d-bar/(H/2) are dimensionless; velocities (v-bar_p, v'_p, P(v_p)'s v_p, V^S, U_y) in gammadot a; times in strain
units 1/gammadot; lengths (H, Lx, Lz, snapshot positions, pair displacements) in a. NaN marks an undefined value (a
masked bin, an absent species); `Estimate.reason` says why where summary.json gives it.

Everything is read when the file is opened (the file is closed again at once).
"""

import json
import math
import os
from collections import namedtuple

import numpy as np

from ._files import MALFORMED, FormatError, UnsupportedVersionError, attrs_dict, describe, open_h5, read_consistently, text

#: The analysis format and the version of it this reader knows.
FORMAT = "capsflow-analysis"
FORMAT_VERSION = 1

SPECIES = ("stiff", "floppy", "all")
PROFILE_QUANTITIES = ("n_hat", "phi_hat", "v_bar", "v_prime", "dv_rel", "xf_hat")

_WHAT = "a capsflow analysis (analysis.h5 written by `capsflow analyze`)"

Estimate = namedtuple("Estimate", "value se reason")
Estimate.__doc__ = """A steady estimate with its standard error; value NaN (and a reason) when undefined."""

Isolated = namedtuple("Isolated", "ca y_over_H V_S")
Isolated.__doc__ = """Isolated pinned capsules of one Ca: V^S (gammadot a, positive toward the centreline) at y0/H."""

Snapshot = namedtuple("Snapshot", "time positions triangles stiff")
Snapshot.__doc__ = """One frame of the group's first run: positions [Nn, 3] (a), triangles [M, 3] (0-based), stiff [Nn]
bool (node of a stiff capsule), time (strain)."""

DBarSeries = namedtuple("DBarSeries", "time stiff floppy all")
DBarSeries.__doc__ = """d-bar(t)/(H/2) of each species at every record (averaged over realizations at equal record
index); time in strain. A species absent from the group is all NaN."""

PairSeries = namedtuple("PairSeries", "time separation disp_top disp_bottom uy_top uy_bottom ca_top ca_bottom "
                                      "final_top final_bottom")
PairSeries.__doc__ = """A pair collision in shear: time (strain since the first record), separation x_top - x_bottom (a),
(y - y_i) (a) and U_y (gammadot a) of each capsule, the bottom one sign-flipped; final displacements at
x_top - x_bottom = +10a (NaN if not reached)."""


class Profile(namedtuple("Profile", "y_over_H value se")):
    """A folded wall-normal profile over [0, H/2]: bin centres y/H, value and standard error per bin (NaN: masked)."""

    @property
    def masked(self):
        """[bins] bool: the bins without a defined value."""
        return ~np.isfinite(self.value)


class Pdf(namedtuple("Pdf", "y0_over_H edges density samples mean stddev")):
    """P(v_p) at y'/H within 0.025 of y0/H: bin edges and probability density of v_p (gammadot a), sample count,
    sample mean and standard deviation (gammadot a)."""

    @property
    def centres(self):
        return 0.5 * (self.edges[1:] + self.edges[:-1])


def _array(g, name):
    return g[name][()] if name in g else None


class Group:
    """One group of analysis.h5 (/groups/gNNN): realizations of one composition, a pinned run or a pair run.

    Attributes: id ("g000"), key, label, kind ("suspension", "pinned" or "pair"), set, runs (list of paths),
    x_f (number fraction of floppy capsules; NaN for pairs), H, Lx, Lz (a), ca_stiff, ca_floppy, window (t0, t1)
    in strain; dbar, f_AB, E: dicts species -> Estimate (steady d-bar/(H/2), transition probability, enrichment);
    dbar_t (DBarSeries); y_over_H (bin centres); snapshot (Snapshot or None); pinned groups: ca, y0_over_H, V_S,
    steady; pair groups: pair (PairSeries).
    """

    def __init__(self, gid, g):
        a = attrs_dict(g)
        self.id = gid
        self.attrs = a
        self.key = a.get("key", "")
        self.label = a.get("label", "")
        self.kind = a.get("kind", "")
        self.set = a.get("set", "")
        self.runs = [r for r in a.get("runs", "").split(",") if r]
        self.x_f = float(a.get("x_f", math.nan))
        self.H, self.Lx, self.Lz = (float(a.get(k, math.nan)) for k in ("H", "Lx", "Lz"))
        self.ca_stiff = float(a.get("ca_stiff", math.nan))
        self.ca_floppy = float(a.get("ca_floppy", math.nan))
        self.window = (float(a.get("t0", math.nan)), float(a.get("t1", math.nan)))
        undefined = Estimate(math.nan, math.nan, "not in the analysis")
        self.dbar = {s: undefined for s in SPECIES}
        self.f_AB = {s: undefined for s in ("stiff", "floppy")}
        self.E = {s: undefined for s in ("stiff", "floppy")}
        # pinned groups
        self.ca = float(a.get("ca", math.nan))
        self.y0_over_H = float(a.get("y0_over_H", math.nan))
        self.V_S = float(a.get("V_S", math.nan))
        self.steady = bool(a.get("steady", 0))

        self.dbar_t = None
        if "dbar_t" in g:
            d = g["dbar_t"]
            self.dbar_t = DBarSeries(*(_array(d, n) for n in ("time", "stiff", "floppy", "all")))
        self._profiles = {}
        self.y_over_H = None
        if "profiles" in g:
            p = g["profiles"]
            self.y_over_H = _array(p, "y_over_H")
            for name in p:
                if name != "y_over_H" and not name.endswith("_se"):
                    self._profiles[name] = (p[name][()], _array(p, name + "_se"))
        self._pdfs = {}
        if "pdf" in g:
            for sp in g["pdf"]:
                for yk, n in g["pdf"][sp].items():
                    y0 = int(yk[1:]) / 1000.0
                    na = attrs_dict(n)
                    self._pdfs[(sp, y0)] = Pdf(y0, n["edges"][()], n["density"][()], int(na.get("samples", 0)),
                                               float(na.get("mean", math.nan)), float(na.get("stddev", math.nan)))
        self.snapshot = None
        if "snapshot" in g and "positions" in g["snapshot"]:
            s = g["snapshot"]
            stiff = _array(s, "node_species_stiff")
            self.snapshot = Snapshot(float(s.attrs.get("time", math.nan)), s["positions"][()], s["triangles"][()],
                                     None if stiff is None else stiff.astype(bool))
        self.pair = None
        if self.kind == "pair" and "time" in g:
            self.pair = PairSeries(*(_array(g, n) for n in ("time", "separation", "disp_top", "disp_bottom",
                                                             "uy_top", "uy_bottom")),
                                   *(float(a.get(k, math.nan)) for k in ("ca_top", "ca_bottom", "final_top",
                                                                         "final_bottom")))

    @property
    def t0(self):
        return self.window[0]

    @property
    def t1(self):
        return self.window[1]

    @property
    def profile_names(self):
        """The profiles this group has: "n_hat_stiff", "phi_hat_floppy", "xf_hat", ..."""
        return sorted(self._profiles)

    def profile(self, quantity, species=None):
        """Profile of `quantity` (n_hat, phi_hat, v_bar, v_prime, dv_rel: give species "stiff" or "floppy";
        xf_hat: no species). n_hat, phi_hat, xf_hat and dv_rel are dimensionless, v_bar and v_prime in gammadot a.
        KeyError naming what the group has when it is absent."""
        name = quantity if species is None else "%s_%s" % (quantity, species)
        if name not in self._profiles:
            raise KeyError("group %s (%s) has no profile %r (capsflow analyze leaves out a profile undefined in every "
                           "bin, the profiles of a species the group lacks, and dv_rel when the set has no pure group "
                           "of the species); it has: %s"
                           % (self.id, self.label, name, ", ".join(self.profile_names) or "none"))
        value, se = self._profiles[name]
        if se is None:
            se = np.full_like(value, np.nan)
        return Profile(self.y_over_H, value, se)

    def pdfs(self, species):
        """{y0/H: Pdf} of P(v_p) for `species` ("stiff" or "floppy"), by height."""
        return {y0: p for (sp, y0), p in sorted(self._pdfs.items()) if sp == species}

    def __repr__(self):
        return "<capsflow analysis group %s: %s %s>" % (self.id, self.kind, self.label)


class Curve:
    """Steady results of one set against X_f (/curves/cNNN): attributes set, ca_stiff, ca_floppy, H (a), phi,
    two_a_over_H, R (= ca_floppy/ca_stiff); arrays (over the set's suspension groups, sorted by X_f) x_f,
    dbar_stiff, dbar_floppy, dbar_all, E_s, E_f, fab_stiff, fab_floppy, each with <name>_se (NaN: undefined)."""

    def __init__(self, cid, g):
        a = attrs_dict(g)
        self.id = cid
        self.set = a.get("set", "")
        self.ca_stiff = float(a.get("ca_stiff", math.nan))
        self.ca_floppy = float(a.get("ca_floppy", math.nan))
        self.H = float(a.get("H", math.nan))
        self.phi = float(a.get("phi", math.nan))
        self.two_a_over_H = float(a.get("two_a_over_H", math.nan))
        self.R = self.ca_floppy / self.ca_stiff
        self.arrays = {name: g[name][()] for name in g}
        for name, v in self.arrays.items():
            setattr(self, name, v)

    def estimate(self, name, x_f):
        """Estimate of curve `name` (e.g. "dbar_stiff") at the group with this X_f; None if the set has none."""
        i = np.flatnonzero(self.arrays["x_f"] == x_f)
        if i.size == 0 or name not in self.arrays:
            return None
        se = self.arrays.get(name + "_se")
        return Estimate(float(self.arrays[name][i[0]]), math.nan if se is None else float(se[i[0]]), None)

    def __repr__(self):
        return "<capsflow analysis curve %s: set %s>" % (self.id, self.set)


def _members(path, h5, name):
    """The members of group /name (none when it is absent); FormatError when /name is not a group."""
    if name not in h5:
        return []
    g = h5[name]
    if not hasattr(g, "keys"):
        raise FormatError("%s: /%s: expected a group, got a dataset (a damaged or hand-edited file)" % (path, name))
    return list(g.keys())


def _parsed(path, where, make, *args):
    """make(*args), with what a malformed object raises inside h5py and numpy as FormatError naming file and path."""
    try:
        return make(*args)
    except FormatError:
        raise
    except MALFORMED as e:
        raise FormatError("%s: %s: malformed (%s; a damaged or hand-edited file)" % (path, where, describe(e))) from e


def _isolated(n):
    ca = float(n.attrs["ca"])
    return Isolated(ca, n["y_over_H"][()], n["V_S"][()])


class Analysis:
    """The result of `capsflow analyze`; use `capsflow.open_analysis(path)`.

    Attributes: path (analysis.h5), format_version, capsflow_version, bins (folded bins over [0, H/2]);
    groups (list of Group, file order); curves (list of Curve, one per set); isolated (dict Ca -> Isolated);
    summary (summary.json as a dict, or None when it is not next to analysis.h5).
    """

    def __init__(self, path):
        path = os.fspath(path)
        if os.path.isdir(path):
            path = os.path.join(path, "analysis.h5")
            if not os.path.exists(path):
                raise FileNotFoundError("%s: no analysis.h5 in this directory (expected %s; write it with capsflow "
                                        "analyze)" % (os.path.dirname(path), _WHAT))
        self.path = path
        read_consistently(path, self._read_file)
        self.summary = self._read_summary()
        try:
            self._fill_estimates()
        except (AttributeError, TypeError, ValueError, KeyError) as e:
            raise FormatError("%s: malformed next to %s (%s; a damaged or hand-edited file)"
                              % (os.path.join(os.path.dirname(self.path), "summary.json"), self.path, describe(e)))

    def _read_file(self):
        """Everything of analysis.h5 (read_consistently calls it again while the file changes)."""
        path = self.path
        with open_h5(path, _WHAT) as h5:
            fmt = text(h5.attrs["format"]) if "format" in h5.attrs else None
            if fmt != FORMAT:
                hint = "; open a run output with capsflow.open_run" if "series" in h5 and "parameters" in h5 else ""
                raise FormatError("%s: not %s: attribute format = %r, expected %r%s" % (path, _WHAT, fmt, FORMAT, hint))
            version = h5.attrs.get("format_version")
            if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)):
                raise UnsupportedVersionError("%s: attribute format_version = %r is not an integer analysis format "
                                              "version (this reader knows version %d)" % (path, version, FORMAT_VERSION))
            if version != FORMAT_VERSION:
                raise UnsupportedVersionError("%s: written in analysis format version %d; this reader knows version %d"
                                              % (path, version, FORMAT_VERSION))
            self.format_version = int(version)
            root = attrs_dict(h5)
            self.capsflow_version = root.get("capsflow_version")
            self.bins = int(root.get("bins", 0))
            self.groups = [_parsed(path, "/groups/" + k, Group, k, h5["groups"][k])
                           for k in sorted(_members(path, h5, "groups"))]
            self.curves = [_parsed(path, "/curves/" + k, Curve, k, h5["curves"][k])
                           for k in sorted(_members(path, h5, "curves"))]
            self.isolated = {}
            for k in sorted(_members(path, h5, "isolated")):
                iso = _parsed(path, "/isolated/" + k, _isolated, h5["isolated"][k])
                self.isolated[iso.ca] = iso

    def _read_summary(self):
        p = os.path.join(os.path.dirname(self.path), "summary.json")
        if not os.path.isfile(p):
            return None
        try:
            with open(p, encoding="utf-8") as fh:
                return json.load(fh)
        except ValueError as e:
            raise FormatError("%s: not valid JSON (%s)" % (p, e))

    def _fill_estimates(self):
        """d-bar, f_AB and E per group: the exact doubles of /curves where the group is on a curve, else the values
        of summary.json (the same doubles: written at full precision; pinned groups); the reasons from summary.json."""
        summary_species = {e.get("id"): e.get("species", {}) for e in (self.summary or {}).get("groups", [])}
        targets = ([("dbar", s, "dbar_" + s) for s in SPECIES] + [("f_AB", s, "fab_" + s) for s in ("stiff", "floppy")]
                   + [("E", "stiff", "E_s"), ("E", "floppy", "E_f")])
        for g in self.groups:
            sp = summary_species.get(g.id, {})
            c = self.curve(g.set) if g.kind == "suspension" else None
            for attr, s, curve_name in targets:
                js = sp.get(s, {}).get(attr)
                # reason: why the value is null, or why its SE is (se_reason: not estimable, issue 35)
                reason = (js.get("reason") or js.get("se_reason")) if isinstance(js, dict) else None
                est = c.estimate(curve_name, g.x_f) if c is not None else None
                if est is None and isinstance(js, dict):
                    v, se = js.get("value"), js.get("se")
                    est = Estimate(math.nan if v is None else float(v), math.nan if se is None else float(se), None)
                if est is not None:
                    getattr(g, attr)[s] = est._replace(reason=reason)

    def curve(self, set_key):
        """The Curve of a set, or None."""
        return next((c for c in self.curves if c.set == set_key), None)

    def suspension_groups(self, set_key=None):
        """Suspension groups (of one set if given), sorted by X_f."""
        gs = [g for g in self.groups if g.kind == "suspension" and (set_key is None or g.set == set_key)]
        return sorted(gs, key=lambda g: g.x_f)

    def group(self, key):
        """The group with this id ("g000") or label."""
        for g in self.groups:
            if key in (g.id, g.label):
                return g
        raise KeyError("%s: no group %r (groups: %s)" % (self.path, key, ", ".join(g.id for g in self.groups)))

    def __repr__(self):
        return "<capsflow analysis %s: %d groups, %d sets>" % (self.path, len(self.groups), len(self.curves))


def open_analysis(path):
    """Reads the output of `capsflow analyze`: its directory, or the analysis.h5 in it.

    Raises FileNotFoundError (no such file or directory, no analysis.h5 in the directory), capsflow.FormatError (not
    HDF5, not a capsflow analysis) and capsflow.UnsupportedVersionError (an analysis format this reader does not
    know).
    """
    return Analysis(path)
