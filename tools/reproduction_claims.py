#!/usr/bin/env python3
"""The claims table of docs/reproduction.md, computed from a `capsflow analyze` output.

Every claim of analysis-spec sections 6.1 and 6.2 that a sweep of one set at X_f = 0, 0.5 and 1 can test is turned
into a number with its standard error and a verdict by a fixed rule, so that the table is made by the program and
not by hand:

  - an ordering claim ("a > b"): z = (a - b) / sqrt(SE_a^2 + SE_b^2); "agrees" when z >= 2, "same direction, z < 2"
    when 0 < z < 2, "opposite direction, |z| < 2" when -2 < z <= 0, "disagrees" when z <= -2;
  - a closeness claim ("a ~ b"): "agrees" when |z| < 2, else "disagrees";
  - a position claim ("at y ~ 0.2H"): "agrees" when the feature lies within the tolerance named in the row (the bins
    are 0.02H wide);
  - a claim that needs another set, another X_f or isolated runs: "not testable here", with the reason.

The SEs are the block (jackknife) errors of `capsflow analyze` (docs/analysis.md); a mean of n bins combines the
bins' SEs in quadrature (the bins of one window are treated as independent, so such SEs are lower bounds). The
records of one window are correlated over a few strain units, so a z of 2-3 is weaker evidence than it looks.

    PYTHONPATH=python tools/reproduction_claims.py docs/figures/reproduction               # print the tables
    PYTHONPATH=python tools/reproduction_claims.py docs/figures/reproduction --check docs/reproduction.md

--check compares the tables with the text between `<!-- claims:begin -->` and `<!-- claims:end -->` in the document
(exit 1 on drift, printing both), so the numbers of the page cannot drift from the committed analysis.
"""
import argparse
import math
import sys

import numpy as np

try:
    import capsflow
except ImportError as e:  # the package lives in python/ of the checkout
    sys.exit("reproduction_claims.py: cannot import the capsflow package (%s): run with PYTHONPATH=python" % e)

BEGIN, END = "<!-- claims:begin -->", "<!-- claims:end -->"


def fmt(v, se=None, digits=4):
    if v is None or not math.isfinite(v):
        return "-"
    if se is None or not math.isfinite(se):
        return "%.*f" % (digits, v)
    return "%.*f ± %.*f" % (digits, v, digits, se)


def order(a, sa, b, sb):
    """Verdict of the claim a > b."""
    den = math.hypot(sa, sb)
    if not (math.isfinite(den) and den > 0):
        return "%s, no standard error" % ("same direction" if a > b else "opposite direction")
    z = (a - b) / den
    if z >= 2:
        return "agrees (z = %.1f)" % z
    if z > 0:
        return "same direction, z = %.1f < 2" % z
    if z > -2:
        return "opposite direction, z = %.1f" % z
    return "**disagrees** (z = %.1f)" % z


def close(a, sa, b, sb):
    den = math.hypot(sa, sb)
    if not (math.isfinite(den) and den > 0):
        return "no standard error: not judged"
    z = (a - b) / den
    return ("agrees (|z| = %.1f < 2)" if abs(z) < 2 else "**disagrees** (|z| = %.1f)") % abs(z)


def position(found, target, tol):
    if found is None or not math.isfinite(found):
        return "not found"
    return ("agrees (within %.2fH)" if abs(found - target) <= tol else "**disagrees** (off by more than %.2fH)") % tol


def judged(value, verdict):
    """verdict() where `value` is defined, else why not."""
    return verdict() if math.isfinite(value) else "not judged (masked bins)"


def region_mean(prof, lo, hi):
    """Mean of a profile over the bins with centres in [lo, hi] (y/H), with the quadrature SE; NaN bins skipped."""
    m = (prof.y_over_H >= lo) & (prof.y_over_H <= hi) & np.isfinite(prof.value)
    if not m.any():
        return math.nan, math.nan
    se = prof.se[m]
    se = math.sqrt(np.nansum(se ** 2)) / m.sum() if np.isfinite(se).any() else math.nan
    return float(np.mean(prof.value[m])), se


def argext(prof, lo, hi, largest=True):
    """y/H and value of the largest (or smallest) defined bin with centre in [lo, hi]."""
    m = (prof.y_over_H >= lo) & (prof.y_over_H <= hi) & np.isfinite(prof.value)
    if not m.any():
        return math.nan, math.nan
    idx = np.flatnonzero(m)
    k = idx[np.argmax(prof.value[m])] if largest else idx[np.argmin(prof.value[m])]
    return float(prof.y_over_H[k]), float(prof.value[k])


