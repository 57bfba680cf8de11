#!/usr/bin/env python3
"""The claims tables of docs/reproduction.md, computed from one or more `capsflow analyze` outputs.

Every claim of the paper (its numbers and its qualitative statements) that sweeps of KG's sets at X_f = 0, 0.5 and 1 can test is turned
into a number with its standard error and a verdict by a fixed rule, so that the tables are made by the program and
not by hand. Several analyses (set A and set C) may be given at once: each set gets its own tables of steady values
and steadiness, and the claims are judged on set A, the paper's set, when it is there (else on the first set, with
the claim's set named beside it); with both A and C, the appendix's comparisons of the two are judged too.

Verdicts:
  - an ordering claim ("a > b"): z = (a - b) / sqrt(SE_a^2 + SE_b^2); "agrees" when z >= 2, "same direction, z < 2"
    when 0 < z < 2, "opposite direction" when -2 < z <= 0, "disagrees" when z <= -2. When an SE is not estimable
    (capsflow analyze gives a lower bound: the block SE still grows at the longest usable block) the z is an upper
    bound: a claim is then called "agrees" only where it also holds in every 50-strain block of the window, and
    otherwise "same direction, not established";
  - a closeness claim ("a ~ b"): "agrees" when |z| < 2, else "disagrees";
  - a position claim ("at y ~ 0.2H"): "agrees" when the feature lies within the tolerance named in the row (the bins
    are 0.02H wide);
  - a claim that needs another set, another X_f or isolated runs: "not testable here", with the reason.

Errors. Each d-bar SE is checked against the block SE of the longest blocks (25 x 2^k strain, at least 5 in the
window) recomputed from d-bar(t): "too small" when that exceeds it by more than twice its own uncertainty.
d-bar's SE is the one `capsflow analyze` exports (summary.json: block SE at the plateau of block length, or
from the integrated autocorrelation time, or across realizations; null with a lower bound when not estimable). For
an analysis written before those fields existed the tool recomputes the same estimators from the analysis's own
d-bar(t) (identical for groups of one run) and says so. f_AB's SE must come from independent crossings (a jackknife
over capsules and over sub-windows at least the horizon long); an older analysis's f_AB SE (a jackknife over
sub-windows shorter than the horizon) is not used. A mean of n profile bins carries the mean of the bins' SEs, the
largest its SE can be for any correlation between the bins (Cauchy-Schwarz).

v-bar_p, the mean wall-normal velocity binned by position, vanishes in a stationary state (no net flux of capsules
across any plane y = const), so KG's three regimes of v-bar_p (claims 26-29) are not judged; the profile is used as
a stationarity check instead (its capsule-weighted mean against the drift of d-bar).

    PYTHONPATH=python tools/reproduction_claims.py docs/figures/reproduction/steady          # print the tables
    PYTHONPATH=python tools/reproduction_claims.py SET_A_DIR SET_C_DIR                          # two sets, one page
    PYTHONPATH=python tools/reproduction_claims.py DIR --check docs/reproduction.md
    PYTHONPATH=python tools/reproduction_claims.py SET_A_DIR SET_C_DIR --write docs/reproduction.md

--isolated FILE names the isolated migration velocities V^S (default: docs/figures/migration_isolated.txt, the table of
docs/validation.md section 8.1; an analysis with pinned groups uses its own). --check compares the tables with the
text between `<!-- claims:begin -->` and `<!-- claims:end -->` in the document (exit 1 on drift, printing both), so
the numbers of the page cannot drift from the committed analysis. --write puts the tables there instead, and the
`<!-- claims:from DIR... -->` line before them (the directories as given; the page check reads it).
"""
import argparse
import math
import os
import re
import sys

import numpy as np

try:
    import capsflow
except ImportError as e:  # the package lives in python/ of the checkout
    sys.exit("reproduction_claims.py: cannot import the capsflow package (%s): run with PYTHONPATH=python" % e)

BEGIN, END = "<!-- claims:begin -->", "<!-- claims:end -->"
FROM = "<!-- claims:from"  # the line before BEGIN naming the analyses (tests/python/test_reproduction_claims.py)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ISOLATED = os.path.join(ROOT, "docs", "figures", "migration_isolated.txt")
# Claim 3 is stated for X_f = 0.2: d-bar per 100-strain block of that run (tools/dbar_blocks.py --csv).
XF02_BLOCKS = os.path.join(ROOT, "docs", "figures", "reproduction", "set_a_xf0.2_dbar_blocks.csv")
BLOCK = 50.0      # strain: the blocks of the d-bar(t) tables, the plateau and the block-sign check
BAND = 0.005      # d-bar/(H/2): the fixed plateau band (a third of one capsule's layer exchange at N = 30)
EPS = 1e-9
# Regions of the profile claims (bin centres, y/H): the near-wall layer holds the wall peaks of n-hat (0.21-0.23H; the
# cell-free layer y < a ~ 0.1H holds no centroid), "between the peaks" lies between it and the centre peak's rise.
WALL = (0.0, 0.25)
WALL_LAYER = (0.19, 0.25)
BETWEEN = (0.27, 0.39)
CENTRE = (0.41, 0.5)


def fmt(v, se=None, digits=4):
    if v is None or not math.isfinite(v):
        return "-"
    if se is None or not math.isfinite(se):
        return "%.*f" % (digits, v)
    return "%.*f ± %.*f" % (digits, v, digits, se)


def finite(*v):
    return all(x is not None and math.isfinite(x) for x in v)


def prof(g, quantity, species=None):
    """g's profile, or one undefined in every bin (NaN) when the analysis left it out (e.g. every bin masked)."""
    try:
        return g.profile(quantity, species)
    except KeyError:
        y = g.y_over_H if g.y_over_H is not None else np.full(1, math.nan)
        return capsflow.analysis.Profile(y, np.full(len(y), math.nan), np.full(len(y), math.nan))


def order(a, sa, b, sb, lower=False, blocks=None):
    """Verdict of the claim a > b. lower: the SEs are lower bounds (not estimable). blocks: (k, n), the number of
    50-strain blocks of the window in which a > b."""
    if not finite(a, b):
        return "not judged (undefined: masked bins)"
    if blocks is not None and blocks[1] == 0:  # a window shorter than one block
        blocks = None
    den = math.hypot(sa, sb)
    if not (math.isfinite(den) and den > 0):
        return "%s, no standard error" % ("same direction" if a > b else "opposite direction")
    z = (a - b) / den
    if not lower:
        if z >= 2:
            return "agrees (z = %.1f)" % z
        if z > 0:
            return "same direction, z = %.1f < 2" % z
        if z > -2:
            return "opposite direction, z = %.1f" % z
        return "**disagrees** (z = %.1f)" % z
    blk = "" if blocks is None else "; in %d of %d %g-strain blocks" % (blocks[0], blocks[1], BLOCK)
    if z >= 2:
        if blocks is not None and blocks[0] == blocks[1] and blocks[1] > 1:
            return "agrees in every %g-strain block of the window (%d/%d); z ≤ %.1f (SE not estimable)" % (
                BLOCK, blocks[0], blocks[1], z)
        return "same direction, not established (z ≤ %.1f, SE not estimable%s)" % (z, blk)
    if z > 0:
        return "same direction, z ≤ %.1f < 2 (SE not estimable)" % z
    if z > -2:
        return "opposite direction, |z| ≤ %.1f < 2 (SE not estimable)" % -z
    if blocks is not None and blocks[0] == 0 and blocks[1] > 1:
        return "**disagrees** in every %g-strain block of the window (0/%d); |z| ≤ %.1f (SE not estimable)" % (
            BLOCK, blocks[1], -z)
    return "opposite direction, not established (|z| ≤ %.1f, SE not estimable%s)" % (-z, blk)


