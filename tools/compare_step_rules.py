#!/usr/bin/env python3
"""Statistics of one suspension under two settings: the two step rules (T4 and T5 of the step-rule issue;
docs/validation.md 9.4), or two settings named with --names and given by --first/--second: the defaults against
[ggem] tolerance (validation.md 12), cfl 0.5 against 0.6 (validation.md 9.8).

Reads the `capsflow analyze` outputs of the two groups (summary.json, profiles.csv; each group the seeds of one rule,
analysed over one window) and the run files themselves (mean Taylor D, contact events, steps per strain), and writes
a Markdown table: each statistic under both rules, their difference, the combined standard error, and whether the
difference is within 2 combined standard errors.

  python3 tools/compare_step_rules.py --window 40 100 \\
      --paper  runs/paper-analysis   runs/paper/*/output.h5 \\
      --membrane runs/membrane-analysis runs/membrane/*/output.h5 --out docs/figures/step_rule_statistics.md
  python3 tools/compare_step_rules.py --window 40 100 --names defaults "tolerance 2e-2" \
      --first an_def def_s*/out.h5 --second an_tol tol_s*/out.h5 --out docs/figures/tolerance_statistics.md

Standard errors: d-bar and phi-hat as `capsflow analyze` gives them (block averages pooled over the seeds); mean D
from the seed-to-seed spread of the per-run window means. Needs python3-h5py and numpy (Debian packages).
"""
import argparse
import csv
import json
import math
import sys

import h5py
import numpy as np


def group_of(analysis_dir):
    with open(f"{analysis_dir}/summary.json") as f:
        s = json.load(f)
    groups = [g for g in s["groups"] if g["kind"] == "suspension"]
    if len(groups) != 1:
        sys.exit(f"{analysis_dir}/summary.json: expected one suspension group, found {len(groups)}")
    return groups[0]


def profiles(analysis_dir, quantity):
    out = {}
    with open(f"{analysis_dir}/profiles.csv") as f:
        for row in csv.DictReader(f):
            if row["quantity"] != quantity or row["value"] in ("null", "nan", ""):
                continue
            out.setdefault(row["species"], []).append((float(row["y_over_H"]), float(row["value"]), float(row["se"])))
    return out


def run_stats(paths, t0, t1):
    """Per run: mean D per species over the window, steps per strain over it, contact statistics over it."""
    per_run = []
    for p in paths:
        with h5py.File(p, "r") as f:
            t = f["/series/time"][:]
            step = f["/series/step"][:]
            D = f["/series/taylor_D"][:]
            species = f["/capsules/species"][:]
            names = f["/capsules/species"].attrs["names"]
            names = (names.decode() if isinstance(names, bytes) else names).split(",")
            w = (t >= t0) & (t <= t1)
            if w.sum() < 2:
                sys.exit(f"{p}: fewer than two records in the window [{t0}, {t1}] (the run reached {t[-1]:.4g})")
            i0, i1 = np.argmax(w), len(w) - 1 - np.argmax(w[::-1])
            r = {"path": p, "span": t[i1] - t[i0], "steps": int(step[i1] - step[i0]), "D": {}}
            for k, name in enumerate(names):
                sel = species == k
                if sel.any():
                    r["D"][name] = float(D[w][:, sel].mean())
            ev_t = f["/events/time"][:] if "/events/time" in f else np.zeros(0)
            ev_gap = f["/events/gap_before"][:] if "/events/gap_before" in f else np.zeros(0)
            ev_dy = f["/events/dy"][:] if "/events/dy" in f else np.zeros((0, 2))
            e = (ev_t >= t[i0]) & (ev_t <= t[i1])
            r["events"] = int(e.sum())
            r["negative_gap_events"] = int((ev_gap[e] < 0).sum())
            r["min_gap_before"] = float(ev_gap[e].min()) if e.any() else math.inf
            r["contact_dy"] = float(np.abs(ev_dy[e]).sum())
            r["np"] = len(species)
            # Cross-stream motion from collisions: |y_c(t + 1) - y_c(t)| summed per capsule and strain unit.
            c = f["/series/centroid"][:]
            y = c[w][:, :, 1]
            tw = t[w]
            stride = max(1, int(round(1.0 / np.median(np.diff(tw)))))
            r["cross_stream"] = float(np.abs(np.diff(y[::stride], axis=0)).sum() / (len(species) * (tw[::stride][-1] - tw[0])))
        per_run.append(r)
    return per_run


def rms_y_difference(pa, pb, t):
    """rms over capsules of y_c(paper) - y_c(membrane) at the records nearest strain t (y: no record-time bias,
    unlike x, which moves at ~1.5 a per strain unit)."""
    with h5py.File(pa, "r") as fa, h5py.File(pb, "r") as fb:
        ia = int(np.argmin(abs(fa["/series/time"][:] - t)))
        ib = int(np.argmin(abs(fb["/series/time"][:] - t)))
        d = fa["/series/centroid"][ia][:, 1] - fb["/series/centroid"][ib][:, 1]
    return float(np.sqrt((d ** 2).mean()))


