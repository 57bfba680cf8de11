"""A `capsflow run` output (OUT.h5) as named numpy arrays.

Layout: docs/output_format.md. Units (docs/usage.md): lengths in the capsule radius a (the unit of [domain]),
times in strain units 1/gammadot (gammadot = [flow] shear_rate, the wall shear rate in Poiseuille flow),
velocities in gammadot a. Shapes: T records, Np capsules, Ns species, B profile slabs, F frames, Nn = Np nv nodes
(nv per capsule), Nt triangles per capsule, E contact events.

Series are read on first use and cut to the shortest per-record dataset, so the file of a run that is still writing
reads as whole records (the run flushes after every record; datasets of one record differ by at most that record).
A read that meets the file between two of the run's writes is tried again while the file changes
(_files.read_consistently); a file that does not change and cannot be read, or holds datasets of other shapes than
the layout's, is malformed: capsflow.FormatError naming the file and the path in it. Frames are read one at a time,
on demand.
"""

import os
import re

import numpy as np
from h5py import Dataset as h5py_Dataset

from ._files import MALFORMED, FormatError, UnsupportedVersionError, attrs_dict, describe, open_h5, read_consistently, text

try:
    import tomllib as _toml
except ImportError:  # Python < 3.11
    try:
        import tomli as _toml
    except ImportError:
        _toml = None

#: The newest output format this reader knows (docs/output_format.md, "Format versions").
FORMAT_VERSION = 6

_WHAT = "a capsflow run output (OUT.h5 written by `capsflow run`)"


def _shape_text(shape):
    return "[" + ", ".join("*" if d is None else str(d) for d in shape) + "]"


def _common_extent(path, h5, group, names, empty=None):
    """The number of whole entries of the growing datasets `names` of `group`: the shortest one's. A live run appends
    one record's datasets one after another, so they differ by at most one; more is a damaged file (a dataset cut
    short by hand would otherwise cut every other to its length)."""
    ext = {n: h5["%s/%s" % (group, n)].shape[0] for n in names if "%s/%s" % (group, n) in h5}
    if not ext:
        if empty is not None:
            return empty
        raise FormatError("%s: /%s: expected its datasets (%s), found none" % (path, group, ", ".join(names)))
    lo, hi = min(ext.values()), max(ext.values())
    if hi - lo > 1:
        short = min(ext, key=ext.get)
        raise FormatError("%s: /%s/%s: expected %d or %d entries like the other datasets of /%s (a live run's "
                          "datasets differ by at most the record being written), got %d (a damaged or hand-edited "
                          "file)" % (path, group, short, hi - 1, hi, group, lo))
    return lo


def _store_part_number(name):
    """N of output.part-NNN.h5 (three digits or more: tools/run_store.py's name of a part), else 0."""
    m = re.match(r"^output\.part-(\d{3,})\.h5$", name)
    return int(m.group(1)) if m else 0


def _refuse_run_store_file(path, h5):
    """A file of a run store (tools/run_store.py: a base and append-only parts) is not a run: a part holds a stretch of
    records from mid-way (its /_store group, written by every save), the base with parts beside it the records to the
    first save only. Either would open as a shorter run that looks whole."""
    part = "_store" in h5
    if not part and os.path.basename(path) != "output.h5":
        return  # a store's base is always output.h5: no folder to list
    folder = os.path.dirname(path) or "."
    try:
        parts = sum(1 for n in os.listdir(folder) if _store_part_number(n))
    except OSError:
        parts = 0
    restore = "restore the store with tools/run_store.py restore %s RUN_DIR and open RUN_DIR/output.h5" % folder
    if part:
        meta = h5["_store"].attrs
        k = int(meta["part"]) if "part" in meta else _store_part_number(os.path.basename(path))
        which = "part %d of %d" % (k, parts) if k else "a part"
        start = ", its records from record %d on" % int(meta["series/time"]) if "series/time" in meta else ""
        raise FormatError("%s: %s of a run store (tools/run_store.py%s), not %s: %s"
                          % (path, which, start, _WHAT, restore))
    if parts:
        raise FormatError("%s: the base of a run store with %d part(s) beside it (the records to its first save "
                          "only), not the whole run: %s" % (path, parts, restore))


