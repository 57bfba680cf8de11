#!/usr/bin/env python3
"""Bytes per record and per frame of capsflow run files, and the size of a longer run of the same kind.

    tools/output_sizes.py T F RUN.h5 ...     # e.g. 25001 1251 for a whole set-A run (docs/output_format.md)

Raw bytes are the data's own; stored bytes are what the file holds for them (a compressed dataset's chunks, a plain
one's raw bytes: the unused tail of an allocated chunk is not counted). The rest of the file (the mesh, headers, the
frames' XDMF views) is counted once: it hardly grows with the run (a frame's view adds about 3 kB), and scaling it
with the frames, as this tool did until 2026-12-07, counted a short run's mesh once per frame of the long one (about
230 MB too many for set A from a 2-frame run). Reads the files only (also a live run's: file locking is switched off).
"""
import os
import sys

os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")
import h5py  # noqa: E402


def report(path, records, frames):
    with h5py.File(path, "r") as f:
        T, F = f["series/time"].shape[0], f["frames/time"].shape[0]
        groups = {g: [f[g + "/" + n] for n in f[g]] for g in ("series", "frames")}
        raw = {g: sum(d.size * d.dtype.itemsize for d in ds) for g, ds in groups.items()}
        allocated = {g: sum(d.id.get_storage_size() for d in ds) for g, ds in groups.items()}
        # A compressed dataset's stored bytes are its chunks; a plain one's its data (a chunk's unused tail is not
        # counted: a longer run fills it).
        stored = {g: sum(d.id.get_storage_size() if d.compression else d.size * d.dtype.itemsize for d in ds)
                  for g, ds in groups.items()}
    rest = os.path.getsize(path) - allocated["series"] - allocated["frames"]
    per_record, per_frame = stored["series"] / T, stored["frames"] / F
    total = records * per_record + frames * per_frame + rest
    print(f"{path}: {os.path.getsize(path) / 1e6:.2f} MB, {T} records, {F} frames; "
          f"per record {raw['series'] / T:.0f} B raw, {per_record:.0f} B stored; "
          f"per frame {raw['frames'] / F / 1e3:.1f} kB raw, {per_frame / 1e3:.1f} kB stored; "
          f"{records} records and {frames} frames: {total / 1e6:.0f} MB")


if __name__ == "__main__":
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    for p in sys.argv[3:]:
        report(p, int(sys.argv[1]), int(sys.argv[2]))
