#!/usr/bin/env python3
"""tools/reproduction_claims.py on a synthetic analysis whose verdicts are known by hand.

Set C at X_f = 0, 0.5 and 1 (25 folded bins), written with h5py in the layout of docs/analysis.md:
  - d-bar(t) = d_inf + 0.04 exp(-t/60) to strain 600, window [300, 600]: the 50-strain block means fall below the
    0.005 band from the block starting at 150 (0.02714 exp(-lo/60) <= 0.005 first at lo = 150), so "plateau from 150";
  - steady d-bar 0.36 (pure stiff) and 0.35 (pure floppy), SE 0.001 each: z = 0.01 / 0.001414 = 7.1, "agrees";
  - floppy d-bar 0.352 in the mixture against 0.35 pure: z = -1.4, "opposite direction";
  - v'_p of the stiff 0.02 in the mixture against 0.04 pure, SE 0.001 per bin, so 0.001/sqrt(20) for the mean of the
    20 bins in [0.1H, 0.5H] and z = -0.02 / (sqrt(2) 0.000224) = -63.2: "**disagrees**";
  - X_f-hat = 0.5 + 2 y/H crosses 1 at y/H = 0.25: "agrees (within 0.05H)";
  - f_AB undefined with a reason: the row says "not computed" with it.
The --check mode passes on a document holding the tables between the markers and fails (exit 1) on a changed digit.
Last, docs/reproduction.md is checked against the committed analysis in docs/figures/reproduction/steady, so the
page's numbers cannot drift from it.

    tests/python/test_reproduction_claims.py WORKDIR      # as ctest runs it (exit 77: numpy or h5py missing)
"""
import json
import os
import shutil
import subprocess
import sys

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
TOOL = os.path.join(os.path.dirname(os.path.dirname(HERE)), "tools", "reproduction_claims.py")
try:
    import numpy as np
    import h5py
except ImportError as e:  # pragma: no cover - depends on the machine
    print("SKIP: %s" % e)
    sys.exit(SKIP)

BINS = 25
NAN = float("nan")
SET = "H=10.155 Lx=10.155 Lz=10.155 Np=30 Ca=0.2/0.5"


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def profile(g, name, value, se):
    g["profiles/" + name] = np.asarray(value, float)
    g["profiles/%s_se" % name] = np.full(BINS, se)


