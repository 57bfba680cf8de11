#!/usr/bin/env python3
"""capsflow flow's picture: the fluid velocity of a frame on a plane, from the FLOW.h5 that `capsflow flow` writes.

    capsflow_flow.py FLOW.h5 FLOW.png

Two panels over the plane's grid (axes in a, velocities in gammadot a): (a) the velocity along x with the streamlines
of its in-plane components; (b) the disturbance u - u_inf (what the capsules add to the imposed flow), its in-plane
magnitude with its streamlines. The capsules cut by the plane are shaded (FLOW.h5's /capsule >= 0). Usually run by
`capsflow flow` (src/host/cli/flow_command.cpp), which finds this file and a python3 with matplotlib and h5py.
The PNG is written to a temporary name beside FLOW.png and renamed, so a reader never sees half a picture.
Exit status: 0 drawn; 2 bad input, one line "capsflow: error: ..." on stderr.
"""

import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

AXES = "xyz"


def fail(message):
    print("capsflow: error: %s" % message, file=sys.stderr)
    sys.exit(2)


def attr(f, name):
    v = f.attrs[name]
    return v.decode() if isinstance(v, bytes) else v


def read(path):
    """The plane's grid and fields, shaped (nv, nu)."""
    with h5py.File(path, "r") as f:
        if attr(f, "format") != "capsflow-flow" or not attr(f, "plane"):
            fail("%s: expected the FLOW.h5 of `capsflow flow --plane`" % path)
        nu, nv = int(f.attrs["nu"]), int(f.attrs["nv"])
        iu, iv = AXES.index(attr(f, "axis_u")), AXES.index(attr(f, "axis_v"))
        pts = f["points"][:].reshape(nv, nu, 3)
        d = {"u": pts[0, :, iu], "v": pts[:, 0, iv], "iu": iu, "iv": iv,
             "vel": f["velocity"][:].reshape(nv, nu, 3), "dist": f["disturbance"][:].reshape(nv, nu, 3),
             "capsule": f["capsule"][:].reshape(nv, nu),
             "title": "%s, frame %d (strain %.4g): plane %s" % (
                 os.path.basename(attr(f, "source")), int(f.attrs["frame"]), float(f.attrs["strain"]),
                 attr(f, "plane"))}
    return d


def panel(ax, d, field, colour, label, cmap):
    u, v = d["u"], d["v"]
    m = ax.pcolormesh(u, v, colour, shading="auto", cmap=cmap)
    plt.colorbar(m, ax=ax, label=label)
    fu, fv = field[:, :, d["iu"]], field[:, :, d["iv"]]
    if np.all(np.isfinite(fu)) and np.all(np.isfinite(fv)) and np.hypot(fu, fv).max() > 0:
        ax.streamplot(u, v, fu, fv, color="k", linewidth=0.6, density=1.2, arrowsize=0.7)
    inside = (d["capsule"] >= 0).astype(float)
    if inside.any():
        ax.contourf(u, v, inside, levels=[0.5, 1.5], colors=["0.5"], alpha=0.35)
        ax.contour(u, v, inside, levels=[0.5], colors=["0.2"], linewidths=0.8)
    ax.set_xlabel("%s / a" % AXES[d["iu"]])
    ax.set_ylabel("%s / a" % AXES[d["iv"]])
    ax.set_aspect("equal")
    ax.set_xlim(u[0], u[-1])
    ax.set_ylim(v[0], v[-1])


def main(argv):
    if len(argv) != 3:
        fail("usage: capsflow_flow.py FLOW.h5 FLOW.png")
    src, out = argv[1], argv[2]
    try:
        d = read(src)
    except (OSError, KeyError) as e:
        fail("%s: cannot read it as capsflow flow's output (%s)" % (src, e))
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    panel(axes[0], d, d["vel"], d["vel"][:, :, 0], r"$u_x$ / ($\dot\gamma a$)", "viridis")
    axes[0].set_title("(a) velocity, streamlines in the plane", fontsize=10)
    dist = d["dist"]
    mag = np.hypot(dist[:, :, d["iu"]], dist[:, :, d["iv"]])
    panel(axes[1], d, dist, mag, r"$|u - u_\infty|$ in the plane / ($\dot\gamma a$)", "magma")
    axes[1].set_title(r"(b) disturbance $u - u_\infty$ (the capsules' share)", fontsize=10)
    fig.suptitle(d["title"] + "; shaded: inside a capsule", fontsize=10)
    fig.tight_layout()
    tmp = os.path.join(os.path.dirname(os.path.abspath(out)), ".%s.tmp.%d" % (os.path.basename(out), os.getpid()))
    try:
        fig.savefig(tmp, format="png", dpi=130, metadata={"Software": None})
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
