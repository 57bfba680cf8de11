#!/usr/bin/env python3
"""A copy of a capsflow checkpoint with another [time] cfl, to measure the explicit step's limit in a developed state.

`capsflow run --restart` refuses to change the physics of a checkpointed run, and the stability probe (`capsflow
probe`) measures a configuration's initial state only; a developed suspension's limit is measured by continuing it
at several cfl from one checkpoint (docs/validation.md 9.8):

  python3 tools/set_checkpoint_cfl.py run.checkpoint.h5 cfl075.checkpoint.h5 0.75
  cp run.h5 cfl075.h5      # the continued run appends to a copy of the run's output, never to the run's own
  capsflow run --restart cfl075.checkpoint.h5 --output cfl075.h5 --end T

Only `cfl` in the stored configuration (/parameters/config) changes, with the digest capsflow checks it by (its
attribute `digest`): the copy is deliberately other physics, and the one tool that may say so. The state is the
checkpoint's, its /state digest unchanged. The copy is written beside DST and renamed into place; an existing DST is
refused unless --force. Exit status 2 on bad input. Needs python3-h5py (Debian).
"""
import argparse
import math
import os
import re
import shutil
import sys
import tempfile


def fail(msg):
    print(f"set_checkpoint_cfl: {msg}", file=sys.stderr)
    sys.exit(2)


def text_digest(text):
    """capsflow's Digest64 of a text (src/host/base/digest.cpp; docs/output_format.md): its byte length, then its
    bytes as little-endian 64-bit words (the last zero-padded), each mixed in by a multiply-xorshift; then an
    avalanche. "h64:" and 16 hex digits."""
    mask = (1 << 64) - 1
    h = 0x243F6A8885A308D3

    def add(word):
        nonlocal h
        h = ((h ^ word) * 0x9E3779B97F4A7C15) & mask
        h ^= h >> 32

    data = text.encode()
    add(len(data))
    for i in range(0, len(data), 8):
        add(int.from_bytes(data[i:i + 8].ljust(8, b"\0"), "little"))
    h ^= h >> 29
    h = (h * 0xBF58476D1CE4E5B9) & mask
    h ^= h >> 32
    return f"h64:{h:016x}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("src", help="checkpoint to copy (FILE.checkpoint.h5)")
    ap.add_argument("dst", help="the copy to write")
    ap.add_argument("cfl", help="the new [time] cfl (a number > 0)")
    ap.add_argument("--force", action="store_true", help="replace DST if it exists")
    a = ap.parse_args()
    try:
        cfl = float(a.cfl)
    except ValueError:
        cfl = float("nan")
    if not (math.isfinite(cfl) and cfl > 0):
        fail(f"cfl: expected a finite number > 0, got {a.cfl!r}")
    if not os.path.isfile(a.src):
        fail(f"{a.src}: no such checkpoint")
    if os.path.exists(a.dst) and not a.force:
        fail(f"{a.dst}: exists (pass --force to replace it)")
    try:
        import h5py
    except ImportError:
        fail("needs python3-h5py (apt-get install python3-h5py)")
    fd, tmp = tempfile.mkstemp(prefix=".cfl-", suffix=".h5", dir=os.path.dirname(os.path.abspath(a.dst)))
    os.close(fd)
    try:
        shutil.copyfile(a.src, tmp)
        try:
            f = h5py.File(tmp, "r+")
        except OSError:
            fail(f"{a.src}: not an HDF5 file (expected a capsflow checkpoint)")
        with f:
            if "/parameters/config" not in f:
                fail(f"{a.src}: no /parameters/config (not a capsflow checkpoint)")
            text = f["/parameters/config"][()]
            text = text.decode() if isinstance(text, bytes) else str(text)
            # The stored configuration is capsflow's resolved TOML: `cfl = <number>` once, in [time].
            new, n = re.subn(r"(?m)^(\s*)cfl\s*=\s*[-+0-9.eE]+", rf"\g<1>cfl = {cfl!r}", text)
            if n != 1:
                fail(f"{a.src}: expected one 'cfl = ...' line in /parameters/config, found {n}")
            del f["/parameters/config"]
            d = f.create_dataset("/parameters/config", data=new.encode(), dtype=h5py.string_dtype("utf-8"))
            d.attrs["digest"] = text_digest(new)
        os.replace(tmp, a.dst)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


if __name__ == "__main__":
    main()