def write(d):
    y = (np.arange(BINS) + 0.5) / (2 * BINS)
    t = np.arange(0.0, 600.05, 0.5)
    steady = {0.0: {"stiff": 0.36, "all": 0.36}, 0.5: {"stiff": 0.37, "floppy": 0.352, "all": 0.361},
              1.0: {"floppy": 0.35, "all": 0.35}}
    with h5py.File(os.path.join(d, "analysis.h5"), "w") as f:
        f.attrs["format"] = "capsflow-analysis"
        f.attrs["format_version"] = 1
        f.attrs["bins"] = BINS
        f.attrs["capsflow_version"] = "test"
        for i, xf in enumerate((0.0, 0.5, 1.0)):
            g = f.create_group("groups/g%03d" % i)
            for k, v in (("key", "suspension %s xf=%g" % (SET, xf)), ("label", "Xf=%g" % xf), ("kind", "suspension"),
                         ("set", SET), ("runs", "runs/%g.h5" % xf)):
                g.attrs[k] = v
            for k, v in (("x_f", xf), ("H", 10.155), ("Lx", 10.155), ("Lz", 10.155), ("ca_stiff", 0.2),
                         ("ca_floppy", 0.5), ("t0", 300.0), ("t1", 600.0)):
                g.attrs[k] = v
            g["dbar_t/time"] = t
            for sp in ("stiff", "floppy", "all"):
                g["dbar_t/" + sp] = (steady[xf][sp] + 0.04 * np.exp(-t / 60.0)) if sp in steady[xf] \
                    else np.full_like(t, NAN)
            g["profiles/y_over_H"] = y
            shape = np.where(y < 0.1, 0.0, 1.0 + 0.8 * np.cos(2 * np.pi * (y - 0.2) / 0.3))
            for sp in ("stiff", "floppy"):
                if sp not in steady[xf]:
                    continue
                profile(g, "n_hat_" + sp, shape, 0.05)
                profile(g, "phi_hat_" + sp, shape, 0.05)
                profile(g, "v_bar_" + sp, np.where(y < 0.1, NAN, 0.02 * (0.5 - y)), 0.001)
                mixture = 0 < xf < 1
                profile(g, "v_prime_" + sp, np.full(BINS, 0.02 if (mixture and sp == "stiff") else 0.04), 0.001)
                if mixture:
                    profile(g, "dv_rel_" + sp, np.full(BINS, -0.3 if sp == "stiff" else -0.05), 0.02)
            if 0 < xf < 1:
                profile(g, "xf_hat", 0.5 + 2 * y, 0.01)
        c = f.create_group("curves/c000")
        c.attrs["set"] = SET
        cols = {"x_f": [0.0, 0.5, 1.0], "dbar_stiff": [0.36, 0.37, NAN], "dbar_floppy": [NAN, 0.352, 0.35],
                "dbar_all": [0.36, 0.361, 0.35], "E_s": [NAN, 1.15, NAN], "E_f": [NAN, 1.12, NAN],
                "fab_stiff": [NAN, NAN, NAN], "fab_floppy": [NAN, NAN, NAN]}
        for k, v in cols.items():
            c[k] = np.asarray(v, float)
            if k != "x_f":
                c[k + "_se"] = np.full(3, 0.001)
    why = "the steady window is shorter than the horizon 100 (test)"
    summary = {"groups": [{"id": "g%03d" % i, "contact": {"events_per_strain": 10.0 * (i + 1)},
                           "species": {sp: {"f_AB": {"value": None, "se": None, "reason": why}}
                                       for sp in ("stiff", "floppy")}} for i in range(3)]}
    with open(os.path.join(d, "summary.json"), "w") as fh:
        json.dump(summary, fh)


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: test_reproduction_claims.py WORKDIR")
    work = os.path.abspath(sys.argv[1])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    write(work)
    p = subprocess.run([sys.executable, TOOL, work], capture_output=True, text=True)
    if p.returncode != 0:
        fail("the tool exited %d: %s" % (p.returncode, p.stderr))
    out = p.stdout
    expect = [
        "plateau from 150 / 150 / 150 (X_f = 0 / 0.5 / 1) | agrees: steady by 150, at or before 500",
        "| 0.3600 ± 0.0010 vs 0.3500 ± 0.0010 | agrees (z = 7.1) |",
        "d-bar of the floppy increases with X_f (501-503) | 0.3500 ± 0.0010 (1) vs 0.3520 ± 0.0010 (0.5) | "
        "opposite direction, z = -1.4 |",
        "| mean v'_p over 0.1-0.5H: 0.0200 ± 0.0002 (mixture) vs 0.0400 ± 0.0002 (pure) | **disagrees** (z = -63.2) |",
        "| crossings at y/H = 0.250 | agrees (within 0.05H) |",
        "| f_AB (1033-1063) | - | not computed: %s |" % "the steady window is shorter than the horizon 100 (test)",
        "| 0.5 | [300, 600] | 0.3700 ± 0.0010 | 0.3520 ± 0.0010 | 0.3610 ± 0.0010 | 1.150 ± 0.001 | 1.120 ± 0.001 "
        "| - | - | 20.0 |",
    ]
    for e in expect:
        if e not in out:
            fail("expected in the output:\n  %s\noutput:\n%s" % (e, out))

    doc = os.path.join(work, "doc.md")
    with open(doc, "w") as fh:
        fh.write("# page\n\n<!-- claims:begin -->\n%s<!-- claims:end -->\n\nmore\n" % out)
    if subprocess.run([sys.executable, TOOL, work, "--check", doc], capture_output=True).returncode != 0:
        fail("--check refused the document holding the tool's own output")
    with open(doc, "w") as fh:
        fh.write("<!-- claims:begin -->\n%s<!-- claims:end -->\n" % out.replace("0.3600 ± 0.0010", "0.3601 ± 0.0010"))
    r = subprocess.run([sys.executable, TOOL, work, "--check", doc], capture_output=True, text=True)
    if r.returncode != 1 or "differ" not in r.stdout:
        fail("--check passed a document with a changed digit (exit %d)" % r.returncode)
    print("claims tool: verdicts and --check as expected")

    # The page itself: docs/reproduction.md's tables are the tool's output on the committed analysis.
    root = os.path.dirname(os.path.dirname(HERE))
    analysis = os.path.join(root, "docs", "figures", "reproduction", "steady")
    r = subprocess.run([sys.executable, TOOL, analysis, "--check", os.path.join(root, "docs", "reproduction.md")],
                       capture_output=True, text=True)
    if r.returncode != 0:
        fail("docs/reproduction.md's claims tables differ from tools/reproduction_claims.py on %s (regenerate them "
             "and paste between the markers):\n%s%s" % (analysis, r.stdout, r.stderr))
    print("docs/reproduction.md: its tables are the tool's on the committed analysis")
    return 0


if __name__ == "__main__":
    sys.exit(main())
