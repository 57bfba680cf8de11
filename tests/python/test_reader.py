#!/usr/bin/env python3
"""The Python reader (python/capsflow) against a real run and its analysis.

A tiny run (4 capsules of mesh level 1, two species, to strain 1: about 2 s on one core) is made with the built
capsflow, then `capsflow analyze`; both are opened with the package and checked against what they must be: counts
and shapes, the configuration written, the frames against the series (volume, centroid, zero volume rate of the
node velocities), d-bar and phi-hat of the analysis recomputed from the run's series with the definitions of
docs/analysis.md, and the errors for missing, foreign and too-new files.

    tests/python/test_reader.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it (exit 77: skipped)
    python3 -m unittest discover -s tests/python -p 'test_reader.py'
                             # binary from $CAPSFLOW_BINARY, else build/release/capsflow; a temporary work dir
"""

import os
import shutil
import subprocess
import sys
import tempfile
import unittest

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
# CAPSFLOW_READER_INSTALLED=1: test the capsflow that is installed (tests/python/test_pip_install.py), not the source's.
if os.environ.get("CAPSFLOW_READER_INSTALLED") != "1":
    sys.path.insert(0, os.path.join(SOURCE_DIR, "python"))

try:
    import numpy as np
    import h5py
    MISSING = None
except ImportError as e:  # pragma: no cover - depends on the machine
    MISSING = str(e)

if MISSING is None:
    import capsflow

BINARY = os.environ.get("CAPSFLOW_BINARY") or os.path.join(SOURCE_DIR, "build", "release", "capsflow")
WORKDIR = None       # set by the command line, else a temporary directory

from tiny_run import CA, CENTRES, SPECIES  # noqa: E402  (the shared tiny run: tests/python/tiny_run.py)
import tiny_run  # noqa: E402

H = 6.0
MESH_LEVEL = 1
PROFILE_BINS = 50
END = 1.0

CONFIG = tiny_run.config(END, 0.02, 0.2, H=H, mesh_level=MESH_LEVEL, output_extra="profile_bins = %d\n" % PROFILE_BINS)

_made = {}


