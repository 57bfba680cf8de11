"""Opening capsflow's HDF5 files with errors that name the file and what was expected."""

import os

import h5py
import numpy as np


class FormatError(ValueError):
    """The file exists but is not what was asked for (not HDF5, another kind of capsflow file, malformed)."""


class UnsupportedVersionError(FormatError):
    """The file's format version is one this reader does not know (written by a newer capsflow)."""


def open_h5(path, what):
    """Opens `path` read-only. `what` says what was expected, for the messages ("a capsflow run output")."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError("%s: no such file (expected %s)" % (path, what))
    if os.path.isdir(path):
        raise FormatError("%s: is a directory (expected %s)" % (path, what))
    if not h5py.is_hdf5(path):
        raise FormatError("%s: not an HDF5 file (expected %s)" % (path, what))
    try:
        # A live run holds an HDF5 file lock on its output: read without taking one (the run flushes whole records).
        return h5py.File(path, "r", locking=False)
    except TypeError:  # h5py < 3.5 has no `locking`; HDF5_USE_FILE_LOCKING=FALSE does the same there
        return h5py.File(path, "r")


def text(value):
    """An HDF5 string (attribute or scalar dataset value) as str."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray) and value.shape == ():
        return text(value[()])
    return str(value)


def attrs_dict(obj):
    """The attributes of an HDF5 object as plain Python values (str, int, float)."""
    out = {}
    for k, v in obj.attrs.items():
        if isinstance(v, (bytes, str)):
            out[k] = text(v)
        elif isinstance(v, np.generic):
            out[k] = v.item()
        else:
            out[k] = v
    return out