def _dataset(name, doc, since=1):
    """A read-only attribute that reads dataset `name` of its group the first time it is used."""

    def get(self):
        return self._read(name, since)

    get.__doc__ = doc
    return property(get)


class _Group:
    """Datasets of one HDF5 group, read lazily and cut to a common first extent (`n`; None: as stored)."""

    def __init__(self, run, group, n=None):
        self._run = run
        self._group = group
        self._n = n
        self._cache = {}

    def _read(self, name, since):
        if name not in self._cache:
            path = "%s/%s" % (self._group, name)
            h5 = self._run._file()
            if path not in h5:
                if self._run.format_version < since:
                    raise AttributeError("%s: /%s is not in output format %d (it exists since format %d)"
                                         % (self._run.path, path, self._run.format_version, since))
                raise AttributeError("%s: /%s is missing (expected in output format %d)"
                                     % (self._run.path, path, self._run.format_version))
            n = self._n
            self._cache[name] = self._run._read_data("/" + path, lambda h: h[path][:n] if n is not None else h[path][()])
        return self._cache[name]

    def __contains__(self, name):
        """`"profile" in run.series`: whether the file has that dataset (older formats lack some)."""
        return "%s/%s" % (self._group, name) in self._run._file()


class Series(_Group):
    """The per-record time series (`/series`): T records, the first step at or past each multiple of
    [output] every."""

    time = _dataset("time", "[T] strain of each record (1/gammadot)")
    step = _dataset("step", "[T] step number")
    dt = _dataset("dt", "[T] the last step size (strain; 0 at the start)")
    max_step_ratio = _dataset("max_step_ratio", "[T] largest dt_n/dt_(n-1) since the previous record", 2)
    contact_corrections = _dataset("contact_corrections", "[T] contact pushes so far (pairs + walls)")
    centroid = _dataset("centroid", "[T, Np, 3] capsule centres of mass (a), x and z unwrapped across periods")
    velocity = _dataset("velocity", "[T, Np, 3] volume-averaged capsule velocities (gammadot a), before the pinning "
                                    "correction")
    taylor_D = _dataset("taylor_D", "[T, Np] Taylor deformation (L - B)/(L + B) in the x-y plane")
    inclination = _dataset("inclination", "[T, Np] angle of the long axis from x (radians)")
    volume = _dataset("volume", "[T, Np] enclosed volume (a^3)")
    area = _dataset("area", "[T, Np] membrane area (a^2)")
    profile = _dataset("profile", "[T, Ns, B] interior volume (a^3) of each species in each of B equal slabs of "
                                  "[0, H] (exact for the meshes)", 2)
    flow_rate_ratio = _dataset("flow_rate_ratio", "[T] Poiseuille: flow rate over that of the particle-free slit "
                                                  "(NaN in shear)", 2)
    relative_viscosity = _dataset("relative_viscosity", "[T] shear: wall shear stress over that of the "
                                                        "particle-free slit (NaN in Poiseuille)", 2)
    step_limits = _dataset("step_limits", "[T, 5] steps since the previous record by what set their size "
                                          "(docs/output_format.md)", 4)
    closest_gap = _dataset("closest_gap", "[T] smallest capsule-capsule gap (a) if below the mean edge, else inf", 4)
    wall_gap = _dataset("wall_gap", "[T] smallest node-wall gap (a) if below the mean edge, else inf", 4)
    ab2_error = _dataset("ab2_error", "[T] AB2 truncation proxy (a; NaN before two steps)", 4)
    gmres_iterations = _dataset("gmres_iterations", "[T] viscosity ratio != 1: mean GMRES operator applications per "
                                                    "step since the previous record (0 without the solve)", 6)
    gmres_residual = _dataset("gmres_residual", "[T] viscosity ratio != 1: largest final relative GMRES residual "
                                                "since the previous record (0 without the solve)", 6)

    _NAMES = ("time", "step", "dt", "max_step_ratio", "contact_corrections", "centroid", "velocity", "taylor_D",
              "inclination", "volume", "area", "profile", "flow_rate_ratio", "relative_viscosity", "step_limits",
              "closest_gap", "wall_gap", "ab2_error", "gmres_iterations", "gmres_residual")

    @property
    def profile_bin_edges(self):
        """[B + 1] slab edges of `profile` in y (a), from 0 to H."""
        nb = self.profile.shape[2]
        return np.linspace(0.0, self._run.H, nb + 1)