def close(a, sa, b, sb):
    if not finite(a, b):
        return "not judged (undefined: masked bins)"
    den = math.hypot(sa, sb)
    if not (math.isfinite(den) and den > 0):
        return "no standard error: not judged"
    z = (a - b) / den
    return ("agrees (|z| = %.1f < 2)" if abs(z) < 2 else "**disagrees** (|z| = %.1f)") % abs(z)


def position(found, target, tol):
    if found is None or not math.isfinite(found):
        return "not found"
    return ("agrees (within %.2fH)" if abs(found - target) <= tol else "**disagrees** (off by more than %.2fH)") % tol


def early(g, sp):
    """(d-bar at t = 0, mean over [10, 30]) of a species; NaN where the run has no records there."""
    t, d = g.dbar_t.time, getattr(g.dbar_t, sp)
    m = (t >= 10) & (t <= 30) & np.isfinite(d)
    return float(d[0]), float(d[m].mean()) if m.any() else math.nan


def in_region(y, lo, hi):
    return (y >= lo - EPS) & (y <= hi + EPS)


def region_mean(prof, lo, hi):
    """Mean of a profile over the bins with centres in [lo, hi] (y/H), and the mean of their SEs: the largest the
    SE of the mean can be for any correlation between the bins. NaN bins skipped."""
    m = in_region(prof.y_over_H, lo, hi) & np.isfinite(prof.value)
    if not m.any():
        return math.nan, math.nan
    se = prof.se[m]
    return float(np.mean(prof.value[m])), float(np.mean(se)) if np.isfinite(se).all() else math.nan


def argext(prof, lo, hi, largest=True):
    """y/H and value of the largest (or smallest) defined bin with centre in [lo, hi]."""
    m = in_region(prof.y_over_H, lo, hi) & np.isfinite(prof.value)
    if not m.any():
        return math.nan, math.nan
    idx = np.flatnonzero(m)
    k = idx[np.argmax(prof.value[m])] if largest else idx[np.argmin(prof.value[m])]
    return float(prof.y_over_H[k]), float(prof.value[k])


def crossing(prof, level, lo, hi):
    """The heights y/H in [lo, hi] where the profile crosses `level` (linear between bin centres)."""
    y, v = prof.y_over_H, prof.value
    out = []
    for k in range(len(y)):
        if not (lo <= y[k] <= hi and np.isfinite(v[k])):
            continue
        if v[k] == level:  # on a bin centre
            out.append(float(y[k]))
            continue
        if k + 1 < len(y) and y[k + 1] <= hi and np.isfinite(v[k + 1]) and (v[k] - level) * (v[k + 1] - level) < 0:
            out.append(float(y[k] + (level - v[k]) * (y[k + 1] - y[k]) / (v[k + 1] - v[k])))
    return out


def interpolate(prof, y0):
    """Value and SE of a profile at y0/H, linear between the bin centres around it (SE: the larger of the two)."""
    y, v, s = prof.y_over_H, prof.value, prof.se
    k = int(np.searchsorted(y, y0))
    if k == 0 or k >= len(y):
        return math.nan, math.nan
    f = (y0 - y[k - 1]) / (y[k] - y[k - 1])
    return float(v[k - 1] + f * (v[k] - v[k - 1])), float(max(s[k - 1], s[k]))


def tail_ratio(pdf, side):
    """Probability beyond 2 standard deviations on one side of the mean, over the Gaussian's 0.02275."""
    c, d = pdf.centres, pdf.density
    w = np.diff(pdf.edges)
    p = d * w
    p = p / p.sum()
    m = float(np.sum(p * c))
    s = math.sqrt(float(np.sum(p * (c - m) ** 2)))
    beyond = c > m + 2 * s if side > 0 else c < m - 2 * s
    return float(p[beyond].sum()) / 0.022750131948179195


# ---------------------------------------------------------------------------------------------------------------
# Errors of a time average: the estimators of `capsflow analyze` (src/host/analysis/analysis_errors.cpp), for an
# analysis written before it exported them.

def block_sweep(x, min_blocks=16):
    """(SE or NaN, lower bound or NaN, reason): the block SE at the Lee-Needs-Drummond optimal block when no larger
    usable block exceeds it by more than 3 combined uncertainties; else not estimable, bounded below."""
    n_all = len(x)
    if n_all < max(2, min_blocks):
        return math.nan, math.nan, "fewer than %d records" % max(2, min_blocks)
    levels, b = [], 1
    while n_all // b >= 2:
        n = n_all // b
        m = x[:n * b].reshape(n, b).mean(axis=1)
        se = float(np.std(m, ddof=1) / math.sqrt(n))
        levels.append((b, n, se, se / math.sqrt(2.0 * (n - 1))))
        b *= 2
    usable = sum(1 for L in levels if L[1] >= min_blocks)
    se1 = levels[0][2]
    if se1 == 0:
        return 0.0, math.nan, "constant series"
    largest = max(L[2] for L in levels[:usable])
    opt = next((k for k in range(usable) if levels[k][0] ** 3 > 2.0 * n_all * (levels[k][2] / se1) ** 4), None)
    last = levels[usable - 1]
    if opt is None:
        return math.nan, largest, ("the block SE still grows at the largest usable block (%d records, %d blocks)"
                                   % (last[0], last[1]))
    for j in range(opt + 1, usable):
        if levels[j][2] - levels[opt][2] > 3.0 * math.hypot(levels[j][3], levels[opt][3]):
            return math.nan, largest, "the block SE grows past the optimal block"
    return levels[opt][2], math.nan, "block SE at the plateau (%d records per block)" % levels[opt][0]


