#!/usr/bin/env python3
"""A long run's output kept in the repository as a base file and append-only parts (issue 35).

A run's output.h5 only grows (records, frames, contact events), but git stores every changed file whole: saving a
70 MB output after each working stretch adds 70 MB to the repository and to the submission each time, and one
day's saves of set A (three such files) went over what a submission may carry. So the store keeps the file it
was first given (the base, never rewritten) and, at each later save, a part holding only the records written since,
deflated; restoring joins them back into an output that `capsflow run --restart` continues and `capsflow analyze`
reads like the original.

    tools/run_store.py save RUN_DIR STORE_DIR     # RUN_DIR/output.h5 -> STORE_DIR/output.h5 or output.part-NNN.h5
    tools/run_store.py restore STORE_DIR RUN_DIR [--force]  # STORE_DIR/output.h5 + parts -> RUN_DIR/output.h5
    tools/run_store.py status STORE_DIR...        # records, frames and events per file of each store
    tools/run_store.py lock-status RUN_DIR        # exit 2 (one line) when a live run writes RUN_DIR/output.lock

The growing datasets are the ones with an unlimited first dimension (the layout's series, frames and events). A
part holds, for each of them, the records from the stored count on (its start is an attribute under /_store), and a
copy of everything else of the output at the save (the mesh, the configuration, every attribute): the join takes
the base, cuts each growing dataset to the part's start and appends the part's records, then takes the rest from
the newest part and makes the frame views of the XDMF index (/xdmf/NAME/F, virtual datasets of frame F) again.

A save checks itself before it keeps anything: the store joined with the new part must equal the run's output in
every dataset, attribute and creation property (chunks, filters, fill value, the views' mappings); otherwise the
part is removed and the save fails. A run whose output holds no record past the store saves nothing.

Checksums: each save records the SHA-256 of the file it wrote (the base, a part) in STORE_DIR/output.sha256
(sha256sum's format: `sha256sum --check output.sha256` in the store reads it too). restore, save and status check
every file of the store against it before they read it: a damaged file (one flipped byte of a part's plain dataset
reads as another number, without any error from HDF5) is refused naming it. Files of a store saved before checksums
(none listed, or listed only from a later part on) are read unchecked, said so ("unchecked: stored before
checksums"); an error reading one (zlib's on a damaged chunk) is refused naming that file.

Refused with exit 2 and one line naming the file, before anything is written (a restore does not even make
RUN_DIR): a missing file; a folder that a live run is writing (its output.lock read as capsflow reads it,
tools/run_marker.py: a marker left by a run that was killed is stale, said and ignored, as capsflow replaces it); an
output of another run (run_id); an output that holds fewer records than the store (a continuation that has not yet
caught up: continue it first); a store with a gap between parts; a file of the store whose checksum differs, that
the manifest lists but is missing, or a part without a checksum after one with one (a save that did not finish); a
store and run folder that are one folder. A restore never goes backwards: onto an output that holds more records
than the store (the run continued there since its last save) or another run's output it is refused with both record
counts and strains; `--force` replaces it, keeping the replaced file aside as output.replaced-DATE.h5 (only once
the joined output is ready: a refused or failed join moves nothing).

A part marks itself as a fragment: its /_store group (the records' starts, the run id, `part`, its number, and a
`note`; parts saved before 2026-12-08 lack the last two) is what the Python reader and `capsflow analyze` recognise
to refuse it as a run, as they refuse the base of a store with parts beside it; the join leaves /_store out.

Every file (the base, a part, a restored output) is written through tools/capsflow_atomic.py: to a hidden temporary
beside it (`.NAME.tmp.PID.N`), synced and renamed into place, the directory synced after; a part and a joined output
are built in memory first, so that HDF5 never meets a failed write (h5py crashed under HDF5 1.10 when it did). A
failure (a full disk: exit 1 and one line with the file and the system's reason) removes the temporary and leaves the
store and the run's folder as they were (a new base or part whose directory sync failed is removed too, and
output.sha256 is put back as it was). The same
test-only fault injection as capsflow's (CAPSFLOW_TEST_FAULT_AT, ...: capsflow_atomic.py) fails each write, sync and
rename in turn (tests/python/test_python_write_faults.py).
"""

import contextlib
import hashlib
import io
import os
import re
import sys
import time