class Events(_Group):
    """Contact corrections (`/events`, format >= 2): E events."""

    time = _dataset("time", "[E] strain of the step whose contact control made the correction", 2)
    capsules = _dataset("capsules", "[E, 2] capsules (p, q); q = -1: wall y = 0, q = -2: wall y = H", 2)
    gap_before = _dataset("gap_before", "[E] gap before the correction (a; signed surface distance)", 2)
    dy = _dataset("dy", "[E, 2] y-displacement (a) of p and of q by the correction (0 for a wall)", 2)


#: The per-node membrane fields of a frame (format >= 5; None in older files).
_MEMBRANE_FIELDS = ("traction_jump", "tension_max", "tension_min", "energy_density")


class Frame:
    """One mesh frame: node positions and velocities with the triangles of all capsules.

    positions [Nn, 3] (a): each capsule shifted by whole periods so that its node mean lies in the box;
    velocity [Nn, 3] (gammadot a): the node velocities the surface moves with; triangles [Np Nt, 3]: 0-based
    node numbers (outward orientation); node k nv + i belongs to capsule k.
    Format >= 5 (None before): traction_jump [Nn, 3] (mu gammadot), the jump (sigma_out - sigma_in) n of the fluid
    traction across the membrane, n outward; tension_max, tension_min [Nn] (mu gammadot a), the principal Cauchy
    tensions; energy_density [Nn] (mu gammadot a), the strain energy per reference area (the last three averaged
    over the elements at a node with their current areas as weights).
    """

    def __init__(self, run, index, time, positions, velocity, membrane=None):
        self.index = index
        self.time = time
        self.positions = positions
        self.velocity = velocity
        membrane = membrane or {}
        for name in _MEMBRANE_FIELDS:
            setattr(self, name, membrane.get(name))
        self.triangles = run.triangles_all
        self.nodes_per_capsule = run.nodes_per_capsule
        self._local = run.triangles

    def capsule(self, k):
        """(positions [nv, 3], velocity [nv, 3], triangles [Nt, 3] with local node numbers) of capsule k."""
        nv = self.nodes_per_capsule
        s = slice(k * nv, (k + 1) * nv)
        return self.positions[s], self.velocity[s], self._local


class Frames:
    """The mesh frames (`/frames`), read one at a time: `len(run.frames)`, `run.frames.time`, `run.frames[-1]`."""

    def __init__(self, run):
        self._run = run
        h5 = run._file()
        self._n = _common_extent(run.path, h5, "frames", ("time", "positions", "velocity") + _MEMBRANE_FIELDS)
        self.time = h5["frames/time"][: self._n]  # [F] strain of each frame (1/gammadot)

    def __len__(self):
        return self._n

    def __getitem__(self, i):
        if not -self._n <= i < self._n:
            raise IndexError("frame %d of %d (%s)" % (i, self._n, self._run.path))
        i %= self._n

        def read(h5):
            membrane = {n: h5["frames/" + n][i] for n in _MEMBRANE_FIELDS if "frames/" + n in h5}
            return h5["frames/positions"][i], h5["frames/velocity"][i], membrane

        positions, velocity, membrane = self._run._read_data("/frames (frame %d)" % i, read)
        return Frame(self._run, i, float(self.time[i]), positions, velocity, membrane)

    def __iter__(self):
        for i in range(self._n):
            yield self[i]


