"""Opening capsflow's HDF5 files with errors that name the file and what was expected."""

import os
import time

import h5py
import numpy as np


class FormatError(ValueError):
    """The file exists but is not what was asked for (not HDF5, another kind of capsflow file, malformed: truncated,
    overwritten, hand-edited). The message names the file and, where it is one object, the path in it."""


class UnsupportedVersionError(FormatError):
    """The file's format version is one this reader does not know (written by a newer capsflow)."""


def open_h5(path, what):
    """Opens `path` read-only. `what` says what was expected, for the messages ("a capsflow run output")."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError("%s: no such file (expected %s)" % (path, what))
    if os.path.isdir(path):
        raise FormatError("%s: is a directory (expected %s)" % (path, what))
    try:
        if not h5py.is_hdf5(path):
            raise FormatError("%s: not an HDF5 file (expected %s)" % (path, what))
        try:
            # A live run holds an HDF5 file lock on its output: read without taking one (the run flushes whole
            # records).
            return h5py.File(path, "r", locking=False)
        except TypeError:  # h5py < 3.5 has no `locking`; HDF5_USE_FILE_LOCKING=FALSE does the same there
            return h5py.File(path, "r")
    except (OSError, RuntimeError) as e:
        # h5py raises RuntimeError for some damaged metadata (a bad checksum), OSError for the rest.
        if isinstance(e, (FileNotFoundError, PermissionError, IsADirectoryError)):
            raise
        # A truncated, overwritten or garbage file: HDF5's own words, after the file's name.
        raise FormatError("%s: cannot be read as HDF5, truncated or damaged? (expected %s; %s)" % (path, what, e))


#: What reading a malformed file raises inside h5py and numpy (a missing object, another shape or type, a short
#: dataset; RuntimeError: h5py's for metadata whose checksum fails, as where garbage overwrote the file's end);
#: turned into FormatError with the file's name.
MALFORMED = (KeyError, IndexError, ValueError, TypeError, ZeroDivisionError, OSError, AttributeError, RuntimeError)


def describe(exc):
    """A one-line account of an exception raised while reading (h5py's KeyError holds its text in args[0])."""
    msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
    return "%s: %s" % (type(exc).__name__, msg) if msg else type(exc).__name__


def stamp(path):
    """(size, mtime) of a file: whether it changed between two reads (a live run appended to it)."""
    try:
        st = os.stat(path)
        return (st.st_size, st.st_mtime_ns)
    except OSError:
        return None


def read_consistently(path, read, attempts=40, pause=0.05):
    """Calls read() until it succeeds. A file that a live run is writing can be caught between the run's writes
    (HDF5 metadata of a record half flushed), and a handle opened earlier holds metadata the run has since moved:
    read() is tried a second time in any case (read() opens the file afresh on each call), and again while the file
    changes (`attempts` times in all, `pause` seconds apart); a file that failed twice in a row without changing is
    malformed, and its error is raised. Twice, because the file's time stamp is coarse (a kernel tick, ~4 ms): a write
    that began and ended within the tick of an attempt's first stamp leaves the stamp as it was, and only the next
    attempt sees the finished file. FormatError (and its subclasses) from read() pass through as they are; the other
    errors of MALFORMED become FormatError naming the file."""
    last = None
    quiet_failures = 0
    for attempt in range(attempts):
        before = stamp(path)
        try:
            return read()
        except FormatError as e:
            last = e
        except MALFORMED as e:
            if isinstance(e, (FileNotFoundError, PermissionError)):
                raise
            last = FormatError("%s: malformed (%s)" % (path, describe(e)))
            last.__cause__ = e
        time.sleep(pause)
        quiet_failures = quiet_failures + 1 if stamp(path) == before else 0
        if quiet_failures >= 2:
            break
    raise last


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