# The shared atomic writer and its test-only fault injection, and capsflow's reading of a run's lock (beside this file).
from capsflow_atomic import file_chunks, h5_image, temporary_beside, write_atomically
from run_marker import lock_status

try:
    import h5py
    import numpy as np
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"run_store.py: needs numpy and h5py ({e}); Debian: apt-get install python3-h5py", file=sys.stderr)
    sys.exit(2)

OUTPUT = "output.h5"
PART_RE = re.compile(r"^output\.part-(\d{3,})\.h5$")
# The store's checksums: one line "SHA256  NAME" per file (sha256sum's format: `sha256sum --check output.sha256` in the
# store reads it too), the base and each part, written by the save that wrote the file.
MANIFEST = "output.sha256"
MANIFEST_LINE = re.compile(r"^([0-9a-f]{64})  (output\.h5|output\.part-\d{3,}\.h5)$")
UNCHECKED = "unchecked: stored before checksums"
STORE_GROUP = "_store"
VIEWS = "xdmf"        # /xdmf/NAME/F: frame F of /frames/NAME (format 3 on), made again by the join
STORE_FORMAT = 1


class Refused(Exception):
    """Bad input: one line, exit 2."""


def growing(f):
    """Paths of the datasets with an unlimited first dimension, outside the frame views."""
    out = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and not name.startswith(VIEWS + "/") and not name.startswith(STORE_GROUP):
            if obj.maxshape and obj.maxshape[0] is None:
                out.append(name)
    f.visititems(visit)
    return sorted(out)


def parts_of(store):
    """The store's parts in order, checked to be numbered 1, 2, ... without a gap."""
    found = []
    for name in os.listdir(store):
        m = PART_RE.match(name)
        if m:
            found.append((int(m.group(1)), name))
    found.sort()
    for i, (n, name) in enumerate(found, start=1):
        if n != i:
            raise Refused(f"{store}: part {i} is missing before {name}: the store cannot be joined")
    return [os.path.join(store, name) for _, name in found]


def part_name(n):
    return f"output.part-{n:03d}.h5"


def sha256_of(path):
    h = hashlib.sha256()
    for c in file_chunks(path):
        h.update(c)
    return h.hexdigest()


def read_manifest(store):
    """{name: sha256} of the store's checksums ({} for a store saved before them); a malformed line is refused."""
    path = os.path.join(store, MANIFEST)
    if not os.path.exists(path):
        return {}
    sums = {}
    with open(path, "rb") as fh:
        for i, raw in enumerate(fh.read().decode("utf-8", "replace").splitlines(), start=1):
            m = MANIFEST_LINE.match(raw)
            if not m:
                raise Refused(f"{path}: line {i} is not 'SHA256  NAME' of a file of the store ({raw[:60]!r}): the "
                              f"checksums are damaged; take the file again from where the store is kept (git)")
            sums[m.group(2)] = m.group(1)
    return sums


def verify_store(store):
    """Every file of the store against the checksum its save recorded, before anything reads it for a restore or a
    save: a damaged file (a flipped byte in a plain dataset reads as another number, silently) is refused naming it.
    Returns the names of the files stored before checksums (unchecked). A part without a checksum after a file that
    has one is a save that did not finish: refused too."""
    base = os.path.join(store, OUTPUT)
    if not os.path.isfile(base):
        raise Refused(f"{store}: no {OUTPUT} (nothing stored)")
    files = [base] + parts_of(store)
    sums = read_manifest(store)
    manifest = os.path.join(store, MANIFEST)
    names = {os.path.basename(p) for p in files}
    for name in sorted(sums):
        if name not in names:
            raise Refused(f"{os.path.join(store, name)}: missing, though {manifest} lists it: take it again from where "
                          f"the store is kept (git)")
    unchecked, checked_before = [], None
    for p in files:
        name = os.path.basename(p)
        if name not in sums:
            if checked_before:
                raise Refused(f"{p}: no checksum in {manifest}, though {checked_before} before it has one: a save "
                              f"that did not finish? remove {name} and save the run again")
            unchecked.append(name)
            continue
        checked_before = name
        got = sha256_of(p)
        if got != sums[name]:
            raise Refused(f"{p}: damaged: its SHA-256 is {got[:16]}..., not the {sums[name][:16]}... its save "
                          f"recorded in {manifest}; nothing written: take the file again from where the store is "
                          f"kept (git)")
    return unchecked