class Run:
    """An open run output; use `capsflow.open_run(path)`, preferably as a context manager.

    Attributes:
      path, format_version, capsflow_version, run_id
      config           the resolved configuration (nested dict from /parameters/config: config["domain"]["H"])
      info             the attributes of / and /parameters (units, source, grid_nx, grid_nz, grid_ny, cutoff, threads)
      H, Lx, Lz, radius   box and capsule radius (a)
      species_names    [Ns] names in [[species]] order
      species          [Np] species index of each capsule;  ca [Np];  pinned [Np] bool
      triangles        [Nt, 3] triangles of one capsule;  triangles_all [Np Nt, 3];  node_capsule, node_species [Nn]
      series           the time series (Series: series.time, series.centroid, ...)
      frames           the mesh frames (Frames: frames.time, frames[i] -> Frame)
      events           contact events (Events; format >= 2)
    """

    def __init__(self, path):
        self.path = os.fspath(path)
        self._h5 = None

        def attempt():
            self.close()
            self._h5 = open_h5(self.path, _WHAT)
            self._check_and_read_header()

        try:
            read_consistently(self.path, attempt)
        except BaseException:
            self.close()
            raise

    def _read_data(self, what, read):
        """read(h5) of the open file; tried again on a fresh handle while a live run changes the file. `what` names
        the object for the FormatError of a file that does not change."""
        tries = [0]

        def attempt():
            if tries[0]:
                self._h5.close()
                self._h5 = open_h5(self.path, _WHAT)
            tries[0] += 1
            try:
                return read(self._file())
            except FormatError:
                raise
            except MALFORMED as e:
                if isinstance(e, (FileNotFoundError, PermissionError)):
                    raise
                raise FormatError("%s: %s cannot be read (%s)" % (self.path, what, describe(e))) from e

        return read_consistently(self.path, attempt)

    def _check_and_read_header(self):
        h5 = self._h5
        _refuse_run_store_file(self.path, h5)
        if "format" in h5.attrs and text(h5.attrs["format"]) == "capsflow-analysis":
            raise FormatError("%s: is a capsflow analysis file, not %s; open it with capsflow.open_analysis"
                              % (self.path, _WHAT))
        if "state" in h5 and "output_file" in h5.attrs:
            raise FormatError("%s: is a checkpoint, not %s; open the output it belongs to (%s)"
                              % (self.path, _WHAT, text(h5.attrs["output_file"])))
        # The version first: a newer format may have moved what the checks below look for.
        version = h5.attrs.get("format_version", 1)
        if isinstance(version, np.ndarray) and version.shape == (1,):
            version = version[0]
        # capsflow writes an integer: 5.5, "6" or 6.0 are not versions this reader knows.
        if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)):
            raise UnsupportedVersionError("%s: attribute format_version = %r is not an integer output format (this "
                                          "reader knows formats 1 to %d)" % (self.path, version, FORMAT_VERSION))
        version = int(version)
        if version > FORMAT_VERSION or version < 1:
            raise UnsupportedVersionError(
                "%s: attribute format_version: written in output format %d; this reader knows formats 1 to %d%s"
                % (self.path, version, FORMAT_VERSION, " (a newer capsflow wrote it)" if version > 1 else ""))
        missing = [p for p in ("parameters/config", "capsules/species", "capsules/ca", "capsules/pinned",
                               "mesh/triangles", "mesh/triangles_all", "mesh/node_capsule", "mesh/node_species",
                               "series/time", "frames/time", "frames/positions", "frames/velocity")
                   if p not in h5]
        if missing:
            raise FormatError("%s: not %s: missing %s" % (self.path, _WHAT, ", ".join("/" + p for p in missing)))
        self.format_version = version
        self.info = attrs_dict(h5)
        self.info.update(attrs_dict(h5["parameters"]))
        self.capsflow_version = self.info.get("capsflow_version")
        self.run_id = self.info.get("run_id")
        self.config = self._parse_config(text(h5["parameters/config"][()]))
        dom = self.config.get("domain", {})
        try:
            self.H, self.Lx, self.Lz = float(dom["H"]), float(dom["Lx"]), float(dom["Lz"])
            self.radius = float(h5["capsules"].attrs.get("radius",
                                                         self.config.get("capsules", {}).get("radius", 1.0)))
        except (KeyError, TypeError, ValueError) as e:
            raise FormatError("%s: /parameters/config: expected [domain] H, Lx, Lz and a radius as numbers (%s)"
                              % (self.path, describe(e)))

        bad = self._malformed
        self.species = self._dataset_value(h5, "capsules/species", 1).astype(np.int64)
        np_ = int(self.species.shape[0])
        if np_ == 0:
            raise bad("/capsules/species", "at least one capsule, got none")
        names = h5["capsules/species"].attrs.get("names")
        if names is not None:
            self.species_names = text(names).split(",")
        else:
            self.species_names = [s.get("name") for s in self.config.get("species", [])]
        if np_ and not (self.species.min() >= 0 and self.species.max() < len(self.species_names)):
            raise bad("/capsules/species", "species indices 0 to %d (%d names)"
                      % (len(self.species_names) - 1, len(self.species_names)))
        self.ca = self._dataset_value(h5, "capsules/ca", 1, (np_,))
        self.pinned = self._dataset_value(h5, "capsules/pinned", 1, (np_,)).astype(bool)
        self.triangles = self._dataset_value(h5, "mesh/triangles", 2, (None, 3))
        self.triangles_all = self._dataset_value(h5, "mesh/triangles_all", 2, (np_ * self.triangles.shape[0], 3))
        self.node_capsule = self._dataset_value(h5, "mesh/node_capsule", 1)
        nn = int(self.node_capsule.shape[0])
        if np_ == 0 or nn % np_ != 0:
            raise bad("/mesh/node_capsule", "a multiple of the %d capsules' count of nodes, got %d" % (np_, nn))
        self.node_species = self._dataset_value(h5, "mesh/node_species", 1, (nn,))
        self.n_capsules = np_
        self.nodes_per_capsule = nn // np_
        if self.triangles.size and not (self.triangles.min() >= 0 and self.triangles.max() < self.nodes_per_capsule):
            raise bad("/mesh/triangles", "node numbers 0 to %d" % (self.nodes_per_capsule - 1))

        # Every per-record, per-frame and per-event dataset with the inner shape of the layout.
        ns = len(self.species_names)
        inner = {"centroid": (np_, 3), "velocity": (np_, 3), "taylor_D": (np_,), "inclination": (np_,),
                 "volume": (np_,), "area": (np_,), "profile": (ns, None), "step_limits": (5,)}
        for name in Series._NAMES:
            self._check_inner(h5, "series/" + name, inner.get(name, ()))
        frame_inner = {"positions": (nn, 3), "velocity": (nn, 3), "traction_jump": (nn, 3)}
        for name in ("time", "positions", "velocity") + _MEMBRANE_FIELDS:
            self._check_inner(h5, "frames/" + name, frame_inner.get(name, (nn,) if name in _MEMBRANE_FIELDS else ()))
        for name, shape in (("time", ()), ("capsules", (2,)), ("gap_before", ()), ("dy", (2,))):
            self._check_inner(h5, "events/" + name, shape)

        self.series = Series(self, "series", _common_extent(self.path, h5, "series", Series._NAMES))
        self.frames = Frames(self)
        self.events = Events(self, "events", _common_extent(self.path, h5, "events",
                                                            ("time", "capsules", "gap_before", "dy"), 0))

    def _malformed(self, path, expected):
        return FormatError("%s: %s: expected %s (a damaged or hand-edited file)" % (self.path, path, expected))

    def _dataset_value(self, h5, path, ndim, shape=None):
        """The whole dataset `path` (no leading /), of rank `ndim` and, where given, `shape` (None: any extent)."""
        ds = h5[path]
        if not isinstance(ds, h5py_Dataset) or len(ds.shape) != ndim or (
                shape is not None and any(w is not None and w != g for w, g in zip(shape, ds.shape))):
            raise self._malformed("/" + path, "a dataset of shape %s, got %s"
                                  % (_shape_text(shape or (None,) * ndim),
                                     _shape_text(ds.shape) if isinstance(ds, h5py_Dataset) else "a group"))
        return ds[()]

    def _check_inner(self, h5, path, inner):
        """A growing dataset (records, frames, events) present with the inner shape `inner` (None: any extent)."""
        if path not in h5:
            return
        ds = h5[path]
        ok = isinstance(ds, h5py_Dataset) and len(ds.shape) == 1 + len(inner) and all(
            w is None or w == g for w, g in zip(inner, ds.shape[1:]))
        if not ok:
            raise self._malformed("/" + path, "a dataset of shape %s, got %s"
                                  % (_shape_text(("T",) + tuple(inner)),
                                     _shape_text(ds.shape) if isinstance(ds, h5py_Dataset) else "a group"))

    def _parse_config(self, toml_text):
        if _toml is None:
            raise ImportError("%s: reading /parameters/config needs tomllib (Python >= 3.11) or the tomli package"
                              % self.path)
        try:
            return _toml.loads(toml_text)
        except Exception as e:
            raise FormatError("%s: /parameters/config is not valid TOML (%s)" % (self.path, e))

    def _file(self):
        if self._h5 is None:
            raise ValueError("%s: the run file is closed" % self.path)
        return self._h5

    # ---- conveniences

    @property
    def n_records(self):
        """T, the number of whole records."""
        return int(self.series.time.shape[0])

    @property
    def n_species(self):
        return len(self.species_names)

    @property
    def capsule_species(self):
        """[Np] the species name of each capsule."""
        return [self.species_names[s] for s in self.species]

    def units(self, path):
        """The `units` attribute of dataset `path` ("series/centroid" -> "a"; format >= 5), None where absent."""
        h5 = self._file()
        u = h5[path].attrs.get("units")
        return None if u is None else text(u)

    def capsules_of(self, name):
        """Indices of the capsules of species `name` (a [[species]] name)."""
        if name not in self.species_names:
            raise KeyError("%s: no species %r (the run has %s)" % (self.path, name, ", ".join(self.species_names)))
        return np.flatnonzero(self.species == self.species_names.index(name))

    def centreline_distance(self):
        """[T, Np] d = |y_c - H/2| (a), the distance of each centre from the centreline (docs/analysis.md §5)."""
        return np.abs(self.series.centroid[:, :, 1] - 0.5 * self.H)

    def close(self):
        if getattr(self, "_h5", None) is not None:
            self._h5.close()
            self._h5 = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        state = "closed" if self._h5 is None else "%d records, %d frames" % (self.n_records, len(self.frames))
        return "<capsflow run %s: %d capsules (%s), format %d, %s>" % (
            self.path, self.n_capsules, ", ".join(self.species_names), self.format_version, state)


def open_run(path):
    """Opens the output OUT.h5 of `capsflow run` (read-only, also while the run is writing it).

    Raises FileNotFoundError (no such file), capsflow.FormatError (not HDF5, or not a run output: an analysis file,
    a checkpoint, another HDF5 file) and capsflow.UnsupportedVersionError (an output format newer than this reader).
    """
    return Run(path)