def mean_se(values):
    v = np.asarray(values, float)
    if len(v) < 2:
        return float(v.mean()), math.nan
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--paper", "--first", dest="paper", nargs="+", required=True, metavar=("ANALYSIS_DIR", "RUN.h5"))
    ap.add_argument("--membrane", "--second", dest="membrane", nargs="+", required=True,
                    metavar=("ANALYSIS_DIR", "RUN.h5"))
    ap.add_argument("--names", nargs=2, default=["paper rule", "membrane rule"], metavar=("FIRST", "SECOND"),
                    help="the two settings' names in the tables (default: the step rules')")
    ap.add_argument("--window", nargs=2, type=float, required=True, metavar=("T0", "T1"))
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    t0, t1 = a.window
    rules = {"paper": a.paper, "membrane": a.membrane}
    g = {r: group_of(v[0]) for r, v in rules.items()}
    prof = {r: profiles(v[0], "phi_hat") for r, v in rules.items()}
    runs = {r: run_stats(v[1:], t0, t1) for r, v in rules.items()}

    rows, verdicts = [], []

    def compare(name, p, pse, m, mse):
        se = math.sqrt(pse ** 2 + mse ** 2) if not (math.isnan(pse) or math.isnan(mse)) else math.nan
        d = m - p
        ok = (abs(d) <= 2 * se) if not math.isnan(se) else None
        verdicts.append(ok)
        rows.append(f"| {name} | {p:.4f} ± {pse:.4f} | {m:.4f} ± {mse:.4f} | {d:+.4f} | {se:.4f} | "
                    f"{'yes' if ok else ('no' if ok is not None else '-')} |")

    for sp in ("stiff", "floppy", "all"):
        ps, ms = g["paper"]["species"].get(sp, {}).get("dbar"), g["membrane"]["species"].get(sp, {}).get("dbar")
        if ps and ms and ps["value"] is not None and ms["value"] is not None:
            compare(f"d-bar {sp}", ps["value"], ps["se"], ms["value"], ms["se"])
    for sp in sorted(set(runs["paper"][0]["D"]) & set(runs["membrane"][0]["D"])):
        p, pse = mean_se([r["D"][sp] for r in runs["paper"]])
        m, mse = mean_se([r["D"][sp] for r in runs["membrane"]])
        compare(f"mean D {sp}", p, pse, m, mse)
    profile_rows = 0
    profile_fail = 0
    for sp in sorted(set(prof["paper"]) & set(prof["membrane"])):
        P = {round(y, 6): (v, s) for y, v, s in prof["paper"][sp]}
        M = {round(y, 6): (v, s) for y, v, s in prof["membrane"][sp]}
        for y in sorted(set(P) & set(M)):
            (p, pse), (m, mse) = P[y], M[y]
            se = math.hypot(pse, mse)
            profile_rows += 1
            if se > 0 and abs(m - p) > 2 * se:
                profile_fail += 1
    with open(a.out, "w") as f:
        n1, n2 = a.names
        f.write(f"Window [{t0:g}, {t1:g}] strain; {n1}: {len(runs['paper'])} runs, {n2}: {len(runs['membrane'])} runs.\n\n")
        f.write(f"| statistic | {n1} | {n2} | difference | combined SE | within 2 SE |\n")
        f.write("|---|---|---|---|---|---|\n")
        f.write("\n".join(rows) + "\n")
        f.write(f"\nphi-hat profiles ({', '.join(sorted(set(prof['paper']) & set(prof['membrane'])))}; "
                f"{profile_rows} bins): {profile_rows - profile_fail} within 2 combined SE, {profile_fail} outside "
                f"(at 2 SE about 5 % of bins fall outside by chance).\n\n")
        f.write("| setting | run | steps per strain | contact events | events with gap < 0 | smallest gap before | "
                "contact abs(dy) per capsule per strain | cross-stream abs(dy) per capsule per strain |\n")
        f.write("|---|---|---|---|---|---|---|---|\n")
        for rule, rs in runs.items():
            for r in rs:
                f.write(f"| {n1 if rule == 'paper' else n2} | {r['path']} | {r['steps'] / r['span']:.1f} | {r['events']} | "
                        f"{r['negative_gap_events']} | {r['min_gap_before']:.4g} | "
                        f"{r['contact_dy'] / (r['np'] * r['span']):.3g} | {r['cross_stream']:.3g} |\n")
        if len(runs["paper"]) == len(runs["membrane"]):
            # Runs given in the same seed order start from the same placement: how far apart did they go?
            f.write("\n| seed pair | rms difference of y_c at the window's start | at its end |\n|---|---|---|\n")
            for rp, rm in zip(runs["paper"], runs["membrane"]):
                d = [rms_y_difference(rp["path"], rm["path"], t) for t in (t0, t1)]
                f.write(f"| {rp['path']} / {rm['path']} | {d[0]:.3g} | {d[1]:.3g} |\n")
    print(open(a.out).read())
    bad = [v for v in verdicts if v is False]
    sys.exit(1 if bad or profile_fail > max(1, 0.1 * profile_rows) else 0)


if __name__ == "__main__":
    main()