def capsflow_cmd(*args):
    r = subprocess.run([BINARY, *args], cwd=WORKDIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    if r.returncode != 0:
        raise AssertionError("capsflow %s: exit status %d\n%s%s" % (" ".join(args), r.returncode, r.stdout, r.stderr))
    return r


def setUpModule():
    global WORKDIR
    if MISSING is not None:
        raise unittest.SkipTest("needs numpy and h5py (%s)" % MISSING)
    if not os.access(BINARY, os.X_OK):
        raise unittest.SkipTest("no capsflow executable at %s (set CAPSFLOW_BINARY)" % BINARY)
    if WORKDIR is None:
        WORKDIR = tempfile.mkdtemp(prefix="capsflow-reader-")
        _made["tmp"] = WORKDIR
    os.makedirs(WORKDIR, exist_ok=True)
    with open(os.path.join(WORKDIR, "tiny.toml"), "w") as fh:
        fh.write(CONFIG)
    capsflow_cmd("run", "tiny.toml", "--threads", "1", "--force", "-q")
    capsflow_cmd("analyze", "tiny.h5", "--out", "analysis", "--force", "-q")


def tearDownModule():
    if "tmp" in _made:
        shutil.rmtree(_made["tmp"], ignore_errors=True)


def work(*names):
    return os.path.join(WORKDIR, *names)


def mesh_volume_and_centroid(x, tri):
    """Volume and volume centroid of a closed, outward-oriented triangulated surface (tetrahedra on the origin)."""
    a, b, c = x[tri[:, 0]], x[tri[:, 1]], x[tri[:, 2]]
    v = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    return v.sum(), (v[:, None] * (a + b + c) / 4.0).sum(axis=0) / v.sum()


def volume_gradient(x, tri):
    """w_i = dV/dx_i of the polyhedron's volume (the weights of the velocity projection, D11)."""
    a, b, c = x[tri[:, 0]], x[tri[:, 1]], x[tri[:, 2]]
    w = np.zeros_like(x)
    for j, (p, q) in enumerate(((b, c), (c, a), (a, b))):
        np.add.at(w, tri[:, j], np.cross(p, q) / 6.0)
    return w


def block_mean(t, q, t0, t1, blocks=10):
    """docs/analysis.md, "Blocks": records with t0 <= t <= t1, block floor(blocks (t - t0)/(t1 - t0)) (the record at
    t1 in the last one), the estimate the mean of the block means over blocks that hold records."""
    inw = (t >= t0) & (t <= t1)
    b = np.minimum(np.floor(blocks * (t[inw] - t0) / (t1 - t0)).astype(int), blocks - 1)
    return np.mean([q[inw][b == k].mean() for k in range(blocks) if np.any(b == k)])


class RunReader(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = capsflow.open_run(work("tiny.h5"))

    @classmethod
    def tearDownClass(cls):
        cls.out.close()

    def test_counts_and_shapes(self):
        r = self.out
        nv, nt = 10 * 4 ** MESH_LEVEL + 2, 20 * 4 ** MESH_LEVEL     # icosphere of this level
        np_, ns = len(CENTRES), 2
        T = r.n_records
        self.assertGreater(T, 10)
        self.assertEqual(r.n_capsules, np_)
        self.assertEqual(r.nodes_per_capsule, nv)
        for name, shape in (("time", (T,)), ("step", (T,)), ("dt", (T,)), ("centroid", (T, np_, 3)),
                            ("velocity", (T, np_, 3)), ("taylor_D", (T, np_)), ("volume", (T, np_)),
                            ("area", (T, np_)), ("profile", (T, ns, PROFILE_BINS)), ("step_limits", (T, 5)),
                            ("flow_rate_ratio", (T,))):
            self.assertEqual(getattr(r.series, name).shape, shape, name)
        self.assertEqual(r.series.profile_bin_edges.shape, (PROFILE_BINS + 1,))
        self.assertEqual(r.triangles.shape, (nt, 3))
        self.assertEqual(r.triangles_all.shape, (np_ * nt, 3))
        np.testing.assert_array_equal(r.node_capsule, np.repeat(np.arange(np_), nv))
        np.testing.assert_array_equal(r.triangles_all, np.concatenate([r.triangles + k * nv for k in range(np_)]))
        self.assertEqual(len(r.frames), int(END / 0.2 + 1e-9) + 1)   # frames at 0, 0.2, ..., 1
        f = r.frames[-1]
        self.assertEqual(f.positions.shape, (np_ * nv, 3))
        self.assertEqual(f.velocity.shape, (np_ * nv, 3))
        self.assertEqual(f.index, len(r.frames) - 1)
        with self.assertRaises(IndexError):
            r.frames[len(r.frames)]
        self.assertEqual(r.events.time.shape[0], r.events.capsules.shape[0])
        self.assertEqual(r.species_names, ["stiff", "floppy"])

    def test_every_documented_dataset_is_read(self):
        """The layout table of docs/output_format.md, row by row: each dataset of this file's format is an array of
        the package with the documented rank (a frame's arrays one less: one frame)."""
        rows = []
        with open(os.path.join(SOURCE_DIR, "docs", "output_format.md"), encoding="utf-8") as fh:
            for line in fh:
                cells = [c.strip() for c in line.strip().strip("|").split("|")]
                if line.startswith("| `/") and len(cells) >= 5 and cells[3].isdigit():
                    rows.append((cells[0].strip("`"), cells[1], int(cells[3])))
        self.assertGreater(len(rows), 20)
        r = self.out
        frame = r.frames[0]
        for path, shape, since in rows:
            if since > r.format_version:
                continue
            group, name = path[1:].split("/", 1)
            rank = 0 if shape == "scalar" else shape.count(",") + 1
            if group == "parameters":
                self.assertIsInstance(r.config, dict)
                continue
            if group in ("series", "events"):
                value = getattr(getattr(r, group), name)
            elif group == "frames":
                value = r.frames.time if name == "time" else getattr(frame, name)
                rank -= 0 if name == "time" else 1
            else:                                        # capsules, mesh
                value = getattr(r, name)
            self.assertEqual(np.ndim(value), rank, path)

    def test_strain_increases(self):
        s = self.out.series
        self.assertEqual(s.time[0], 0.0)
        self.assertTrue(np.all(np.diff(s.time) > 0))
        self.assertTrue(np.all(np.diff(s.step) > 0))
        self.assertGreaterEqual(s.time[-1], END)                  # the last record is the first step at or past END
        self.assertLess(s.time[-1], END + 0.2)
        self.assertTrue(np.all(np.diff(self.out.frames.time) > 0))

    def test_species_and_ca_follow_the_config(self):
        r = self.out
        self.assertEqual(r.capsule_species, SPECIES)
        np.testing.assert_array_equal(r.ca, [CA[s] for s in SPECIES])
        np.testing.assert_array_equal(r.capsules_of("floppy"), [i for i, s in enumerate(SPECIES) if s == "floppy"])
        self.assertFalse(r.pinned.any())
        # Node species follow their capsules.
        np.testing.assert_array_equal(r.node_species, r.species[r.node_capsule])
        with self.assertRaises(KeyError):
            r.capsules_of("medium")

    def test_parameters_round_trip(self):
        r = self.out
        self.assertEqual(r.H, H)
        self.assertEqual(r.config["domain"]["H"], H)
        self.assertEqual(r.config["capsules"]["mesh_level"], MESH_LEVEL)
        self.assertEqual(r.config["time"]["end"], END)
        self.assertEqual(r.config["output"]["profile_bins"], PROFILE_BINS)
        self.assertEqual(len(r.config["capsule"]), len(CENTRES))
        self.assertEqual([c["center"] for c in r.config["capsule"]], CENTRES)
        self.assertEqual({s["name"]: s["ca"] for s in r.config["species"]}, CA)
        self.assertIn("cfl", r.config["time"])                     # the stored configuration is the resolved one
        self.assertEqual(r.format_version, capsflow.run.FORMAT_VERSION)
        self.assertTrue(r.run_id)
        self.assertIn("grid_nx", r.info)
        # The first record is the initial state: undeformed capsules centred where the configuration put them.
        np.testing.assert_allclose(r.series.centroid[0], CENTRES, rtol=0, atol=1e-12)

    def test_frames_agree_with_the_series(self):
        r = self.out
        t = r.series.time
        L = np.array([r.Lx, np.inf, r.Lz])
        for f in r.frames:
            i = int(np.argmin(np.abs(t - f.time)))
            self.assertEqual(t[i], f.time, "a frame is taken at a record's step")
            for k in range(r.n_capsules):
                x, u, tri = f.capsule(k)
                # The centroid's y is the mean of the frame's node heights within mesh accuracy (level 1,
                # deformation D ~ 0.1: 1e-3 a measured; the node mean is not the volume centroid) ...
                self.assertLess(abs(x[:, 1].mean() - r.series.centroid[i, k, 1]), 0.01, (f.index, k))
                # ... and exactly the volume centroid of the frame's polyhedron; in x and z up to whole periods
                # (frames are shifted into the box, the series unwrapped).
                vol, cen = mesh_volume_and_centroid(x, tri)
                self.assertAlmostEqual(vol, r.series.volume[i, k], delta=1e-12 * vol)
                shift = (cen - r.series.centroid[i, k]) / np.where(np.isinf(L), 1.0, L)
                np.testing.assert_allclose(shift[[0, 2]], np.round(shift[[0, 2]]), rtol=0, atol=1e-12)
                self.assertAlmostEqual(cen[1], r.series.centroid[i, k, 1], delta=1e-12 * H)
                # The node velocities are those after the zero-volume-rate projection (D11): sum w_i . u_i = 0.
                w = volume_gradient(x, tri)
                self.assertLess(abs(np.sum(w * u)), 1e-12 * np.abs(w).sum() * np.abs(u).max(), (f.index, k))

    def test_units_and_membrane_fields(self):
        """Format 5: every dataset names its units; the first frame holds the pre-inflated spheres (default inflation
        beta = 0.1, neo-Hookean), whose principal tensions (single precision) are both Gs (1 - (1 + beta)^-6) with Gs = a / Ca, and
        whose traction jump points outward with Laplace's mean 2T/a."""
        r = self.out
        self.assertEqual(r.units("series/centroid"), "a")
        self.assertEqual(r.units("series/time"), "1/gammadot")
        self.assertEqual(r.units("frames/velocity"), "gammadot a")
        self.assertEqual(r.units("frames/traction_jump"), "mu gammadot")
        f = r.frames[0]
        self.assertEqual(f.time, 0.0)
        nv = r.nodes_per_capsule
        for k in range(r.n_capsules):
            gs = r.radius / r.ca[k]
            T = gs * (1.0 - 1.1 ** -6)
            s = slice(k * nv, (k + 1) * nv)
            # stored in single precision: float32 rounding (6e-8) plus the double computation's round-off
            np.testing.assert_allclose(f.tension_max[s], T, rtol=2e-7)
            np.testing.assert_allclose(f.tension_min[s], T, rtol=2e-7)
            np.testing.assert_allclose(f.energy_density[s], 0.5 * gs * (2 * 1.1 ** 2 - 3 + 1.1 ** -4), rtol=2e-7)
            n = f.positions[s] - f.positions[s].mean(axis=0)
            n /= np.linalg.norm(n, axis=1)[:, None]
            tn = np.sum(f.traction_jump[s] * n, axis=1)
            self.assertTrue(np.all(tn > 0), k)
            self.assertLess(abs(tn.mean() / (2 * T / r.radius) - 1), 0.05, k)  # level 1: lumping error ~ a few %

    def test_profile_holds_the_capsule_volumes(self):
        s = self.out.series
        # Capsules inside the slit: the slabs of each species add up to the species' volume at every record.
        for sp in range(self.out.n_species):
            np.testing.assert_allclose(s.profile[:, sp, :].sum(axis=1),
                                       s.volume[:, self.out.species == sp].sum(axis=1), rtol=1e-12)


class AnalysisReader(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = capsflow.open_run(work("tiny.h5"))
        cls.an = capsflow.open_analysis(work("analysis"))
        cls.group = cls.an.suspension_groups()[0]

    @classmethod
    def tearDownClass(cls):
        cls.out.close()

    def test_layout(self):
        an, g = self.an, self.group
        self.assertEqual(len(an.groups), 1)
        self.assertEqual(g.kind, "suspension")
        self.assertEqual(g.x_f, 0.5)
        self.assertEqual(g.H, H)
        self.assertEqual(g.runs, ["tiny.h5"])
        self.assertEqual((g.ca_stiff, g.ca_floppy), (CA["stiff"], CA["floppy"]))
        self.assertEqual(an.bins, 25)
        np.testing.assert_allclose(g.y_over_H, (np.arange(an.bins) + 0.5) / (2 * an.bins), rtol=1e-14)
        self.assertIs(an.curve(g.set), an.curves[0])
        self.assertEqual(an.group("g000"), g)
        self.assertIsNotNone(an.summary)
        with self.assertRaises(KeyError) as cm:
            g.profile("dv_rel", "stiff")        # no pure group in this analysis: no relative change
        self.assertIn("phi_hat_stiff", str(cm.exception))

    def test_window_is_the_second_half(self):
        t0, t1 = self.group.window
        t = self.out.series.time
        self.assertEqual(t1, t[-1])
        self.assertAlmostEqual(t0, 0.5 * (t[0] + t[-1]), delta=1e-12)

    def test_dbar_time_series_is_the_mean_centreline_distance(self):
        d = self.out.centreline_distance() / (0.5 * H)           # [T, Np] d_i/(H/2)
        ts = self.group.dbar_t
        np.testing.assert_array_equal(ts.time, self.out.series.time)
        for name in ("stiff", "floppy"):
            np.testing.assert_allclose(getattr(ts, name), d[:, self.out.capsules_of(name)].mean(axis=1),
                                       rtol=1e-13, atol=0)
        np.testing.assert_allclose(ts.all, d.mean(axis=1), rtol=1e-13, atol=0)

    def test_steady_dbar_is_the_block_mean_over_the_window(self):
        t0, t1 = self.group.window
        t = self.out.series.time
        d = self.out.centreline_distance() / (0.5 * H)
        for name, cols in (("stiff", self.out.capsules_of("stiff")), ("floppy", self.out.capsules_of("floppy")),
                           ("all", np.arange(self.out.n_capsules))):
            per_record = d[:, cols].mean(axis=1)
            expected = block_mean(t, per_record, t0, t1)
            est = self.group.dbar[name]
            self.assertAlmostEqual(est.value, expected, delta=1e-13, msg=name)
            # The block rule is not the plain mean over the records here (blocks hold 1 or 2 records) ...
            inw = (t >= t0) & (t <= t1)
            self.assertNotEqual(est.value, per_record[inw].mean())
            # ... but no further from it than the spread of the series allows.
            self.assertLess(abs(est.value - per_record[inw].mean()), np.ptp(per_record[inw]))
            # A dozen records in the window are too few for an SE of correlated records (docs/analysis.md, "Errors
            # of correlated series"): null, with the reason, not a small number.
            self.assertTrue(np.isnan(est.se), name)
            self.assertIn("not estimable", est.reason, name)
        # The same numbers as summary.json (printed there to 10 digits).
        js = {e["id"]: e for e in self.an.summary["groups"]}[self.group.id]["species"]
        for name in ("stiff", "floppy", "all"):
            self.assertAlmostEqual(self.group.dbar[name].value, js[name]["dbar"]["value"], delta=1e-9)
            self.assertIsNone(js[name]["dbar"]["se"])
            self.assertIn(js[name]["dbar"]["halves"]["verdict"].split(":")[0], ("steady", "not steady", "not judged"))

    def test_undefined_estimates_carry_the_reason(self):
        fab = self.group.f_AB["stiff"]
        self.assertTrue(np.isnan(fab.value))
        self.assertIn("horizon", fab.reason)      # a window of 0.5 strain is shorter than the f_AB horizon of 100

    def test_phi_hat_from_the_recorded_slabs(self):
        """phi-hat_X(k) = bins S_k / V (docs/analysis.md), S_k the volume in the two slabs of folded bin k summed
        over the window's records; 50 slabs fold exactly onto 25 bins."""
        t0, t1 = self.group.window
        s = self.out.series
        inw = (s.time >= t0) & (s.time <= t1)
        nb = self.an.bins
        for sp, name in enumerate(self.out.species_names):
            slabs = s.profile[inw, sp, :].sum(axis=0)             # [50]
            per_half = slabs.reshape(2, -1)                       # [0, H/2] and [H/2, H]
            S = (per_half[0] + per_half[1][::-1]).reshape(nb, -1).sum(axis=1)
            expected = nb * S / S.sum()
            p = self.group.profile("phi_hat", name)
            np.testing.assert_allclose(p.value, expected, rtol=1e-12, atol=1e-14)
            self.assertAlmostEqual(p.value.sum() / nb, 1.0, delta=1e-12)    # (2/H) sum phi-hat dy = 1
            self.assertFalse(p.masked.any())
            n = self.group.profile("n_hat", name)
            self.assertAlmostEqual(n.value.sum() / nb, 1.0, delta=1e-12)

    def test_curves_hold_the_group(self):
        c = self.an.curve(self.group.set)
        np.testing.assert_array_equal(c.x_f, [0.5])
        self.assertEqual(c.dbar_stiff[0], self.group.dbar["stiff"].value)
        self.assertAlmostEqual(c.two_a_over_H, 2.0 / H, delta=1e-15)
        self.assertAlmostEqual(c.R, CA["floppy"] / CA["stiff"], delta=1e-15)


class Errors(unittest.TestCase):
    def copy(self, src, name):
        dst = work("errors", name)
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        shutil.copyfile(src, dst)
        return dst

    def assertNames(self, cm, *parts):
        for p in parts:
            self.assertIn(p, str(cm.exception))

    def test_missing_file(self):
        p = work("errors", "nothing.h5")
        with self.assertRaises(FileNotFoundError) as cm:
            capsflow.open_run(p)
        self.assertNames(cm, p, "capsflow run output")
        with self.assertRaises(FileNotFoundError) as cm:
            capsflow.open_analysis(work("errors", "no-such-dir"))
        self.assertNames(cm, "no-such-dir", "analysis")

    def test_directory_without_analysis(self):
        d = work("errors", "empty-dir")
        os.makedirs(d, exist_ok=True)
        with self.assertRaises(FileNotFoundError) as cm:
            capsflow.open_analysis(d)
        self.assertNames(cm, d, "no analysis.h5", "capsflow analyze")

    def test_not_hdf5(self):
        p = self.copy(work("tiny.toml"), "config.h5")
        for opener in (capsflow.open_run, capsflow.open_analysis):
            with self.assertRaises(capsflow.FormatError) as cm:
                opener(p)
            self.assertNames(cm, p, "not an HDF5 file")

    def test_other_kinds_of_capsflow_files(self):
        with self.assertRaises(capsflow.FormatError) as cm:
            capsflow.open_run(work("analysis", "analysis.h5"))
        self.assertNames(cm, "analysis.h5", "open_analysis")
        with self.assertRaises(capsflow.FormatError) as cm:
            capsflow.open_analysis(work("tiny.h5"))
        self.assertNames(cm, "tiny.h5", "capsflow-analysis", "open_run")
        with self.assertRaises(capsflow.FormatError) as cm:
            capsflow.open_run(work("tiny.checkpoint.h5"))
        self.assertNames(cm, "tiny.checkpoint.h5", "checkpoint", "tiny.h5")
        p = work("errors", "other.h5")
        with h5py.File(p, "w") as f:
            f["x"] = np.arange(3)
        with self.assertRaises(capsflow.FormatError) as cm:
            capsflow.open_run(p)
        self.assertNames(cm, p, "/parameters/config", "/series/time")

    def test_newer_format_versions(self):
        p = self.copy(work("tiny.h5"), "future.h5")
        with h5py.File(p, "r+") as f:
            f.attrs["format_version"] = capsflow.run.FORMAT_VERSION + 1
        with self.assertRaises(capsflow.UnsupportedVersionError) as cm:
            capsflow.open_run(p)
        self.assertNames(cm, p, "format %d" % (capsflow.run.FORMAT_VERSION + 1), "newer capsflow")
        p = self.copy(work("analysis", "analysis.h5"), "analysis.h5")
        with h5py.File(p, "r+") as f:
            f.attrs["format_version"] = 2
        with self.assertRaises(capsflow.UnsupportedVersionError) as cm:
            capsflow.open_analysis(p)
        self.assertNames(cm, p, "version 2")
        self.assertTrue(issubclass(capsflow.UnsupportedVersionError, capsflow.FormatError))

    def test_older_format_lacks_new_datasets(self):
        """A format-1 file (no format_version, none of the later datasets) opens; a later dataset is refused by
        name."""
        p = self.copy(work("tiny.h5"), "format1.h5")
        with h5py.File(p, "r+") as f:
            del f.attrs["format_version"]
            for name in ("series/profile", "series/step_limits", "series/max_step_ratio"):
                del f[name]
        with capsflow.open_run(p) as r:
            self.assertEqual(r.format_version, 1)
            self.assertNotIn("profile", r.series)
            self.assertEqual(r.series.centroid.shape[1], len(CENTRES))
            with self.assertRaises(AttributeError) as cm:
                r.series.profile
            self.assertNames(cm, "/series/profile", "format 1", "since format 2")

    def test_records_are_cut_to_the_shortest_series(self):
        """A live run's file may hold one dataset a record ahead of another: whole records only."""
        p = self.copy(work("tiny.h5"), "live.h5")
        with h5py.File(p, "r+") as f:
            T = f["series/time"].shape[0]
            f["series/velocity"].resize(T - 1, axis=0)
        with capsflow.open_run(p) as r:
            self.assertEqual(r.n_records, T - 1)
            self.assertEqual(r.series.time.shape, (T - 1,))
            self.assertEqual(r.series.centroid.shape[0], T - 1)

    def test_closed_run(self):
        with capsflow.open_run(work("tiny.h5")) as r:
            pass
        with self.assertRaises(ValueError):
            r.series.time


def main(argv):
    global BINARY, WORKDIR
    if MISSING is not None:
        print("SKIP: the Python reader tests need numpy and h5py (%s)" % MISSING)
        return SKIP
    if len(argv) >= 2:
        BINARY = os.path.abspath(argv[1])
    if len(argv) >= 3:
        WORKDIR = os.path.abspath(argv[2])
    if not os.access(BINARY, os.X_OK):
        print("capsflow executable not found: %s" % BINARY, file=sys.stderr)
        return 1
    prog = unittest.main(argv=[argv[0]], exit=False, verbosity=2)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
