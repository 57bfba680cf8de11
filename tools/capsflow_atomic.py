"""Atomic file writes of capsflow's Python tools (capsflow figures, tools/run_store.py), with the test-only fault
injection of the C++ program (src/host/base/fault_injection.hpp), so that their error paths are tested call by call
as the program's are (issue 55; tests/python/test_python_write_faults.py).

Every file goes to a hidden temporary beside its target (`.NAME.tmp.PID.N`, the C++ helpers' naming), is written,
synced, renamed over the target and the directory synced. A failure before the rename removes the temporary and leaves
the target as it was; it is raised as WriteFailed, an OSError whose text names the file and the system's reason.

HDF5 files are built in memory (h5_image) and written here as bytes: HDF5 itself then never meets a failed write.
That is deliberate: h5py under HDF5 1.10 crashed (SIGSEGV) in Group.copy and when closing objects after a write
failed, so a full disk must be met outside the library.

Test mode, read from the environment once per process (the variables of the C++ program):
  CAPSFLOW_TEST_FAULT_AT=N      the N-th counted call (N >= 1) and every later one fail, as on a disk just filled up
  CAPSFLOW_TEST_FAULT_ERRNO=E   ENOSPC (the default) or EIO
  CAPSFLOW_TEST_FAULT_LOG=FILE  one line "N KIND FILE" appended per counted call (the log itself is not counted)
Counted calls: each write(2) of a file's bytes, the fsync of the temporary and of the directory, and the rename.
"""

import errno
import io
import os

_CHUNK = 1 << 20  # bytes per write(2): a tiny file is one counted write, a 70 MB output seventy


class WriteFailed(OSError):
    """A write, sync or rename that failed: str() is one line naming the file and the system's reason."""

    def __init__(self, err, what):
        super().__init__(err, os.strerror(err))
        self.what = what

    def __str__(self):
        return "%s: %s (errno %d)" % (self.what, os.strerror(self.errno), self.errno)


def _settings():
    at = os.environ.get("CAPSFLOW_TEST_FAULT_AT", "")
    err = errno.EIO if os.environ.get("CAPSFLOW_TEST_FAULT_ERRNO") == "EIO" else errno.ENOSPC
    return (int(at) if at.strip() else 0), err, os.environ.get("CAPSFLOW_TEST_FAULT_LOG", "")


_AT, _ERRNO, _LOG = _settings()
_calls = 0
_temporaries = 0


def fault_point(kind, path):
    """Counts one call of `kind` on `path` in the test mode; returns 0 when it may go on, else the errno to fail with."""
    global _calls
    if _AT <= 0 and not _LOG:
        return 0
    _calls += 1
    if _LOG:
        with open(_LOG, "a", encoding="utf-8") as log:
            log.write("%d %s %s\n" % (_calls, kind, path))
    return _ERRNO if 0 < _AT <= _calls else 0


def temporary_beside(path):
    """A fresh hidden name in the directory of `path` (the rename stays within one file system, so it is atomic)."""
    global _temporaries
    _temporaries += 1
    folder, name = os.path.split(path)
    return os.path.join(folder, ".%s.tmp.%d.%d" % (name, os.getpid(), _temporaries))


def fsync_path(path):
    """fsync of a file or a directory; a file system that cannot sync a directory (EINVAL, ENOTSUP) is no failure."""
    err = fault_point("fsync", path)
    if err:
        raise WriteFailed(err, "cannot sync '%s'" % path)
    fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    except OSError as e:
        if e.errno not in (errno.EINVAL, errno.ENOTSUP):
            raise WriteFailed(e.errno, "cannot sync '%s'" % path) from None
    finally:
        os.close(fd)


def _write_all(fd, data, path, dest):
    view = memoryview(data)
    while view:
        err = fault_point("write", path)
        if err:
            raise WriteFailed(err, "cannot write '%s'" % dest)
        try:
            n = os.write(fd, view[:_CHUNK])
        except OSError as e:
            raise WriteFailed(e.errno, "cannot write '%s'" % dest) from None
        view = view[n:]


def write_atomically(dest, chunks):
    """Replaces (or creates) `dest` with the bytes of `chunks` (bytes, or an iterable of bytes), atomically. On
    failure the temporary is removed and `dest` is as it was, unless only the directory's sync after the rename
    failed (then `dest` is the complete new file, and the error is still raised)."""
    if isinstance(chunks, (bytes, bytearray, memoryview)):
        chunks = (chunks,)
    tmp = temporary_beside(dest)
    try:
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except OSError as e:
            raise WriteFailed(e.errno, "cannot create '%s'" % tmp) from None
        try:
            for c in chunks:
                _write_all(fd, c, tmp, dest)
        finally:
            os.close(fd)
        fsync_path(tmp)
        err = fault_point("rename", dest)
        if err:
            raise WriteFailed(err, "cannot rename '%s' to '%s'" % (tmp, dest))
        try:
            os.replace(tmp, dest)
        except OSError as e:
            raise WriteFailed(e.errno, "cannot rename '%s' to '%s'" % (tmp, dest)) from None
    except BaseException:
        try:
            os.remove(tmp)
        except FileNotFoundError:
            pass
        raise
    fsync_path(os.path.dirname(dest) or ".")


def file_chunks(path):
    """The bytes of the file `path`, a chunk at a time (a copy that does not hold a large file in memory)."""
    with open(path, "rb") as f:
        while True:
            c = f.read(_CHUNK)
            if not c:
                return
            yield c


def h5_image(build):
    """The bytes of a new HDF5 file that build(f) fills (f: an h5py.File open for writing, in memory)."""
    import h5py
    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        build(f)
    return buf.getvalue()