def unchecked_note(unchecked):
    return f"; {UNCHECKED}: {', '.join(unchecked)}" if unchecked else ""


def write_manifest(store, sums, undo):
    """The store's checksums written atomically. On a failure the manifest is left as it was (put back from a hard
    link when only the directory's sync after the rename failed) and undo() removes the file just added, so that the
    store is as before the save."""
    path = os.path.join(store, MANIFEST)
    text = "".join(f"{sums[n]}  {n}\n" for n in sorted(sums, key=lambda n: (n != OUTPUT, n)))
    backup = None
    if os.path.exists(path):
        backup = temporary_beside(path)
        os.link(path, backup)   # no bytes copied: only a name, to put the old manifest back by a rename
    try:
        write_atomically(path, text.encode())
    except BaseException:
        if backup:
            # Put back only where the new one was renamed in: a rename between two links of one file does nothing.
            if not os.path.samefile(backup, path):
                os.replace(backup, path)
        elif os.path.exists(path):
            os.remove(path)
        undo()
        raise
    finally:
        if backup and os.path.lexists(backup):
            os.remove(backup)


@contextlib.contextmanager
def reading(path):
    """HDF5's error while reading a file of the store (zlib's "inflate() failed" on a damaged chunk of a store saved
    before checksums) refused naming that file."""
    try:
        yield
    except Refused:
        raise
    except (OSError, RuntimeError, KeyError, ValueError) as e:
        raise Refused(f"{path}: cannot be read, damaged? ({' '.join(str(e).split())}); nothing written: take the "
                      f"file again from where the store is kept (git)") from e


def copy_attrs(src, dst):
    for k in list(dst.attrs.keys()):
        if k not in src.attrs:
            del dst.attrs[k]
    for k, v in src.attrs.items():
        dst.attrs.create(k, v, dtype=src.attrs.get_id(k).dtype)


def remake_views(f):
    """The frame views /xdmf/NAME/F for every frame of /frames/NAME whose group exists, none past the frames."""
    if VIEWS not in f:
        return
    for name in list(f[VIEWS].keys()):
        src_path = f"/frames/{name}"
        views = f[VIEWS][name]
        if src_path not in f:
            continue
        src = f[src_path]
        frames, inner = src.shape[0], src.shape[1:]
        units = src.attrs.get("units")
        for k in list(views.keys()):
            if int(k) >= frames:
                del views[k]
        for i in range(frames):
            if str(i) in views:
                continue
            # The view's source is "." (this same file), of shape [i + 1, ...] with an unlimited first dimension:
            # the mapping capsflow itself makes (H5File::create_record_view), so the XDMF index reads either alike.
            layout = h5py.VirtualLayout(shape=inner, dtype=src.dtype)
            vsrc = h5py.VirtualSource(".", src_path, shape=(i + 1,) + inner, dtype=src.dtype,
                                      maxshape=(None,) + inner)
            layout[...] = vsrc[i]
            d = views.create_virtual_dataset(str(i), layout, fillvalue=0)
            if units is not None:
                d.attrs.create("units", units, dtype=src.attrs.get_id("units").dtype)


def creation(d):
    """The creation properties a save records for a growing dataset, and the join gives it back."""
    return {"chunks": list(d.chunks or ()), "compression": d.compression or "", "level": d.compression_opts or 0,
            "shuffle": bool(d.shuffle)}


def recreate(out, path, want):
    """Rewrites out[path] with the creation properties `want` (a finished run compresses its series: the output
    then has other filters than the base stored while it ran)."""
    d = out[path]
    data, attrs, fill = d[...], {k: (v, d.attrs.get_id(k).dtype) for k, v in d.attrs.items()}, d.fillvalue
    del out[path]
    kw = dict(chunks=tuple(int(c) for c in want["chunks"]), maxshape=(None,) + data.shape[1:], fillvalue=fill)
    if want["compression"]:
        kw.update(compression=want["compression"], compression_opts=int(want["level"]))
    kw["shuffle"] = bool(want["shuffle"])
    nd = out.create_dataset(path, data=data, **kw)
    for k, (v, t) in attrs.items():
        nd.attrs.create(k, v, dtype=t)


