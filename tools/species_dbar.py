# d-bar(t)/(H/2) per species of a capsflow run file (d_i = |y_c - H/2|, docs/analysis.md §5): CSV and PNG.
# Usage: python3 tools/species_dbar.py RUN.h5 OUT_PREFIX   (docs/presets.md, the blood preset's short run)
import sys, h5py, numpy as np
import matplotlib; matplotlib.use("Agg"); import matplotlib.pyplot as plt
f = h5py.File(sys.argv[1], "r")
t = f["/series/time"][:]; c = f["/series/centroid"][:len(t)]
sp = f["/capsules/species"][:]; names = f["/capsules/species"].attrs["names"]
names = (names.decode() if isinstance(names, bytes) else str(names)).split(",")
import tomllib
H = None
cfg = f["/parameters/config"][()]
cfg = cfg.decode() if isinstance(cfg, bytes) else str(cfg)
H = tomllib.loads(cfg)["domain"]["H"]
d = np.abs(c[:, :, 1] - H / 2) / (H / 2)
out = open(sys.argv[2] + ".csv", "w"); out.write("strain," + ",".join("dbar_" + n for n in names) + "\n")
series = {n: d[:, sp == k].mean(axis=1) for k, n in enumerate(names)}
for i in range(len(t)): out.write("%.4f," % t[i] + ",".join("%.5f" % series[n][i] for n in names) + "\n")
fig, ax = plt.subplots(figsize=(6, 4))
for n in names: ax.plot(t, series[n], label="%s (%d)" % (n, (sp == names.index(n)).sum()))
ax.set_xlabel("strain $\\dot\\gamma_w t$"); ax.set_ylabel("$\\bar d / (H/2)$, $d = |y_c - H/2|$")
ax.set_title(sys.argv[1].split("/")[-1]); ax.legend(); fig.tight_layout()
fig.savefig(sys.argv[2] + ".png", dpi=110)
for n in names: print(n, "start %.4f end %.4f" % (series[n][0], series[n][-1]), "min %.4f max %.4f" % (series[n].min(), series[n].max()))