def tau_se(x, c=6.0, min_length=100.0):
    """SE from the integrated autocorrelation time (Sokal's window), or NaN when not estimable."""
    n = len(x)
    d = x - x.mean()
    c0 = float(np.dot(d, d)) / n
    if n < 4 or c0 == 0:
        return (0.0 if c0 == 0 else math.nan), 0.5
    f = np.fft.rfft(d, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n] / n / c0
    tau = 0.5
    for M in range(1, n // 2):
        tau += acf[M]
        if M >= c * tau:
            if tau > 0 and n >= min_length * tau:
                return math.sqrt(2.0 * tau * c0 / n), tau
            return math.nan, tau
    return math.nan, tau


class DStat:
    """Steady d-bar of one group and species with its SE (NaN when not estimable, then `lower` bounds it), the SE's
    rule, the halves test of docs/analysis.md ("Steady-state window") and where these come from."""

    def __init__(self, g, sp, summ):
        est = g.dbar[sp]
        self.value, self.se, self.lower = est.value, math.nan, math.nan
        js = summ.get(g.id, {}).get("species", {}).get(sp, {}).get("dbar") or {}
        self.exported = "halves" in js
        if self.exported:
            self.se = math.nan if js.get("se") is None else float(js["se"])
            lb = js.get("se_lower_bound")
            self.lower = math.nan if lb is None else float(lb)
            self.rule = (js.get("se_reason") or js.get("se_rule", "")).replace("SE not estimable: ", "not estimable: ")
            h = js["halves"]
            self.first, self.first_se = (h["first"].get(k) for k in ("value", "se"))
            self.second, self.second_se = (h["second"].get(k) for k in ("value", "se"))
            self.z = math.nan if h.get("z") is None else float(h["z"])
            self.verdict = h.get("verdict", "")
            self.source = "capsflow analyze"
            return
        # An analysis written before issue 35: the same estimators on its d-bar(t) over the window.
        self.source = "recomputed here from d-bar(t)"
        t, d = g.dbar_t.time, getattr(g.dbar_t, sp)
        w = (t >= g.t0 - EPS) & (t <= g.t1 + EPS) & np.isfinite(d)
        x = d[w]
        bse, blb, why = block_sweep(x)
        tse, _ = tau_se(x)
        if math.isfinite(bse):
            self.se = max(bse, tse) if math.isfinite(tse) else bse
            self.rule = "block SE at the plateau" if self.se == bse else "autocorrelation-time SE"
        else:
            old = est.se if math.isfinite(est.se) else 0.0
            self.lower = max(blb, tse if math.isfinite(tse) else 0.0, old)
            self.rule = "not estimable: %s" % why
        blk = np.minimum(np.floor(10.0 * (t[w] - g.t0) / (g.t1 - g.t0)), 9).astype(int)
        means = np.array([x[blk == b].mean() if (blk == b).any() else math.nan for b in range(10)])
        a, b = means[:5], means[5:]
        self.first, self.first_se = float(a.mean()), float(a.std(ddof=1) / math.sqrt(5))
        self.second, self.second_se = float(b.mean()), float(b.std(ddof=1) / math.sqrt(5))
        den = math.hypot(self.first_se, self.second_se)
        self.z = (self.second - self.first) / den if den > 0 else 0.0
        self.verdict = "steady" if abs(self.second - self.first) <= 2 * den else "not steady"

    @property
    def lower_bound(self):
        return not math.isfinite(self.se)

    @property
    def err(self):
        """The SE, or its lower bound when not estimable."""
        return self.se if math.isfinite(self.se) else self.lower

    def text(self):
        if not math.isfinite(self.value):
            return "-"
        if math.isfinite(self.se):
            return fmt(self.value, self.se)
        return "%.4f (SE ≥ %.4f)" % (self.value, self.lower) if math.isfinite(self.lower) else "%.4f" % self.value


def window_blocks(g, sp):
    """Means of d-bar(t) over the BLOCK-strain blocks of the window [t0, t1) (complete blocks only)."""
    t, d = g.dbar_t.time, getattr(g.dbar_t, sp)
    out = []
    lo = g.t0
    while lo + BLOCK <= g.t1 + EPS:
        m = (t >= lo) & (t < lo + BLOCK) & np.isfinite(d)
        out.append(float(d[m].mean()) if m.any() else math.nan)
        lo += BLOCK
    return np.array(out)


def long_block(g, sp, least=5):
    """The block SE of d-bar over the window at the longest block length 25 x 2^k strain that still gives `least`
    blocks: (SE, its uncertainty SE / sqrt(2 (n - 1)), length, n); a check of the SE against long blocks."""
    t, d = g.dbar_t.time, getattr(g.dbar_t, sp)
    span = g.t1 - g.t0
    L = 25.0
    if span / L < least:
        return math.nan, math.nan, math.nan, 0
    while span / (2 * L) >= least - EPS:
        L *= 2
    n = int(span / L + EPS)
    m = []
    for j in range(n):
        w = (t >= g.t0 + j * L) & (t < g.t0 + (j + 1) * L) & np.isfinite(d)
        m.append(d[w].mean() if w.any() else math.nan)
    m = np.array(m)
    se = float(np.std(m, ddof=1) / math.sqrt(n))
    return se, se / math.sqrt(2.0 * (n - 1)), L, n


def block_sign(a_blocks, b_blocks):
    """(k, n): blocks in which a > b."""
    n = min(len(a_blocks), len(b_blocks))
    return int(np.sum(a_blocks[:n] > b_blocks[:n])), n


def plateau(t, d, t1, block=BLOCK, least=3):
    """Means of d over consecutive `block`-strain blocks from 0 up to the window's end t1, and the plateau time: the
    start of the first block from which every block mean up to t1 lies within the fixed band ±BAND of the mean of
    those blocks, counting only starts with at least `least` blocks (fewer: not established). The band does not
    depend on the data, so a drift cannot widen it."""
    ok = np.isfinite(d)
    t, d = t[ok], d[ok]
    means = []
    lo = 0.0
    while lo + block <= t1 + EPS:
        m = (t >= lo) & (t < lo + block)
        if m.any():
            means.append((lo, float(d[m].mean())))
        lo += block
    tp = math.nan
    for i, (lo, _) in enumerate(means):
        vals = np.array([v for _, v in means[i:]])
        if len(vals) >= least and np.all(np.abs(vals - vals.mean()) <= BAND):
            tp = lo
            break
    return means, tp


def drift(g, sp):
    """Least-squares slope of d-bar(t)/(H/2) over the window, per strain."""
    t, d = g.dbar_t.time, getattr(g.dbar_t, sp)
    w = (t >= g.t0) & (t <= g.t1) & np.isfinite(d)
    return float(np.polyfit(t[w], d[w], 1)[0]) if w.sum() > 2 else math.nan


def set_name(g):
    """KG's set of a group (Table I), from its box, count and capillary numbers; '?' when none fits."""
    m = re.search(r"Np=(\d+)", g.key)
    np_ = int(m.group(1)) if m else 0
    cs, cf = round(g.ca_stiff, 6), round(g.ca_floppy, 6)
    if abs(g.H - 6.6667) < 0.01 and (cs, cf) == (0.2, 0.5):
        return "B"
    if abs(g.H - 10.155) < 0.01 and abs(g.Lx - 10.155) < 0.01 and abs(g.Lz - 10.155) < 0.01:
        if (cs, cf) == (0.2, 0.5):
            return {50: "A", 30: "C"}.get(np_, "?")
        if (cs, cf) == (0.1, 0.6) and np_ == 30:
            return "D"
    return "?"


SET_TEXT = {"A": "set A (cube 10.155a, N_p 50, phi 0.2)", "B": "set B (H 6.667a, N_p 50, phi 0.2)",
            "C": "set C (cube 10.155a, N_p 30, phi 0.12)", "D": "set D (cube 10.155a, N_p 30, phi 0.12, Ca 0.1/0.6)"}


def load_isolated(analyses, path):
    """{Ca: (y/H array, V^S array)} and where they come from: the pinned groups of an analysis, else the table of
    docs/validation.md 8.1 (its header names the box, H = Lx = Lz)."""
    for an in analyses:
        if an.isolated:
            return {ca: (iso.y_over_H, iso.V_S) for ca, iso in an.isolated.items()}, None, "the analysis's pinned runs"
    if not path or not os.path.isfile(path):
        return {}, None, None
    rows, box = {}, None
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if line.startswith("#"):
                m = re.search(r"H = Lx = Lz = ([0-9.]+)", line)
                if m:
                    box = float(m.group(1))
                continue
            f = line.split()
            if len(f) >= 3:
                rows.setdefault(float(f[0]), []).append((float(f[1]), float(f[2])))
    out = {ca: (np.array([r[0] for r in v]), np.array([r[1] for r in v])) for ca, v in rows.items()}
    return out, box, os.path.relpath(path, ROOT) if path.startswith(ROOT) else path


class Table:
    def __init__(self):
        self.rows = []

    def add(self, claim, where, ours, verdict):
        self.rows.append((claim, where, ours, verdict))

    def markdown(self):
        out = ["| # | claim (line of the paper's source) | set | capsflow | verdict |", "|---|---|---|---|---|"]
        for i, (c, s, o, v) in enumerate(self.rows, 1):
            out.append("| %d | %s | %s | %s | %s |" % (i, c, s, o, v))
        return "\n".join(out)


def set_tables(name, gs, summ, out):
    """The steady values, the steadiness test and d-bar(t) in blocks of one set; returns {X_f: plateau time}."""
    by = {g.x_f: g for g in gs}
    need = [0.0, 0.5, 1.0]
    out.append("**%s**, window [%g, %g]%s.\n" % (SET_TEXT.get(name, "set " + name), by[0.0].t0, by[0.0].t1,
                                                 "" if len({(g.t0, g.t1) for g in gs}) == 1 else " (X_f = 0)"))
    out.append("Steady values over the window (d-bar/(H/2), enrichment E, f_AB with horizon 100 and region A within "
               "0.3H of a wall; ± one SE, \"SE ≥\" where it is not estimable):\n")
    out.append("| X_f | window | d-bar stiff | d-bar floppy | d-bar all | E_s | E_f | f_AB stiff | f_AB floppy | "
               "contacts per strain |")
    out.append("|---|---|---|---|---|---|---|---|---|---|")
    for x in need:
        g = by[x]
        c = summ.get(g.id, {}).get("contact", {}).get("events_per_strain")
        cells = [DStat(g, sp, summ).text() if math.isfinite(g.dbar[sp].value) else "-"
                 for sp in ("stiff", "floppy", "all")]
        fab = [fab_text(g, sp, summ) for sp in ("stiff", "floppy")]
        out.append("| %g | [%g, %g] | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            x, g.t0, g.t1, cells[0], cells[1], cells[2], fmt(g.E["stiff"].value, g.E["stiff"].se, 3),
            fmt(g.E["floppy"].value, g.E["floppy"].se, 3), fab[0], fab[1], "-" if c is None else "%.1f" % c))
    sources = {DStat(by[x], sp, summ).source for x in need for sp in ("stiff", "floppy", "all")
               if math.isfinite(by[x].dbar[sp].value)}
    if "capsflow analyze" not in sources:
        out.append("\n(This analysis predates the exported SE estimators and steadiness test (issue 35): both are "
                   "recomputed here from its d-bar(t), the same estimators as `capsflow analyze`. Its f_AB errors were "
                   "a jackknife over sub-windows shorter than the 100-strain horizon and are not used.)")
    out.append("\nSteadiness (docs/analysis.md, \"Steady-state window\": the means over the two halves of the window, 5 blocks each, agree "
               "within 2 combined SEs) and the SE of the window mean:\n")
    out.append("| X_f | species | first half | second half | z | verdict | SE of the window mean | check: block SE "
               "at the longest blocks (>= 5) |")
    out.append("|---|---|---|---|---|---|---|---|")
    for x in need:
        for sp in ("stiff", "floppy", "all"):
            g = by[x]
            if not math.isfinite(g.dbar[sp].value) or (sp == "all" and x in (0.0, 1.0)):
                continue
            s = DStat(g, sp, summ)
            se = ("%.4f (%s)" % (s.se, s.rule)) if math.isfinite(s.se) else "not estimable, ≥ %.4f (%s)" % (
                s.lower, s.rule.replace("not estimable: ", ""))
            ls, lu, L, n = long_block(g, sp)
            if n == 0:
                chk = "window shorter than 5 blocks of 25 strain"
            else:
                chk = "%.4f (%g strain, %d blocks)" % (ls, L, n)
                if math.isfinite(s.se):
                    chk += ": the SE is too small" if ls - 2 * lu > s.se else ": consistent"
                elif ls - 2 * lu > s.lower:
                    chk += ": above the lower bound"
            out.append("| %g | %s | %s | %s | %.1f | %s | %s | %s |" % (x, sp, fmt(s.first, s.first_se),
                                                                        fmt(s.second, s.second_se), s.z, s.verdict,
                                                                        se, chk))
    out.append("\nd-bar(t)/(H/2) in %g-strain blocks up to the window's end, the least-squares drift over the window, "
               "and the plateau time: the start of the first block from which every block mean up to the window's "
               "end lies within a fixed band of ±%g around their mean, with at least three blocks (else: not "
               "established):\n" % (BLOCK, BAND))
    rows, plats = [], {}
    for x, sp in ((0.0, "stiff"), (0.5, "all"), (1.0, "floppy")):
        g = by[x]
        means, tp = plateau(g.dbar_t.time, getattr(g.dbar_t, sp), g.t1)
        plats[x] = tp
        rows.append((x, sp, means, tp, drift(g, sp)))
    nblocks = max(len(r[2]) for r in rows)
    out.append("| X_f (species) | " + " | ".join("%d-%d" % (BLOCK * i, BLOCK * i + BLOCK) for i in range(nblocks))
               + " | drift over the window, per 100 strain | plateau from |")
    out.append("|---|" + "---|" * nblocks + "---|---|")
    for x, sp, means, tp, dr in rows:
        cells = ["%.4f" % v for _, v in means] + ["-"] * (nblocks - len(means))
        out.append("| %g (%s) | %s | %+.4f | %s |" % (x, sp, " | ".join(cells), 100 * dr,
                                                      "not established" if not math.isfinite(tp) else "%g" % tp))
    snaps = [(g.snapshot.time, g.t1) for g in gs if g.snapshot is not None]
    if snaps:
        out.append("\nSnapshot (fig. 2): the frame at t = %s, for a window ending at %g%s." % (
            " / ".join("%.1f" % s for s, _ in snaps), snaps[0][1],
            "" if all(abs(s - t1) <= 0.5 * BLOCK for s, t1 in snaps) else
            " (written before issue 35 took the frame nearest the window's end: the frame at the end fell just past it)"))
    out.append("")
    return plats


