#!/usr/bin/env python3
"""d-bar(t) per species of one run in consecutive strain blocks (docs/reproduction.md, claim 3: set A at X_f = 0.2).

    python3 tools/dbar_blocks.py RUN.h5 [--block 100] [--from 0] [--to END] [--csv OUT.csv]

d_i = |y_c,i - H/2| / (H/2) per capsule (docs/analysis.md, d-bar); each block's mean over its records, per species
and for all capsules, and the standard deviation of the block means after --from (a spread between blocks, not a
standard error: consecutive blocks of one run are correlated). --csv writes the blocks (the file
tools/reproduction_claims.py reads for claim 3: docs/figures/reproduction/set_a_xf0.2_dbar_blocks.csv). Reads a run
that is still being written (HDF5 file locking off for this read-only open).
"""
import argparse
import os
import tomllib

os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")
import h5py  # noqa: E402
import numpy as np  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run")
    ap.add_argument("--block", type=float, default=100.0)
    ap.add_argument("--from", dest="start", type=float, default=0.0, help="first strain of the spread's blocks")
    ap.add_argument("--to", type=float, default=None)
    ap.add_argument("--csv", help="write the blocks here (strain_from, strain_to, records, one column per species, all)")
    a = ap.parse_args()
    with h5py.File(a.run, "r") as f:
        t = f["/series/time"][:]
        c = f["/series/centroid"][: len(t)]
        sp = f["/capsules/species"][:]
        names = f["/capsules/species"].attrs["names"]
        names = (names.decode() if isinstance(names, bytes) else str(names)).split(",")
        cfg = f["/parameters/config"][()]
        cfg = cfg.decode() if isinstance(cfg, bytes) else str(cfg)
    half = tomllib.loads(cfg)["domain"]["H"] / 2
    d = np.abs(c[:, :, 1] - half) / half
    series = {n: d[:, sp == k].mean(axis=1) for k, n in enumerate(names) if (sp == k).any()}
    series["all"] = d.mean(axis=1)
    end = a.to if a.to is not None else t[-1]
    counts = ", ".join(f"{n} {(sp == k).sum()}" for k, n in enumerate(names))
    print(f"{a.run}: {len(t)} records, strain {t[0]:.1f} .. {t[-1]:.1f}; capsules: {counts}")
    print(f"{'block':>13} " + " ".join(f"{n:>8}" for n in series))
    means = {n: [] for n in series}
    rows = []
    lo = 0.0
    while lo + a.block <= end + 1e-9:
        m = (t >= lo) & (t < lo + a.block)
        if m.any():
            row = {n: float(s[m].mean()) for n, s in series.items()}
            print(f"{lo:6.0f}-{lo + a.block:6.0f} " + " ".join(f"{row[n]:8.4f}" for n in series))
            rows.append((lo, lo + a.block, int(m.sum()), row))
            if lo >= a.start:
                for n in series:
                    means[n].append(row[n])
        lo += a.block
    if a.csv:
        tmp = a.csv + ".tmp"
        with open(tmp, "w") as out:
            out.write(f"# d-bar per 100-strain block of {os.path.basename(os.path.dirname(os.path.abspath(a.run)))}, "
                      f"strain {t[0]:.1f} .. {t[-1]:.1f} (tools/dbar_blocks.py)\n")
            out.write("strain_from,strain_to,records," + ",".join(series) + "\n")
            for lo_, hi_, cnt, row in rows:
                out.write(f"{lo_:g},{hi_:g},{cnt}," + ",".join(f"{row[n]:.5f}" for n in series) + "\n")
        os.replace(tmp, a.csv)
    k = len(means["all"])
    if k >= 2:
        print(f"over the {k} blocks from {a.start:g}: mean " +
              ", ".join(f"{n} {np.mean(v):.4f}" for n, v in means.items()) + "; spread of block means (SD) " +
              ", ".join(f"{n} {np.std(v, ddof=1):.4f}" for n, v in means.items()))


if __name__ == "__main__":
    main()