def joined_image(store):
    """Base + parts joined: the bytes of the output file (built in memory: capsflow_atomic.h5_image says why)."""
    base = os.path.join(store, OUTPUT)
    if not os.path.isfile(base):
        raise Refused(f"{store}: no {OUTPUT} (nothing stored)")
    parts = parts_of(store)

    def build(out):
        with reading(base), h5py.File(base, "r") as b:
            # A new file, not a copy of the base: a dataset rewritten below leaves no dead space behind.
            copy_attrs(b, out)
            for name in b:
                if name == VIEWS:
                    views = out.create_group(VIEWS)
                    copy_attrs(b[VIEWS], views)
                    for v in b[VIEWS]:
                        copy_attrs(b[VIEWS][v], views.create_group(v))
                else:
                    b.copy(b[name], out, name=name)
            for p in parts:
                with reading(p), h5py.File(p, "r") as part:
                    meta = part[STORE_GROUP]
                    if meta.attrs.get("run_id") != out.attrs.get("run_id"):
                        raise Refused(f"{p}: belongs to another run than {base} (run_id)")
                    for path in growing(part):
                        start = int(meta.attrs[path])
                        if path not in out:
                            raise Refused(f"{p}: {path} is not in {base}")
                        d = out[path]
                        if start > d.shape[0]:
                            raise Refused(f"{p}: {path} starts at record {start}, past the {d.shape[0]} stored "
                                          f"before it (a gap)")
                        src = part[path]
                        d.resize(start + src.shape[0], axis=0)
                        if src.shape[0]:
                            d[start:] = src[...]
            if parts:
                with reading(parts[-1]), h5py.File(parts[-1], "r") as last:
                    meta = last[STORE_GROUP]
                    for path in growing(last):
                        want = {k: meta[path].attrs[k] for k in ("chunks", "compression", "level", "shuffle")}
                        want = {"chunks": [int(c) for c in want["chunks"]], "compression": str(want["compression"]),
                                "level": int(want["level"]), "shuffle": bool(want["shuffle"])}
                        if creation(out[path]) != want:
                            recreate(out, path, want)
                    take_rest(last, out)
        remake_views(out)
    return h5_image(build)


def take_rest(last, out):
    """Everything but the growing records from the newest part: static datasets and every attribute."""
    grow = set(growing(last))

    def visit(name, obj):
        if name == STORE_GROUP or name.startswith(STORE_GROUP + "/") or name == VIEWS or name.startswith(VIEWS + "/"):
            return
        if isinstance(obj, h5py.Group):
            g = out.require_group(name)
            copy_attrs(obj, g)
        elif name in grow:
            copy_attrs(obj, out[name])
        elif name in out and props(out[name]) == props(obj) and equal_values(out[name], obj):
            copy_attrs(obj, out[name])   # unchanged since the base: no rewrite (HDF5 would not reuse the space)
        else:
            if name in out:
                del out[name]
            last.copy(obj, out, name=name)
    last.visititems(visit)
    copy_attrs(last, out)


def describe_differences(a_path, b_path, limit=5, b_name=None):
    """Where two outputs differ: dataset values, shapes, types, creation properties, attributes, views. [] if equal.
    b_path may be a file object (an image in memory), named b_name in the messages."""
    diffs = []
    with h5py.File(a_path, "r") as a, h5py.File(b_path, "r") as b:
        names = {}

        def collect(f, key):
            def visit(name, obj):
                names.setdefault(name, [None, None])[key] = obj
            f.visititems(visit)
        collect(a, 0)
        collect(b, 1)
        for name, (x, y) in sorted(names.items()):
            if len(diffs) >= limit:
                break
            if x is None or y is None:
                diffs.append(f"/{name}: only in {(b_name or b_path) if x is None else a_path}")
                continue
            if type(x) is not type(y):
                diffs.append(f"/{name}: a group in one file, a dataset in the other")
                continue
            if dict_attrs(x) != dict_attrs(y):
                diffs.append(f"/{name}: attributes differ")
            if isinstance(x, h5py.Dataset):
                px, py = props(x), props(y)
                if px != py:
                    diffs.append(f"/{name}: creation properties differ ({px} vs {py})")
                elif not equal_values(x, y):
                    diffs.append(f"/{name}: values differ")
        if dict_attrs(a) != dict_attrs(b):
            diffs.append("/: attributes differ")
    return diffs