def fab_text(g, sp, summ):
    e = g.f_AB[sp]
    if not math.isfinite(e.value):
        return "-"
    js = summ.get(g.id, {}).get("species", {}).get(sp, {}).get("f_AB") or {}
    if "se_rule" not in js:
        return "%.3f (no valid SE)" % e.value
    return "%s (%d crossings)" % (fmt(e.value, e.se, 3), int(js.get("crossings") or 0))


def fab_valid(g, sp, summ):
    js = summ.get(g.id, {}).get("species", {}).get(sp, {}).get("f_AB") or {}
    return "se_rule" in js


def claim3_row(path):
    """Claim 3 from the X_f = 0.2 run's 100-strain blocks of d-bar: (capsflow, verdict). The paper averages two
    realizations; one run cannot tell its block-to-block spread from the effect, so the verdict says so."""
    if not os.path.exists(path):
        return "-", "not testable here: stated for X_f = 0.2, two seeds, not run"
    rows = [ln.split(",") for ln in open(path).read().splitlines() if ln and not ln.startswith(("#", "strain"))]
    blk = {int(float(r[0])): (float(r[3]), float(r[4]), float(r[5])) for r in rows}
    end = max(int(float(r[1])) for r in rows)
    late = [v for lo, v in blk.items() if lo >= 800 and lo + 100 <= end]
    if not all(k in blk for k in (500, 600, 700)) or len(late) < 2:
        return "-", "not testable here: the X_f = 0.2 run has not reached strain 1000"
    sd = [float(np.std([v[i] for v in late], ddof=1)) for i in range(3)]
    mean = [float(np.mean([v[i] for v in late])) for i in range(3)]
    ours = ("X_f 0.2, seed 1, 100-strain blocks to %d: stiff %.4f (500-600) → %.4f, %.4f (600-700, 700-800); over "
            "800-%d stiff %.4f (block SD %.4f), all %.4f (block SD %.4f), floppy (10 capsules) %.4f (block SD %.4f)"
            % (end, blk[500][0], blk[600][0], blk[700][0], 800 + 100 * len(late), mean[0], sd[0], mean[2], sd[2],
               mean[1], sd[1]))
    rise = 0.5 * (blk[600][0] + blk[700][0]) - blk[500][0]
    verdict = ("one realization: not decided (the stiff rise after 600, %+.4f, is %.1f block SDs; the paper averages "
               "two seeds)" % (rise, rise / sd[0] if sd[0] > 0 else float("inf")))
    return ours, verdict