def slope(prof, lo, hi):
    """Weighted least-squares slope d(value)/d(y/H) over the bins in [lo, hi], with its SE."""
    m = (prof.y_over_H >= lo) & (prof.y_over_H <= hi) & np.isfinite(prof.value) & np.isfinite(prof.se) & (prof.se > 0)
    if m.sum() < 3:
        return math.nan, math.nan
    x, y, w = prof.y_over_H[m], prof.value[m], 1.0 / prof.se[m] ** 2
    xm = np.sum(w * x) / np.sum(w)
    sxx = np.sum(w * (x - xm) ** 2)
    b = np.sum(w * (x - xm) * y) / sxx
    return float(b), float(1.0 / math.sqrt(sxx))


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


def plateau(t, d, t0, t1, block=50.0, least=3):
    """Means of d over consecutive `block`-strain blocks from 0, and the plateau time: the start of the first block
    from which every later complete block mean lies within 2 standard deviations of the window's block means
    (at least 0.005) of the window mean, counting only starts followed by `least` such blocks in all (fewer: no
    plateau established yet). Also the drift over the window: the least-squares slope of d, per 100 strain."""
    ok = np.isfinite(d)
    t, d = t[ok], d[ok]
    spacing = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    edges = np.arange(0.0, t[-1] + 1e-9, block)
    means = []
    for lo in edges:
        m = (t >= lo) & (t < lo + block)
        if m.any() and t[-1] >= lo + block - 1.5 * spacing:  # complete blocks only
            means.append((lo, float(d[m].mean())))
    w = (t >= t0) & (t <= t1)
    wm = float(d[w].mean())
    inside = [v for lo, v in means if lo >= t0]
    spread = max(2 * float(np.std(inside)) if len(inside) > 1 else 0.0, 0.005)
    tp = math.nan
    for i, (lo, _) in enumerate(means):
        if len(means) - i >= least and all(abs(v - wm) <= spread for _, v in means[i:]):
            tp = lo
            break
    tw, dw = t[w], d[w]
    drift = 100.0 * float(np.polyfit(tw, dw, 1)[0]) if len(tw) > 2 else math.nan
    return means, wm, spread, tp, drift


class Table:
    def __init__(self):
        self.rows = []

    def add(self, claim, ours, verdict):
        self.rows.append((claim, ours, verdict))

    def markdown(self):
        out = ["| # | claim (paper line; analysis-spec) | capsflow | verdict |", "|---|---|---|---|"]
        for i, (c, o, v) in enumerate(self.rows, 1):
            out.append("| %d | %s | %s | %s |" % (i, c, o, v))
        return "\n".join(out)