def dict_attrs(obj):
    return {k: (np.asarray(v).tolist() if not isinstance(v, (str, bytes)) else v, str(obj.attrs.get_id(k).dtype))
            for k, v in obj.attrs.items()}


def props(d):
    p = {"shape": d.shape, "dtype": str(d.dtype), "maxshape": d.maxshape, "virtual": d.is_virtual}
    if d.is_virtual:
        p["sources"] = [(s.file_name, s.dset_name, s.src_space.get_select_bounds(), s.vspace.get_select_bounds())
                        for s in d.virtual_sources()]
    else:
        p.update(chunks=d.chunks, compression=d.compression, opts=d.compression_opts, shuffle=d.shuffle,
                 fillvalue=np.asarray(d.fillvalue).tolist() if d.dtype.kind != "O" else None)
    return p


def equal_values(x, y):
    if x.shape != y.shape:
        return False
    if x.dtype.kind in "OSU" or x.shape == ():
        return x[()] == y[()] if x.shape == () else bool(np.all(x[...] == y[...]))
    step = max(1, (1 << 24) // max(1, x.dtype.itemsize * int(np.prod(x.shape[1:], dtype=np.int64))))
    for i in range(0, x.shape[0] if x.ndim else 1, step):
        u, v = x[i:i + step], y[i:i + step]
        # Bit for bit (NaN where NaN, -0 where -0): a view or copy of the same numbers.
        if u.dtype.kind == "f":
            if not np.array_equal(u.view(f"u{u.dtype.itemsize}"), v.view(f"u{v.dtype.itemsize}")):
                return False
        elif not np.array_equal(u, v):
            return False
    return True


def extents(path_list):
    """Per growing dataset: (records stored, the file that holds the last one) over base + parts."""
    ext = {}
    for i, p in enumerate(path_list):
        with reading(p), h5py.File(p, "r") as f:
            for path in growing(f):
                start = int(f[STORE_GROUP].attrs[path]) if i else 0
                ext[path] = start + f[path].shape[0]
    return ext


def write_new(dest, data):
    """A new file of the store, written atomically; removed again when only the directory's sync after its rename
    failed, so that a failed save leaves the store as it was (the save is then repeated whole)."""
    try:
        write_atomically(dest, data)
    except BaseException:
        if os.path.exists(dest):
            os.remove(dest)
        raise


def refuse_same_folder(run, store):
    """A store is not a run's folder: a restore into it would replace its base with the joined output."""
    if os.path.realpath(run) == os.path.realpath(store):
        raise Refused(f"{store}: the store and the run's folder are one folder; give the run's folder and the store "
                      f"as two")


def check_not_running(run, command):
    """Refuses a folder that a live run is writing (its output.lock read as capsflow reads it: run_marker.py); a
    marker left by a run that was killed is said and ignored, as capsflow itself replaces it."""
    state, line = lock_status(run)
    if state == "live":
        raise Refused(line)
    if state == "stale":
        print(f"{command}: {line}")


def save(run, store):
    src = os.path.join(run, OUTPUT)
    if not os.path.isfile(src):
        raise Refused(f"{src}: no such file (nothing to save)")
    check_not_running(run, "save")
    refuse_same_folder(run, store)
    base = os.path.join(store, OUTPUT)
    if not os.path.isfile(base):
        os.makedirs(store, exist_ok=True)
        digest = hashlib.sha256()

        def hashed(chunks):   # the checksum of the bytes written, without reading the file twice
            for c in chunks:
                digest.update(c)
                yield c
        write_new(base, hashed(file_chunks(src)))
        write_manifest(store, {OUTPUT: digest.hexdigest()}, undo=lambda: os.remove(base))
        print(f"save: {run} -> {base} (the base: {os.path.getsize(base) / 1e6:.1f} MB; its checksum in {MANIFEST})")
        return
    # A damaged store is found before it is joined or added to (a part saved onto it would pass the self-check only
    # where the damage is in data the join does not take).
    unchecked = verify_store(store)
    parts = parts_of(store)
    with reading(base), h5py.File(base, "r") as b:
        base_id = b.attrs.get("run_id")
    with h5py.File(src, "r") as out:
        if out.attrs.get("run_id") != base_id:
            raise Refused(f"{src}: belongs to another run (run_id {out.attrs.get('run_id')}) than the store's "
                          f"{base} ({base_id})")
        stored = extents([base] + parts)
        now = {p: out[p].shape[0] for p in growing(out)}
        missing = sorted(set(stored) - set(now))
        if missing:
            raise Refused(f"{src}: lacks {missing[0]}, which the store holds")
        behind = [p for p in now if now[p] < stored.get(p, 0)]
        if behind:
            p = behind[0]
            raise Refused(f"{src}: /{p} holds {now[p]} records, the store {stored[p]}: the run was continued from "
                          f"an earlier checkpoint and has not yet caught up; continue it past the store first")
        if all(now[p] == stored.get(p, 0) for p in now):
            print(f"save: {run}: nothing new past the store ({len(parts)} part(s))")
            return
        n = len(parts) + 1
        dest = os.path.join(store, part_name(n))

        def write_part(part):
            meta = part.create_group(STORE_GROUP)
            meta.attrs["store_format"] = STORE_FORMAT
            meta.attrs["run_id"] = out.attrs.get("run_id")
            # A fragment, said as such: the reader and `capsflow analyze` refuse a file with /_store as a run.
            meta.attrs["part"] = n
            meta.attrs["note"] = (f"part {n} of a run store, the records from {stored.get('series/time', 0)} on: not "
                                  f"a run; tools/run_store.py restore STORE_DIR RUN_DIR joins the store into one")
            for path in sorted(now):
                s = stored.get(path, 0)
                meta.attrs[path] = s
                d = out[path]
                rows = d[s:]
                kw = {}
                if rows.size and rows.dtype.kind in "iuf":
                    kw = dict(compression="gzip", compression_opts=6, shuffle=True,
                              chunks=(max(1, min(rows.shape[0], (1 << 20) // max(1, rows[0].nbytes))),)
                              + rows.shape[1:])
                nd = part.create_dataset(path, data=rows, maxshape=(None,) + rows.shape[1:], **kw)
                copy_attrs(d, nd)
                rec = meta.require_group(path)   # the output's own creation properties, for the join
                for k, v in creation(d).items():
                    rec.attrs[k] = v

            def visit(name, obj):
                if name == VIEWS or name.startswith(VIEWS + "/") or name in now:
                    return
                if isinstance(obj, h5py.Group):
                    copy_attrs(obj, part.require_group(name))
                else:
                    out.copy(obj, part, name=name)
            out.visititems(visit)
            copy_attrs(out, part)
        image = h5_image(write_part)
        write_new(dest, image)
    # The check: the store joined with the new part is the run's output (joined in memory: no file to clean up).
    try:
        diffs = describe_differences(src, io.BytesIO(joined_image(store)), b_name="the joined store")
    except BaseException:
        os.remove(dest)
        raise
    if diffs:
        os.remove(dest)
        raise RuntimeError(f"save: {run}: the store joined with the new part differs from the output "
                           f"({'; '.join(diffs)}); nothing kept")
    # Kept: its checksum joins the others (a store saved before checksums gets its first manifest, of this part).
    sums = read_manifest(store)
    sums[os.path.basename(dest)] = hashlib.sha256(image).hexdigest()
    write_manifest(store, sums, undo=lambda: os.remove(dest))
    added = {p: now[p] - stored.get(p, 0) for p in now}
    print(f"save: {run} -> {dest} ({os.path.getsize(dest) / 1e6:.1f} MB: "
          f"{added.get('series/time', 0)} records, {added.get('frames/time', 0)} frames, "
          f"{added.get('events/time', 0)} events; joined equal to the output; its checksum in {MANIFEST})"
          + unchecked_note(unchecked))


def last_strain(path):
    """The strain of a file's last record (a part: its own last record), or None."""
    with reading(path), h5py.File(path, "r") as f:
        t = f["series/time"] if "series/time" in f else None
        return float(t[-1]) if t is not None and t.shape[0] else None


def refuse_going_back(store, dest):
    """A restore never replaces newer work: refused when dest holds more records than the store in any growing
    dataset (a run continued here since its last save), or is another run's output."""
    base = os.path.join(store, OUTPUT)
    if not os.path.isfile(base):
        raise Refused(f"{store}: no {OUTPUT} (nothing to restore)")
    files = [base] + parts_of(store)
    stored = extents(files)
    try:
        with h5py.File(dest, "r") as out, h5py.File(base, "r") as b:
            if out.attrs.get("run_id") != b.attrs.get("run_id"):
                raise Refused(f"{dest}: belongs to another run (run_id {out.attrs.get('run_id')}) than the store's "
                              f"{base} ({b.attrs.get('run_id')}); --force replaces it (kept aside)")
            now = {p: out[p].shape[0] for p in growing(out)}
    except OSError:
        return  # not an HDF5 file we can read (a killed first write): nothing of value to keep
    ahead = [p for p in now if now[p] > stored.get(p, 0)]
    if ahead:
        p = ahead[0]
        here, there = last_strain(dest), last_strain(files[-1])
        raise Refused(f"{dest}: /{p} holds {now[p]} records (to strain {here}), the store {stored[p]} (to strain "
                      f"{there}): restoring would replace newer work; save it first (run_store.py save), or --force "
                      f"(the replaced output kept aside)")


def restore(store, run, force=False):
    """Base + parts -> RUN/output.h5. Everything is checked and the output joined (in memory) before anything is
    written: a refusal (a live run, a damaged store, newer work at RUN) leaves RUN as it was, not even made."""
    check_not_running(run, "restore")
    refuse_same_folder(run, store)
    unchecked = verify_store(store)
    dest = os.path.join(run, OUTPUT)
    if os.path.exists(dest) and not force:
        refuse_going_back(store, dest)
    image = joined_image(store)
    os.makedirs(run, exist_ok=True)
    kept = None
    if os.path.exists(dest) and force:
        # Aside, not gone: --force is for a store known to be the one to keep, but a mistaken one costs nothing.
        kept = os.path.join(run, time.strftime("output.replaced-%Y%m%d-%H%M%S.h5"))
        os.replace(dest, kept)
    write_atomically(dest, image)
    print(f"restore: {store} -> {dest} (base + {len(parts_of(store))} part(s)"
          + (f", each as its save's checksum in {MANIFEST} says" if not unchecked else "")
          + ")" + (f"; the output it replaced is {kept}" if kept else "") + unchecked_note(unchecked))


def status(store):
    unchecked = verify_store(store)
    files = [os.path.join(store, OUTPUT)] + parts_of(store)
    for i, p in enumerate(files):
        with reading(p), h5py.File(p, "r") as f:
            t = f["series/time"][...] if "series/time" in f else np.zeros(0)
            span = f"strain {t[0]:.1f} -> {t[-1]:.1f}" if t.size else "no records"
            print(f"{p}: {os.path.getsize(p) / 1e6:.1f} MB, {t.size} records ({span})"
                  + (f", from record {int(f[STORE_GROUP].attrs['series/time'])}" if i else " (base)")
                  + (f", {UNCHECKED}" if os.path.basename(p) in unchecked else ", checksum as saved"))


def main(argv):
    usage = ("usage: run_store.py save RUN_DIR STORE_DIR | restore STORE_DIR RUN_DIR [--force] | status STORE_DIR... "
             "| lock-status RUN_DIR")
    try:
        if len(argv) == 2 and argv[0] == "lock-status":
            state, line = lock_status(argv[1])
            if state == "live":
                raise Refused(line)
            if line:
                print(line)
        elif len(argv) == 3 and argv[0] == "save":
            save(argv[1], argv[2])
        elif len(argv) in (3, 4) and argv[0] == "restore" and (len(argv) == 3 or argv[3] == "--force"):
            restore(argv[1], argv[2], force=len(argv) == 4)
        elif len(argv) >= 2 and argv[0] == "status":
            for s in argv[1:]:
                status(s)
        else:
            print(usage, file=sys.stderr)
            return 2
    except Refused as e:
        print(f"run_store.py: {e}", file=sys.stderr)
        return 2
    except KeyError as e:
        print(f"run_store.py: {e}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError) as e:
        # An I/O failure (a full disk; h5py reports HDF5's as OSError or RuntimeError): one line with the file and the
        # system's reason, as capsflow says it. Then out at once: HDF5 1.10 crashes (SIGSEGV) closing, at the
        # interpreter's exit, a file whose writes failed; the temporaries are removed already (write_atomically).
        print("run_store.py: " + " ".join(str(e).split()), file=sys.stderr)
        sys.stderr.flush()
        sys.stdout.flush()
        os._exit(1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