def build(paths, isolated_path=ISOLATED):
    analyses = [capsflow.open_analysis(p) for p in paths]
    summ, sets = {}, {}
    for k, an in enumerate(analyses):
        for e in (an.summary or {}).get("groups", []):
            summ[e["id"] if len(analyses) == 1 else (k, e["id"])] = e
        for g in an.suspension_groups():
            if len(analyses) > 1:
                g.id = (k, g.id)
            sets.setdefault(set_name(g), []).append(g)
    for name, gs in sets.items():
        xs = sorted(g.x_f for g in gs)
        if name == "?" or any(x not in xs for x in (0.0, 0.5, 1.0)) or len(xs) != len(set(xs)):
            sys.exit("reproduction_claims.py: %s: expected for each of KG's sets one group at each of X_f = 0, 0.5 and "
                     "1; set %s has X_f = %s" % (", ".join(paths), name, ", ".join("%g" % x for x in xs)))
    if not sets:
        sys.exit("reproduction_claims.py: %s: no suspension groups" % ", ".join(paths))
    out = []
    plats = {}
    for name in sorted(sets):
        plats[name] = set_tables(name, sorted(sets[name], key=lambda g: g.x_f), summ, out)
    main_set = "A" if "A" in sets else sorted(sets)[0]
    by = {g.x_f: g for g in sets[main_set]}
    p0, mx, p1 = by[0.0], by[0.5], by[1.0]
    S = main_set
    A_only = S if S == "A" else "%s (paper: A)" % S  # the paper states the claim for set A only
    T = Table()
    ds = {(x, sp): DStat(by[x], sp, summ) for x in by for sp in ("stiff", "floppy", "all")
          if math.isfinite(by[x].dbar[sp].value)}
    blocks = {(x, sp): window_blocks(by[x], sp) for (x, sp) in ds}

    def dcmp(ka, kb):
        """(text a, text b, verdict of a > b) for two (X_f, species) d-bar values."""
        a, b = ds[ka], ds[kb]
        return a.text(), b.text(), order(a.value, a.err, b.value, b.err, a.lower_bound or b.lower_bound,
                                         block_sign(blocks[ka], blocks[kb]))

    # the paper's numbers: steadiness
    tps = [plats[S][x] for x in (0.0, 0.5, 1.0)]
    halves = [(x, sp, ds[(x, sp)]) for x, sp in ((0.0, "stiff"), (0.5, "stiff"), (0.5, "floppy"), (0.5, "all"),
                                                  (1.0, "floppy"))]
    failing = ["X_f %g %s (z = %.1f)" % (x, sp, s.z) for x, sp, s in halves if s.verdict != "steady"]
    reached = all(math.isfinite(v) for v in tps)
    T.add("d-bar reaches an apparent steady state in about 500 strain (473-474)", A_only,
          "halves test: %s; plateau from %s (X_f = 0 / 0.5 / 1)" % (
              " / ".join("%s %s" % (("%g %s" % (x, sp)), s.verdict) for x, sp, s in halves),
              " / ".join("-" if not math.isfinite(v) else "%g" % v for v in tps)),
          ("agrees: steady by %g" % max(tps)) if reached and not failing and max(tps) <= 500 else
          "not established: %s" % ("; ".join(
              ([("not steady by the halves test: " + ", ".join(failing))] if failing else [])
              + ([] if reached else ["no plateau within the fixed band for X_f = %s" % ", ".join(
                  "%g" % x for x, v in zip((0, 0.5, 1), tps) if not math.isfinite(v))]))
              or "plateau after 500"))
    e = [early(g, sp) for g, sp in ((p0, "stiff"), (mx, "all"), (p1, "floppy"))]
    T.add("d-bar decreases initially in all cases (467-468)", S,
          " / ".join("%.4f → %.4f" % v for v in e) + " (t = 0 → mean over [10, 30])",
          ("agrees" if all(b < a for a, b in e) else "**disagrees**") if all(finite(*v) for v in e)
          else "not judged: the runs do not reach strain 30")
    T.add("t ≈ 600: stiff displaced toward the walls after ~600; d-bar_all weakly evolving after 800 (486-491)", "A",
          *claim3_row(XF02_BLOCKS))

    # the paper's qualitative claims: d-bar orderings
    ta, tb, v = dcmp((0.0, "stiff"), (1.0, "floppy"))
    T.add("pure stiff d-bar slightly higher than pure floppy, \"not large\" (474-476); at any phi, stiff above floppy "
          "(1250-1251)", S, "%s vs %s" % (ta, tb), v)
    ta, tb, v = dcmp((0.5, "stiff"), (0.5, "floppy"))
    T.add("in the mixture the stiff sit farther from the centreline than the floppy (segregation; 1250-1251, 599-601)",
          S, "%s vs %s (X_f = 0.5)" % (ta, tb), v)
    ta, tb, v = dcmp((0.5, "stiff"), (0.0, "stiff"))
    T.add("d-bar of the stiff increases with X_f (501-503)", S, "%s (0.5) vs %s (0)" % (ta, tb), v)
    ta, tb, v = dcmp((1.0, "floppy"), (0.5, "floppy"))
    T.add("d-bar of the floppy increases with X_f (501-503)", S, "%s (1) vs %s (0.5)" % (ta, tb), v)
    t05a, t05b, v1 = dcmp((0.0, "all"), (0.5, "all"))
    _, t1b, v2 = dcmp((0.5, "all"), (1.0, "all"))
    T.add("d-bar of the whole suspension decreases with X_f (501-503)", S,
          "%s / %s / %s (X_f = 0 / 0.5 / 1)" % (t05a, t05b, t1b), "0 → 0.5: %s; 0.5 → 1: %s" % (v1, v2))
    s5, s0, f1, f5 = ds[(0.5, "stiff")], ds[(0.0, "stiff")], ds[(1.0, "floppy")], ds[(0.5, "floppy")]
    dsv, dss = s5.value - s0.value, math.hypot(s5.err, s0.err)
    dfv, dfs = f1.value - f5.value, math.hypot(f1.err, f5.err)
    lower = any(s.lower_bound for s in (s5, s0, f1, f5))
    n = min(len(blocks[k]) for k in ((0.5, "stiff"), (0.0, "stiff"), (1.0, "floppy"), (0.5, "floppy")))
    bs = (blocks[(0.5, "stiff")][:n] - blocks[(0.0, "stiff")][:n]) - (blocks[(1.0, "floppy")][:n]
                                                                         - blocks[(0.5, "floppy")][:n])
    T.add("the stiff's d-bar rises faster with X_f than the floppy's falls with decreasing X_f (509-511)", S,
          "Δ stiff (0 → 0.5) %s vs Δ floppy (0.5 → 1) %s" % (
              fmt(dsv, dss) if not lower else "%.4f (SE ≥ %.4f)" % (dsv, dss),
              fmt(dfv, dfs) if not lower else "%.4f (SE ≥ %.4f)" % (dfv, dfs)),
          order(dsv, dss, dfv, dfs, lower, (int(np.sum(bs > 0)), n)))

    # n-hat and phi-hat
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        nh = prof(g, "n_hat", sp)
        yw, vw = argext(nh, 0.0, 0.3)
        ym, vm = argext(nh, 0.2, 0.45, largest=False)
        yc, vc = argext(nh, 0.35, 0.5)
        T.add("n-hat of pure %s: a sharp peak near the wall and a broad peak near the centreline (541-542)" % sp,
              A_only, "wall peak %.2f at y/H = %.2f, minimum %.2f at %.2f, centre peak %.2f at %.2f"
              % (vw, yw, vm, ym, vc, yc),
              "agrees" if vw > vm and vc > vm and yw < ym < yc else "**disagrees**")
    ns, nf = prof(p0, "n_hat", "stiff"), prof(p1, "n_hat", "floppy")
    yws, ywf = argext(ns, 0.0, 0.3)[0], argext(nf, 0.0, 0.3)[0]
    k19 = int(np.argmin(np.abs(ns.y_over_H - 0.19)))
    a, sa, b, sb = ns.value[k19], ns.se[k19], nf.value[k19], nf.se[k19]
    T.add("the wall peak of n-hat is closer to the wall for the stiff than for the floppy (545-547)", A_only,
          "argmax y/H = %.2f (stiff) vs %.2f (floppy); leading edge n-hat(0.19H) %s vs %s" % (
              yws, ywf, fmt(a, sa, 2), fmt(b, sb, 2)),
          "argmax: %s; leading edge: %s" % ("closer for the stiff" if yws < ywf else
                                             ("same bin" if yws == ywf else "closer for the floppy"),
                                             order(a, sa, b, sb)))
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        yn = argext(prof(g, "n_hat", sp), 0.0, 0.3)[0]
        yp = argext(prof(g, "phi_hat", sp), 0.0, 0.3)[0]
        T.add("y/H = 0.2 is about the near-wall peak of n-hat and phi-hat (658-659), pure %s" % sp, S,
              "n-hat peak at %.2f, phi-hat peak at %.2f" % (yn, yp),
              "n-hat: %s; phi-hat: %s" % (position(yn, 0.2, 0.05), position(yp, 0.2, 0.05)))
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        ph = prof(g, "phi_hat", sp)
        v, s = float(ph.value[-1]), float(ph.se[-1])
        ym = argext(ph, 0.2, 0.45, largest=False)[0]
        T.add("phi-hat(0.5H) ≈ 2 for pure set A (558-560); the minimum of phi-hat near 0.3H sets region A (1037-1038), "
              "pure %s" % sp, A_only, "phi-hat(%.2fH) = %s; minimum at y/H = %.2f" % (ph.y_over_H[-1], fmt(v, s, 2), ym),
              ("phi-hat(0.5H) ≈ 2: %s" % close(v, s, 2.0, 0.0) if S == "A" else
               "phi-hat(0.5H): not testable here (set A's value; set %s has phi 0.12)" % S)
              + "; minimum: %s" % position(ym, 0.3, 0.05))
    # Profiles against X_f, n-hat and phi-hat side by side: (claim, species, region, relation) where the relation
    # "more" claims mixture > pure, "less" mixture < pure, "same" mixture ~ pure.
    for claim, sp, (lo, hi), rel in (
            ("with increasing X_f the stiff's concentration rises near the walls (566-570)", "stiff", WALL, "more"),
            ("at higher X_f the stiff are slightly depleted around the centreline (566-570)", "stiff", CENTRE, "less"),
            ("with decreasing X_f the floppy are depleted near the walls (573-576)", "floppy", WALL_LAYER, "less"),
            ("... and accumulate between the two peaks (573-576)", "floppy", BETWEEN, "more"),
            ("... with no significant change near the centreline (573-576)", "floppy", CENTRE, "same")):
        pure = p0 if sp == "stiff" else p1
        texts, verdicts = [], []
        for q, label in (("n_hat", "n-hat"), ("phi_hat", "phi-hat")):
            a, sa = region_mean(prof(mx, q, sp), lo, hi)
            b, sb = region_mean(prof(pure, q, sp), lo, hi)
            texts.append("%s %s (0.5) vs %s (%s)" % (label, fmt(a, sa, 3), fmt(b, sb, 3), "0" if sp == "stiff" else "1"))
            verdicts.append("%s: %s" % (label, {"more": lambda: order(a, sa, b, sb), "less": lambda: order(b, sb, a, sa),
                                                 "same": lambda: close(a, sa, b, sb)}[rel]()))
        region = ("y ≤ %.2fH" % hi) if lo == 0 else ("y ≥ %.2fH" % lo if hi >= 0.5 else "%.2f-%.2fH" % (lo, hi))
        T.add(claim, A_only, "mean over %s: %s" % (region, "; ".join(texts)), "; ".join(verdicts))

    # X_f-hat and E
    xh = prof(mx, "xf_hat")
    a, sa = region_mean(xh, *CENTRE)
    b, sb = region_mean(xh, 0.0, 0.2)
    T.add("floppy enriched near the centreline, stiff near the walls (599-601)", S,
          "mean X_f-hat over y ≥ 0.41H %s, over y ≤ 0.2H %s" % (fmt(a, sa, 3), fmt(b, sb, 3)),
          "centre > 1: %s; walls < 1: %s" % (order(a, sa, 1.0, 0.0), order(1.0, 0.0, b, sb)))
    cr = crossing(xh, 1.0, 0.1, 0.45)
    T.add("X_f-hat = 1 at y ≈ H/4 (604-605)", A_only,
          "crossings at y/H = %s" % (", ".join("%.3f" % c for c in cr) or "none"),
          (position(min(cr, key=lambda c: abs(c - 0.25)), 0.25, 0.05)
           + ("" if len(cr) == 1 else "; %d crossings (noise)" % len(cr))) if cr else "no crossing")
    es, ef = mx.E["stiff"], mx.E["floppy"]
    T.add("E ≥ 1 by definition (613)", S, "E_s %s, E_f %s" % (fmt(es.value, es.se, 3), fmt(ef.value, ef.se, 3)),
          "agrees (a check of the construction)" if es.value >= 1 and ef.value >= 1
          else "**disagrees** (an analysis error)")
    T.add("enrichment of a species grows as it becomes more dilute, faster for the stiff (616-618)", A_only, "-",
          "not testable here: needs two or more mixture fractions (one: X_f = 0.5)")

    # v-bar_p: a stationarity check, not a claim
    vb_rows = []
    for g, sp, label in ((p0, "stiff", "0"), (mx, "stiff", "0.5 S"), (mx, "floppy", "0.5 F"), (p1, "floppy", "1")):
        try:
            v, nh = prof(g, "v_bar", sp), prof(g, "n_hat", sp)
        except KeyError:
            continue
        m = np.isfinite(v.value) & np.isfinite(v.se) & np.isfinite(nh.value)
        w = nh.value[m]
        if not w.sum() > 0:
            vb_rows.append("%s: v-bar_p masked in every bin" % label)
            continue
        mean = float(np.sum(w * v.value[m]) / np.sum(w))
        bound = float(np.sum(w * v.se[m]) / np.sum(w))
        flux = -drift(g, sp) * g.H / 2.0
        vb_rows.append("%s: %+.1e ± %.0e vs %+.1e" % (label, mean, bound, flux))
    T.add("v-bar_p: three regimes (<0.2H falling, 0.2-0.3H flat, 0.3-0.5H linear) (655-664); the stiff's reduced by "
          "up to ~50 % with X_f, the floppy's a weak function of X_f (683-698)", A_only,
          "-", "not judged: v-bar_p is the mean of dy_c/dt binned by y, which vanishes in a stationary state (no net "
          "flux of capsules across a plane y = const); KG's profile cannot be matched with this definition. Used as "
          "a stationarity check (next row)")
    T.add("stationarity check (not a claim): capsule-weighted mean of v-bar_p (n-hat weights; ± the weighted mean of "
          "the bin SEs) against the flux the drift of d-bar implies, -d(d-bar H/2)/dt [gammadot a]", S,
          "; ".join(vb_rows), "both vanish in a steady state; their sizes say how far from one the window is")
    iso, box, src = load_isolated(analyses, isolated_path)
    if iso and (box is None or abs(box - p0.H) < 0.01 and abs(box - p0.Lx) < 0.01 and abs(box - p0.Lz) < 0.01):
        parts, exceed, lower_at_wall = [], [], []
        for g, sp, ca in ((p0, "stiff", p0.ca_stiff), (p1, "floppy", p1.ca_floppy)):
            key = next((c for c in iso if abs(c - ca) < 1e-9), None)
            if key is None:
                continue
            ys, vs = iso[key]
            v = prof(g, "v_bar", sp)
            cells = []
            for y0, V in zip(ys, vs):
                if y0 < 0.2 - EPS or y0 > 0.45 + EPS:
                    continue
                a, sa = interpolate(v, y0)
                if not finite(a, sa):
                    continue
                cells.append("%.2fH %.1e vs %+.1e ± %.0e" % (y0, V, a, sa))
                if y0 >= 0.3 - EPS and a - V >= 2 * sa:
                    exceed.append("%s %.2fH" % (sp, y0))
                if y0 <= 0.2 + EPS:
                    lower_at_wall.append((V - a) >= 2 * sa)
            parts.append("%s (Ca %g): %s" % (sp, ca, "; ".join(cells)))
        T.add("the suspension's v-bar_p can exceed the isolated capsule's V^S near the centreline, and is much lower "
              "near the walls (655-657, 672-674)", S,
              "V^S (isolated, %s) vs v-bar_p of the pure suspension: %s" % (src, " | ".join(parts)),
              "exceeds: %s; lower at 0.2H: %s" % (
                  ("yes at " + ", ".join(exceed)) if exceed else
                  "not shown (v-bar_p within 2 SE of or below V^S at every height ≥ 0.3H; in a stationary state "
                  "v-bar_p ~ 0 < V^S)",
                  ("agrees" if all(lower_at_wall) else "not significant") if lower_at_wall else "no bin at 0.2H"))
    else:
        T.add("the suspension's v-bar_p can exceed the isolated capsule's migration velocity (672-674)", S, "-",
              "not judged: no isolated V^S in the box of set %s (%s)" % (S, "none found" if not iso else
                                                                      "the table's box is %g" % box))

    # P(v_p)
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        pd = g.pdfs(sp)
        if 0.2 in pd and 0.5 in pd:
            r2p, r2n = tail_ratio(pd[0.2], +1), tail_ratio(pd[0.2], -1)
            r3p = tail_ratio(pd[0.3], +1) if 0.3 in pd else math.nan
            r5p = tail_ratio(pd[0.5], +1)
            T.add("P(v_p) of pure %s: the positive tail at y = 0.2H is non-Gaussian (closer to exponential), Gaussian "
                  "farther out; negative tails Gaussian (718-722)" % sp, A_only,
                  "mass beyond 2 SD over the Gaussian's: 0.2H positive %.2f, negative %.2f; 0.3H positive %.2f; 0.5H "
                  "positive %.2f (%d samples at 0.2H, correlated)" % (r2p, r2n, r3p, r5p, pd[0.2].samples),
                  "heavier positive tail at 0.2H: %s" % ("agrees" if r2p > 1.3 and r2p > r2n else "**disagrees**"))
    # v'_p
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        vp = prof(g, "v_prime", sp)
        ymin = argext(vp, 0.1, 0.3, largest=False)[0]
        ymax = argext(vp, 0.2, 0.45)[0]
        c, cs = float(vp.value[-1]), float(vp.se[-1])
        vb = prof(g, "v_bar", sp)
        a, sa = region_mean(vp, *CENTRE)
        vb_abs = np.abs(vb.value)
        m = in_region(vb.y_over_H, *CENTRE) & np.isfinite(vb_abs)
        b = float(vb_abs[m].mean()) if m.any() else math.nan
        T.add("v'_p of pure %s: minimum near 0.2H, maximum near 0.3H, finite at 0.5H; larger than the mean near the "
              "centreline (753-770)" % sp, A_only,
              "minimum at %.2f, maximum at %.2f, v'_p(%.2fH) = %s; over y ≥ 0.41H v'_p %s vs |v-bar_p| %.4f"
              % (ymin, ymax, vp.y_over_H[-1], fmt(c, cs), fmt(a, sa), b),
              "min: %s; max: %s; finite: %s; v' > |v-bar|: %s"
              % (position(ymin, 0.2, 0.05), position(ymax, 0.3, 0.05), order(c, cs, 0.0, 0.0).split(" (")[0],
                 "yes" if a > b else "no"))
    # Fluctuations compared over one set of bins, 0.21-0.49H, defined for every profile here.
    lo, hi = 0.21, 0.5
    a, sa = region_mean(prof(p0, "v_prime", "stiff"), lo, hi)
    b, sb = region_mean(prof(p1, "v_prime", "floppy"), lo, hi)
    T.add("stiff capsules fluctuate more than floppy ones, pure (755-756, 778-779)", A_only,
          "mean v'_p over 0.21-0.49H: %s vs %s" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))
    a, sa = region_mean(prof(mx, "v_prime", "stiff"), lo, hi)
    b, sb = region_mean(prof(mx, "v_prime", "floppy"), lo, hi)
    T.add("... and in the mixture (778-779)", A_only, "X_f = 0.5: %s vs %s" % (fmt(a, sa), fmt(b, sb)),
          order(a, sa, b, sb))
    for sp, pure in (("stiff", p0), ("floppy", p1)):
        a, sa = region_mean(prof(mx, "v_prime", sp), lo, hi)
        b, sb = region_mean(prof(pure, "v_prime", sp), lo, hi)
        T.add("fluctuations higher in mixtures than in the pure suspensions, %s (775-777)" % sp, A_only,
              "mean v'_p over 0.21-0.49H: %s (mixture) vs %s (pure)" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))

    # f_AB
    fs0, ff1 = p0.f_AB["stiff"], p1.f_AB["floppy"]
    fs5, ff5 = mx.f_AB["stiff"], mx.f_AB["floppy"]
    cells = [(fs0, p0, "stiff"), (fs5, mx, "stiff"), (ff5, mx, "floppy"), (ff1, p1, "floppy")]
    if not all(math.isfinite(e.value) for e, _, _ in cells):
        why = next(e.reason for e, _, _ in cells if not math.isfinite(e.value))
        T.add("f_AB (1033-1063)", A_only, "-", "not computed: %s" % why)
    elif not all(fab_valid(g, sp, summ) for _, g, sp in cells):
        T.add("f_AB of the two species close in pure suspensions (1061-1063); the stiff's falls with X_f, the "
              "floppy's rises as X_f falls (1042-1054); set A: 0.081 / 0.083, 0.015 at 0.8, 0.141 at 0.2", A_only,
              "%.3f (stiff, X_f = 0), %.3f / %.3f (stiff / floppy, 0.5), %.3f (floppy, 1)"
              % (fs0.value, fs5.value, ff5.value, ff1.value),
              "not judged: this analysis's f_AB SE is a jackknife over sub-windows shorter than the 100-strain "
              "horizon (overlapping replicates), not an error bar; the SE from independent crossings needs the runs "
              "re-analysed")
    else:
        def ft(e, g, sp):
            return fab_text(g, sp, summ)
        T.add("f_AB of the two species very close in their pure suspensions (1061-1063); set A: 0.081 (stiff), "
              "0.083 (floppy)", A_only, "%s (stiff, X_f = 0) vs %s (floppy, X_f = 1)" % (ft(fs0, p0, "stiff"),
                                                                                  ft(ff1, p1, "floppy")),
              close(fs0.value, fs0.se, ff1.value, ff1.se) + ("" if S == "A" else "; set A's values not comparable"))
        T.add("f_AB of the stiff falls as X_f grows (1042-1044: 0.081 → 0.015 at 0.8, set A)", A_only,
              "%s (0) → %s (0.5)" % (ft(fs0, p0, "stiff"), ft(fs5, mx, "stiff")),
              order(fs0.value, fs0.se, fs5.value, fs5.se))
        T.add("f_AB of the floppy rises as X_f falls (1052-1054: 0.083 → 0.141 at 0.2, set A)", A_only,
              "%s (1) → %s (0.5)" % (ft(ff1, p1, "floppy"), ft(ff5, mx, "floppy")),
              order(ff5.value, ff5.se, ff1.value, ff1.se))

    c = [summ.get(g.id, {}).get("contact", {}).get("events_per_strain") for g in (p0, mx, p1)]
    T.add("only a couple of minimum-gap violations per time unit, N_p = 50 (394-395)", S,
          "contact corrections per strain: %s (X_f = 0 / 0.5 / 1)" % " / ".join(
              "-" if v is None else "%.1f" % v for v in c),
          "more here: capsflow counts every correction, each ~1e-4 a (see \"Contact control\")")
    T.add("pair collisions in shear (4.10; Fig. 11-12)", "-", "-",
          "not in this sweep: docs/validation.md (pair collisions)")
    if "A" in sets and "C" in sets:
        bya = {g.x_f: g for g in sets["A"]}
        byc = {g.x_f: g for g in sets["C"]}
        for x, sp in ((0.0, "stiff"), (0.5, "stiff"), (0.5, "floppy"), (1.0, "floppy")):
            a, b = DStat(bya[x], sp, summ), DStat(byc[x], sp, summ)
            T.add("at any X_f the d-bar of a species rises with phi (1260-1261): %s at X_f = %g" % (sp, x), "A vs C",
                  "%s (A, phi 0.2) vs %s (C, 0.12)" % (a.text(), b.text()),
                  order(a.value, a.err, b.value, b.err, a.lower_bound or b.lower_bound,
                        block_sign(window_blocks(bya[x], sp), window_blocks(byc[x], sp))))
        ea, ec = bya[0.5].E, byc[0.5].E
        T.add("maximum E_s higher at phi 0.2, maximum E_f higher at phi 0.12 (1269-1271)", "A vs C",
              "X_f = 0.5 only: E_s %s (A) vs %s (C); E_f %s (A) vs %s (C)" % (
                  fmt(ea["stiff"].value, ea["stiff"].se, 3), fmt(ec["stiff"].value, ec["stiff"].se, 3),
                  fmt(ea["floppy"].value, ea["floppy"].se, 3), fmt(ec["floppy"].value, ec["floppy"].se, 3)),
              "E_s: %s; E_f: %s (one mixture: the maxima over X_f are not resolved)" % (
                  order(ea["stiff"].value, ea["stiff"].se, ec["stiff"].value, ec["stiff"].se),
                  order(ec["floppy"].value, ec["floppy"].se, ea["floppy"].value, ea["floppy"].se)))
        T.add("sets A vs B, C vs D (appendix, 1223-1235, 1280-1295)", "-", "-", "not testable here: sets B and D not run")
    else:
        T.add("sets A vs B, A vs C, C vs D (appendix, 1223-1295)", "-", "-",
              "not testable here: one set (%s) was analysed" % S)

    out.append("The paper's claims, one row each, judged on set %s (the verdict rules are those of "
               "tools/reproduction_claims.py; \"%s\" in the set column: the paper states the claim for set A):\n"
               % (S, A_only))
    out.append(T.markdown())
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("analysis", nargs="+", help="directories of `capsflow analyze` (analysis.h5, summary.json)")
    ap.add_argument("--isolated", default=ISOLATED, help="isolated V^S table (Ca, y0/H, V^S per line; default %(default)s)")
    ap.add_argument("--check", metavar="DOC", help="compare with the tables between the claims markers of DOC")
    ap.add_argument("--write", metavar="DOC", help="replace the tables between the claims markers of DOC, and its "
                    "'<!-- claims:from ... -->' line before them with the analysis directories as given")
    args = ap.parse_args()
    text = build(args.analysis, args.isolated)
    if args.write:
        doc = open(args.write, encoding="utf-8").read()
        if BEGIN not in doc or END not in doc:
            sys.exit("reproduction_claims.py: %s has no %s ... %s block" % (args.write, BEGIN, END))
        head, rest = doc.split(BEGIN, 1)
        lines = [l for l in head.split("\n") if not l.startswith(FROM)]
        head = "\n".join(lines) + "%s %s -->\n" % (FROM, " ".join(args.analysis))
        tmp = args.write + ".tmp"
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(head + BEGIN + "\n" + text + END + rest.split(END, 1)[1])
        os.replace(tmp, args.write)
        return 0
    if not args.check:
        sys.stdout.write(text)
        return 0
    doc = open(args.check, encoding="utf-8").read()
    if BEGIN not in doc or END not in doc:
        sys.exit("reproduction_claims.py: %s has no %s ... %s block" % (args.check, BEGIN, END))
    have = doc.split(BEGIN, 1)[1].split(END, 1)[0].strip("\n") + "\n"
    if have == text:
        return 0
    sys.stdout.write("%s: the claims tables differ from those of %s\n--- in the document:\n%s--- computed:\n%s"
                     % (args.check, ", ".join(args.analysis), have, text))
    return 1


if __name__ == "__main__":
    sys.exit(main())
