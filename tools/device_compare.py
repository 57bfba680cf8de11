#!/usr/bin/env python3
"""Compares two capsflow run files record by record (tools/device-check.sh: the embedded demo on the device against
the serial run made at pack time) and says how long their series stay together.

    python3 tools/device_compare.py REFERENCE.h5 OTHER.h5

For each series (/series/centroid, velocity, taylor_D, volume) it prints, per record, the largest difference over
capsules relative to the series' scale (the capsule radius for centroids, the largest reference magnitude for the
others), and the last strain up to which that stays below 1e-10, 1e-6 and 1e-3. Records are matched by index and must
have the same strain to 1e-9 relative (round-off moves it in the last bits; the step sizes follow the state, so a
diverged run shows as different times: reported, then the compare stops there). Exit status 0 whenever both files could be read: this measures, it does not judge.
"""
import sys

import h5py
import numpy as np

LEVELS = (1e-10, 1e-6, 1e-3)
SERIES = ("centroid", "velocity", "taylor_D", "volume")


def main(argv):
    if len(argv) != 3:
        print(__doc__)
        return 2
    with h5py.File(argv[1], "r") as a, h5py.File(argv[2], "r") as b:
        ta, tb = a["series/time"][:], b["series/time"][:]
        n = min(len(ta), len(tb))
        # Round-off moves a record's strain in the last bits (the step sizes follow the state): records match while
        # their strains agree to 1e-9 relative; a larger difference is a step size that differed.
        same = np.nonzero(np.abs(ta[:n] - tb[:n]) > 1e-9 * np.maximum(np.abs(ta[:n]), 1.0))[0]
        if len(same):
            print(f"record times differ from record {same[0]} (strain {ta[same[0]]:.6g} vs {tb[same[0]]:.6g}): "
                  f"a step size differed; compared up to there")
            n = int(same[0])
        radius = float(np.max(a["capsules/radius"][:])) if "capsules/radius" in a else 1.0
        print(f"records compared: {n} (strain {ta[0]:.4g} .. {ta[n - 1]:.4g}), reference {argv[1]}, other {argv[2]}")
        for name in SERIES:
            key = "series/" + name
            if key not in a or key not in b:
                continue
            ra, rb = a[key][:n], b[key][:n]
            scale = radius if name == "centroid" else max(float(np.max(np.abs(ra))), 1e-300)
            diff = np.abs(rb - ra).reshape(n, -1).max(axis=1) / scale
            together = []
            for level in LEVELS:
                bad = np.nonzero(diff > level)[0]
                together.append(f"{ta[n - 1] if len(bad) == 0 else (ta[bad[0] - 1] if bad[0] > 0 else 0.0):.4g}")
            print(f"{name:10s} max rel diff {diff.max():.2e} (last record {diff[-1]:.2e}); together to strain "
                  + ", ".join(f"{lvl:g}: {t}" for lvl, t in zip(LEVELS, together)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