def build(path):
    an = capsflow.open_analysis(path)
    gs = an.suspension_groups()
    sets = sorted({g.set for g in gs})
    if len(sets) != 1:
        sys.exit("reproduction_claims.py: %s: expected suspension groups of one set, found %d (%s)"
                 % (path, len(sets), "; ".join(sets)))
    by = {g.x_f: g for g in gs}
    need = [0.0, 0.5, 1.0]
    if any(x not in by for x in need):
        sys.exit("reproduction_claims.py: %s: expected groups at X_f = 0, 0.5 and 1; found X_f = %s"
                 % (path, ", ".join("%g" % x for x in sorted(by))))
    p0, mx, p1 = by[0.0], by[0.5], by[1.0]
    out = []

    # Steady values.
    out.append("Steady values over the window (d-bar/(H/2), enrichment E, f_AB with horizon 100 and region A within "
               "0.3H of a wall; ± one block SE):\n")
    out.append("| X_f | window | d-bar stiff | d-bar floppy | d-bar all | E_s | E_f | f_AB stiff | f_AB floppy | "
               "contacts per strain |")
    out.append("|---|---|---|---|---|---|---|---|---|---|")
    summ = {e["id"]: e for e in (an.summary or {}).get("groups", [])}
    for x in need:
        g = by[x]
        c = summ.get(g.id, {}).get("contact", {}).get("events_per_strain")
        out.append("| %g | [%g, %g] | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            x, g.t0, g.t1, fmt(g.dbar["stiff"].value, g.dbar["stiff"].se), fmt(g.dbar["floppy"].value,
                                                                              g.dbar["floppy"].se),
            fmt(g.dbar["all"].value, g.dbar["all"].se), fmt(g.E["stiff"].value, g.E["stiff"].se, 3),
            fmt(g.E["floppy"].value, g.E["floppy"].se, 3), fmt(g.f_AB["stiff"].value, g.f_AB["stiff"].se, 3),
            fmt(g.f_AB["floppy"].value, g.f_AB["floppy"].se, 3), "-" if c is None else "%.1f" % c))

    # Plateau.
    out.append("\nd-bar(t)/(H/2) of each run in 50-strain blocks (the whole run), the least-squares drift of d-bar over "
               "the window, and the plateau time: the start of the first block after which every block mean stays "
               "within the band (twice the spread of the window's block means, at least 0.005) around the window "
               "mean, with at least three blocks from there on (else: not established):\n")
    rows, plats = [], {}
    for x, sp in ((0.0, "stiff"), (0.5, "all"), (1.0, "floppy")):
        g = by[x]
        t, d = g.dbar_t.time, getattr(g.dbar_t, sp)
        means, wm, band, tp, drift = plateau(t, d, g.t0, g.t1)
        plats[x] = tp
        rows.append((x, sp, means, wm, band, tp, drift))
    nblocks = max(len(r[2]) for r in rows)
    out.append("| X_f (species) | " + " | ".join("%d-%d" % (50 * i, 50 * i + 50) for i in range(nblocks))
               + " | band | drift over the window, per 100 strain | plateau from |")
    out.append("|---|" + "---|" * nblocks + "---|---|---|")
    for x, sp, means, wm, band, tp, drift in rows:
        cells = ["%.4f" % v for _, v in means] + ["-"] * (nblocks - len(means))
        out.append("| %g (%s) | %s | ± %.4f | %+.4f | %s |" % (
            x, sp, " | ".join(cells), band, drift, "not established" if not math.isfinite(tp) else "%g" % tp))

    T = Table()
    d = lambda g, s: (g.dbar[s].value, g.dbar[s].se)  # noqa: E731

    # 6.1 quantitative
    tps = [plats[x] for x in need]
    reached = all(math.isfinite(v) for v in tps)
    T.add("d-bar reaches an apparent steady state in about 500 strain (473-474; 6.1)",
          "plateau from %s (X_f = 0 / 0.5 / 1)" % " / ".join("-" if not math.isfinite(v) else "%g" % v for v in tps),
          ("agrees: steady by %g, at or before 500" % max(tps)) if reached and max(tps) <= 500 else
          ("later than 500 (%g)" % max(tps) if reached else "not established within the runs"))
    T.add("d-bar decreases initially in all cases (467-468; 6.2)",
          " / ".join("%.4f → %.4f" % (getattr(g.dbar_t, sp)[0],
                                      float(np.nanmean(getattr(g.dbar_t, sp)[(g.dbar_t.time >= 10)
                                                                              & (g.dbar_t.time <= 30)])))
                     for g, sp in ((p0, "stiff"), (mx, "all"), (p1, "floppy")))
          + " (t = 0 → mean over [10, 30])",
          "agrees" if all(float(np.nanmean(getattr(g.dbar_t, sp)[(g.dbar_t.time >= 10) & (g.dbar_t.time <= 30)]))
                          < getattr(g.dbar_t, sp)[0] for g, sp in ((p0, "stiff"), (mx, "all"), (p1, "floppy")))
          else "**disagrees**")
    T.add("t ≈ 600: stiff displaced toward the walls after ~600; d-bar_all weakly evolving after 800 (486-491)",
          "-", "not testable here: stated for X_f = 0.2, not run")

    # 6.2 d-bar orderings
    a, sa = d(p0, "stiff")
    b, sb = d(p1, "floppy")
    T.add("pure stiff d-bar slightly higher than pure floppy, \"not large\" (474-476); at any phi, stiff above floppy "
          "(1250-1251)", "%s vs %s" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))
    a, sa = d(mx, "stiff")
    b, sb = d(mx, "floppy")
    T.add("in the mixture the stiff sit farther from the centreline than the floppy (segregation; 1250-1251, 599-601)",
          "%s vs %s (X_f = 0.5)" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))
    a, sa = d(mx, "stiff")
    b, sb = d(p0, "stiff")
    T.add("d-bar of the stiff increases with X_f (501-503)", "%s (0.5) vs %s (0)" % (fmt(a, sa), fmt(b, sb)),
          order(a, sa, b, sb))
    a, sa = d(p1, "floppy")
    b, sb = d(mx, "floppy")
    T.add("d-bar of the floppy increases with X_f (501-503)", "%s (1) vs %s (0.5)" % (fmt(a, sa), fmt(b, sb)),
          order(a, sa, b, sb))
    a0, s0 = d(p0, "all")
    a5, s5 = d(mx, "all")
    a1, s1 = d(p1, "all")
    T.add("d-bar of the whole suspension decreases with X_f (501-503)",
          "%s / %s / %s (X_f = 0 / 0.5 / 1)" % (fmt(a0, s0), fmt(a5, s5), fmt(a1, s1)),
          "0 → 0.5: %s; 0.5 → 1: %s" % (order(a0, s0, a5, s5), order(a5, s5, a1, s1)))
    ds = d(mx, "stiff")[0] - d(p0, "stiff")[0]
    dss = math.hypot(d(mx, "stiff")[1], d(p0, "stiff")[1])
    df = d(p1, "floppy")[0] - d(mx, "floppy")[0]
    dfs = math.hypot(d(p1, "floppy")[1], d(mx, "floppy")[1])
    T.add("the stiff's d-bar rises faster with X_f than the floppy's falls with decreasing X_f (509-511)",
          "Δ stiff (0 → 0.5) %s vs Δ floppy (0.5 → 1) %s" % (fmt(ds, dss), fmt(df, dfs)), order(ds, dss, df, dfs))

    # n-hat and phi-hat
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        n = g.profile("n_hat", sp)
        yw, vw = argext(n, 0.0, 0.3)
        ym, vm = argext(n, 0.2, 0.45, largest=False)
        yc, vc = argext(n, 0.35, 0.5)
        T.add("n-hat of pure %s: a sharp peak near the wall and a broad peak near the centreline (541-542)" % sp,
              "wall peak %.2f at y/H = %.2f, minimum %.2f at %.2f, centre peak %.2f at %.2f"
              % (vw, yw, vm, ym, vc, yc),
              "agrees" if vw > vm and vc > vm and yw < ym < yc else "**disagrees**")
    yws = argext(p0.profile("n_hat", "stiff"), 0.0, 0.3)[0]
    ywf = argext(p1.profile("n_hat", "floppy"), 0.0, 0.3)[0]
    T.add("the wall peak of n-hat is closer to the wall for the stiff than for the floppy (545-547)",
          "y/H = %.2f (stiff) vs %.2f (floppy); bins 0.02H" % (yws, ywf),
          "agrees" if yws < ywf else ("same bin: not resolved" if yws == ywf else "**disagrees**"))
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        yn = argext(g.profile("n_hat", sp), 0.0, 0.3)[0]
        yp = argext(g.profile("phi_hat", sp), 0.0, 0.3)[0]
        T.add("y/H = 0.2 is about the near-wall peak of n-hat and phi-hat (658-659), pure %s" % sp,
              "n-hat peak at %.2f, phi-hat peak at %.2f" % (yn, yp),
              "n-hat: %s; phi-hat: %s" % (position(yn, 0.2, 0.05), position(yp, 0.2, 0.05)))
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        ph = g.profile("phi_hat", sp)
        v, s = float(ph.value[-1]), float(ph.se[-1])
        ym = argext(ph, 0.2, 0.45, largest=False)[0]
        T.add("phi-hat(0.5H) ≈ 2 for pure set A (558-560); the minimum of phi-hat near 0.3H sets region A (1037-1038), "
              "pure %s" % sp, "phi-hat(%.2fH) = %s; minimum at y/H = %.2f" % (ph.y_over_H[-1], fmt(v, s, 2), ym),
              "phi-hat(0.5H): not testable here (set A's value; this is set C, phi 0.12); minimum: %s"
              % position(ym, 0.3, 0.05))
    # n-hat against X_f: (claim, profile of the mixture, of the pure run, label, region, relation) where the relation
    # "more" claims mixture > pure, "less" mixture < pure, "same" mixture ~ pure.
    ns0, ns5 = p0.profile("n_hat", "stiff"), mx.profile("n_hat", "stiff")
    nf5, nf1 = mx.profile("n_hat", "floppy"), p1.profile("n_hat", "floppy")
    for claim, mix, pure, label, lo, hi, region, rel in (
            ("with increasing X_f the stiff's concentration rises near the walls (566-570)",
             ns5, ns0, "n-hat_S", 0.0, 0.3, "y < 0.3H", "more"),
            ("at higher X_f the stiff are slightly depleted around the centreline (566-570)",
             ns5, ns0, "n-hat_S", 0.4, 0.5, "y > 0.4H", "less"),
            ("with decreasing X_f the floppy are depleted near the walls (573-576)",
             nf5, nf1, "n-hat_F", 0.0, 0.2, "y < 0.2H", "less"),
            ("... and accumulate between the two peaks (573-576)",
             nf5, nf1, "n-hat_F", 0.2, 0.35, "0.2H-0.35H", "more"),
            ("... with no significant change near the centreline (573-576)",
             nf5, nf1, "n-hat_F", 0.4, 0.5, "y > 0.4H", "same")):
        a, sa = region_mean(mix, lo, hi)
        b, sb = region_mean(pure, lo, hi)
        other = "0" if pure is ns0 else "1"
        verdict = {"more": lambda: order(a, sa, b, sb), "less": lambda: order(b, sb, a, sa),
                   "same": lambda: close(a, sa, b, sb)}[rel]()
        T.add(claim, "mean %s over %s: %s (0.5) vs %s (%s)" % (label, region, fmt(a, sa, 3), fmt(b, sb, 3), other),
              verdict)

    # X_f-hat and E
    xh = mx.profile("xf_hat")
    a, sa = region_mean(xh, 0.4, 0.5)
    b, sb = region_mean(xh, 0.0, 0.2)
    T.add("floppy enriched near the centreline, stiff near the walls (599-601)",
          "mean X_f-hat over y > 0.4H %s, over y < 0.2H %s" % (fmt(a, sa, 3), fmt(b, sb, 3)),
          "centre > 1: %s; walls < 1: %s" % (order(a, sa, 1.0, 0.0), order(1.0, 0.0, b, sb)))
    cr = crossing(xh, 1.0, 0.1, 0.45)
    T.add("X_f-hat = 1 at y ≈ H/4 (604-605)", "crossings at y/H = %s" % (", ".join("%.3f" % c for c in cr) or "none"),
          (position(min(cr, key=lambda c: abs(c - 0.25)), 0.25, 0.05)
           + ("" if len(cr) == 1 else "; %d crossings (noise)" % len(cr))) if cr else "no crossing")
    es, ef = mx.E["stiff"], mx.E["floppy"]
    T.add("E ≥ 1 by definition (613)", "E_s %s, E_f %s" % (fmt(es.value, es.se, 3), fmt(ef.value, ef.se, 3)),
          "agrees" if es.value >= 1 and ef.value >= 1 else "**disagrees** (an analysis error)")
    T.add("enrichment of a species grows as it becomes more dilute, faster for the stiff (616-618)", "-",
          "not testable here: needs two or more mixture fractions (one run: X_f = 0.5)")

    # v-bar_p
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        v = g.profile("v_bar", sp)
        s1, e1 = slope(v, 0.1, 0.2)
        s2, e2 = slope(v, 0.2, 0.3)
        s3, e3 = slope(v, 0.3, 0.5)
        T.add("v-bar_p of pure %s: falls with distance from the wall for y < 0.2H, about constant in 0.2H-0.3H, "
              "falls linearly in 0.3H-0.5H (655-664)" % sp,
              "slopes d v-bar/d(y/H) [gammadot a]: %s (0.1-0.2H), %s (0.2-0.3H), %s (0.3-0.5H)"
              % (fmt(s1, e1, 3), fmt(s2, e2, 3), fmt(s3, e3, 3)),
              "y < 0.2H: %s; 0.2-0.3H flatter than 0.3-0.5H: %s; 0.3-0.5H falling: %s"
              % (judged(s1, lambda: order(0.0, 0.0, s1, e1)),
                 judged(s2 + s3, lambda: "yes" if abs(s2) < abs(s3) else "no"),
                 judged(s3, lambda: order(0.0, 0.0, s3, e3))))
    dv = {}
    for sp in ("stiff", "floppy"):
        try:
            dv[sp] = mx.profile("dv_rel", sp)
        except KeyError:
            dv[sp] = None
    masked = "not judged: Δv-bar_p/v_r masked in every bin (|v_r| < 2 SE(v_r))"
    a, sa = region_mean(dv["stiff"], 0.2, 0.3) if dv["stiff"] is not None else (math.nan, math.nan)
    if dv["stiff"] is not None:
        ym, vm = argext(dv["stiff"], 0.1, 0.45, largest=False)
        T.add("the stiff's v-bar_p is greatly reduced as X_f grows, by up to ~50 % (X_f up to 0.8), most in "
              "0.2H-0.3H (683-687)", "Δv-bar_p/v_r (X_f = 0.5): mean over 0.2-0.3H %s; minimum %.2f at y/H = %.2f"
              % (fmt(a, sa, 2), vm, ym),
              "reduced: %s" % order(0.0, 0.0, a, sa) if math.isfinite(a) else
              "not judged: masked in 0.2-0.3H (|v_r| < 2 SE(v_r))")
    else:
        T.add("the stiff's v-bar_p is greatly reduced as X_f grows (683-687)", "-", masked)
    if dv["floppy"] is not None:
        b, sb = region_mean(dv["floppy"], 0.2, 0.3)
        T.add("the floppy's v-bar_p is a weak function of X_f (697-698)",
              "Δv-bar_p/v_r (X_f = 0.5) over 0.2-0.3H: floppy %s vs stiff %s" % (fmt(b, sb, 2), fmt(a, sa, 2)),
              "weaker than the stiff's: %s" % order(abs(a), sa, abs(b), sb) if math.isfinite(a) and math.isfinite(b)
              else "not judged: masked in 0.2-0.3H")
    else:
        T.add("the floppy's v-bar_p is a weak function of X_f (697-698)", "-", masked)
    T.add("the suspension's v-bar_p can exceed the isolated capsule's migration velocity (672-674)", "-",
          "not testable in this sweep: needs the pinned isolated runs (analysis-spec 4.6) of set C")

    # P(v_p)
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        pd = g.pdfs(sp)
        if 0.2 in pd and 0.5 in pd:
            r2p, r2n = tail_ratio(pd[0.2], +1), tail_ratio(pd[0.2], -1)
            r5p = tail_ratio(pd[0.5], +1)
            T.add("P(v_p) of pure %s: the positive tail at y = 0.2H is non-Gaussian (closer to exponential), Gaussian "
                  "farther out; negative tails Gaussian (718-722)" % sp,
                  "mass beyond 2 SD over the Gaussian's: 0.2H positive %.2f, negative %.2f; 0.5H positive %.2f "
                  "(%d samples at 0.2H)" % (r2p, r2n, r5p, pd[0.2].samples),
                  "heavier positive tail at 0.2H: %s" % ("agrees" if r2p > 1.3 and r2p > r2n else "**disagrees**"))
    # v'_p
    for g, sp in ((p0, "stiff"), (p1, "floppy")):
        vp = g.profile("v_prime", sp)
        ymin = argext(vp, 0.1, 0.3, largest=False)[0]
        ymax = argext(vp, 0.2, 0.45)[0]
        c, cs = float(vp.value[-1]), float(vp.se[-1])
        vb = g.profile("v_bar", sp)
        a, sa = region_mean(vp, 0.4, 0.5)
        vb_abs = np.abs(vb.value)
        m = (vb.y_over_H >= 0.4) & np.isfinite(vb_abs)
        b = float(vb_abs[m].mean()) if m.any() else math.nan
        T.add("v'_p of pure %s: minimum near 0.2H, maximum near 0.3H, finite at 0.5H; larger than the mean near the "
              "centreline (753-770)" % sp,
              "minimum at %.2f, maximum at %.2f, v'_p(%.2fH) = %s; over y > 0.4H v'_p %s vs |v-bar_p| %.4f"
              % (ymin, ymax, vp.y_over_H[-1], fmt(c, cs), fmt(a, sa), b),
              "min: %s; max: %s; finite: %s; v' > |v-bar|: %s"
              % (position(ymin, 0.2, 0.05), position(ymax, 0.3, 0.05), order(c, cs, 0.0, 0.0).split(" (")[0],
                 "yes" if a > b else "no"))
    a, sa = region_mean(p0.profile("v_prime", "stiff"), 0.1, 0.5)
    b, sb = region_mean(p1.profile("v_prime", "floppy"), 0.1, 0.5)
    T.add("stiff capsules fluctuate more than floppy ones, pure (755-756, 778-779)",
          "mean v'_p over 0.1-0.5H: %s vs %s" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))
    a, sa = region_mean(mx.profile("v_prime", "stiff"), 0.1, 0.5)
    b, sb = region_mean(mx.profile("v_prime", "floppy"), 0.1, 0.5)
    T.add("... and in the mixture (778-779)", "X_f = 0.5: %s vs %s" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))
    for sp, pure in (("stiff", p0), ("floppy", p1)):
        a, sa = region_mean(mx.profile("v_prime", sp), 0.1, 0.5)
        b, sb = region_mean(pure.profile("v_prime", sp), 0.1, 0.5)
        T.add("fluctuations higher in mixtures than in the pure suspensions, %s (775-777)" % sp,
              "mean v'_p over 0.1-0.5H: %s (mixture) vs %s (pure)" % (fmt(a, sa), fmt(b, sb)), order(a, sa, b, sb))

    # f_AB
    fs0, ff1 = p0.f_AB["stiff"], p1.f_AB["floppy"]
    fs5, ff5 = mx.f_AB["stiff"], mx.f_AB["floppy"]
    span = min(g.t1 - g.t0 for g in (p0, mx, p1))
    if all(math.isfinite(e.value) for e in (fs0, ff1, fs5, ff5)) and span < 200:
        T.add("f_AB (1033-1063)", "%s (stiff, X_f = 0), %s / %s (stiff / floppy, 0.5), %s (floppy, 1)"
              % (fmt(fs0.value, fs0.se, 3), fmt(fs5.value, fs5.se, 3), fmt(ff5.value, ff5.se, 3),
                 fmt(ff1.value, ff1.se, 3)),
              "not judged: a %g-strain window leaves %g strain of time origins before the 100-strain horizon "
              "(analysis-spec 4.9 uses 900; its jackknife needs >= 200)" % (span, span - 100))
    elif all(math.isfinite(e.value) for e in (fs0, ff1, fs5, ff5)):
        T.add("f_AB of the two species very close in their pure suspensions (1061-1063); set A: 0.081 (stiff), "
              "0.083 (floppy)", "%s (stiff, X_f = 0) vs %s (floppy, X_f = 1)" % (fmt(fs0.value, fs0.se, 3),
                                                                            fmt(ff1.value, ff1.se, 3)),
              close(fs0.value, fs0.se, ff1.value, ff1.se) + "; set A's values not comparable (set C)")
        T.add("f_AB of the stiff falls as X_f grows (1042-1044: 0.081 → 0.015 at 0.8, set A)",
              "%s (0) → %s (0.5)" % (fmt(fs0.value, fs0.se, 3), fmt(fs5.value, fs5.se, 3)),
              order(fs0.value, fs0.se, fs5.value, fs5.se))
        T.add("f_AB of the floppy rises as X_f falls (1052-1054: 0.083 → 0.141 at 0.2, set A)",
              "%s (1) → %s (0.5)" % (fmt(ff1.value, ff1.se, 3), fmt(ff5.value, ff5.se, 3)),
              order(ff5.value, ff5.se, ff1.value, ff1.se))
    else:
        why = next(e.reason for e in (fs0, ff1, fs5, ff5) if not math.isfinite(e.value))
        T.add("f_AB (1033-1063)", "-", "not computed: %s" % why)

    c = [summ.get(g.id, {}).get("contact", {}).get("events_per_strain") for g in (p0, mx, p1)]
    T.add("only a couple of minimum-gap violations per time unit, N_p = 50 (394-395)",
          "contact corrections per strain: %s (X_f = 0 / 0.5 / 1; N_p = 30)"
          % " / ".join("-" if v is None else "%.1f" % v for v in c),
          "more here: capsflow counts every correction, each ~1e-4 a (see \"Contact control\")")
    T.add("pair collisions in shear (4.10; Fig. 11-12)", "-", "not in this sweep: docs/validation.md (pair collisions)")
    T.add("sets A vs B, A vs C, C vs D (appendix, 1223-1295)", "-", "not testable here: one set (C) was run")

    out.append("\nClaims of analysis-spec 6.1 and 6.2, one row each (the verdict rules are those of "
               "tools/reproduction_claims.py):\n")
    out.append(T.markdown())
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("analysis", help="directory of `capsflow analyze` (analysis.h5, summary.json)")
    ap.add_argument("--check", metavar="DOC", help="compare with the tables between the claims markers of DOC")
    args = ap.parse_args()
    text = build(args.analysis)
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
                     % (args.check, args.analysis, have, text))
    return 1


if __name__ == "__main__":
    sys.exit(main())
