#!/usr/bin/env python3
"""`pip install ./python` into a virtual environment works, and the reader's tests pass on the installed copy.

A venv is created with --system-site-packages (numpy and h5py from Debian's python3-numpy and python3-h5py) and
python/ is installed into it with pip --no-index --no-build-isolation --no-deps, so nothing is downloaded:
setuptools is Debian's too (and Debian's h5py does not register as the distribution h5py, so pip could not find it). The package is built from a copy of python/ (a build writes build/ and *.egg-info beside the sources).
Then tests/python/test_reader.py runs under the venv's interpreter with CAPSFLOW_READER_INSTALLED=1, importing the
installed capsflow, whose location is checked to be inside the venv.

    tests/python/test_pip_install.py CAPSFLOW SOURCE_DIR WORKDIR   # as ctest runs it (exit 77: venv or pip missing)
"""
import importlib.util
import os
import shutil
import subprocess
import sys

SKIP = 77


def run(cmd, env, cwd=None):
    p = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        sys.exit("FAIL: %s exited %d\nstdout:\n%s\nstderr:\n%s" % (" ".join(cmd), p.returncode, p.stdout, p.stderr))
    return p


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: test_pip_install.py CAPSFLOW SOURCE_DIR WORKDIR")
    exe, src, work = (os.path.abspath(a) for a in sys.argv[1:])
    for mod in ("venv", "ensurepip", "numpy", "h5py"):
        if importlib.util.find_spec(mod) is None:
            print("SKIP: %s lacks the module %s (python3-venv, python3-numpy, python3-h5py)" % (sys.executable, mod))
            return SKIP
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PIP_INDEX_URL", "PIP_EXTRA_INDEX_URL")}
    env.update(PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONDONTWRITEBYTECODE="1", PIP_NO_CACHE_DIR="1")
    venv = os.path.join(work, "venv")
    run([sys.executable, "-m", "venv", "--system-site-packages", venv], env)
    py = os.path.join(venv, "bin", "python")
    pkg = os.path.join(work, "python")
    shutil.copytree(os.path.join(src, "python"), pkg, ignore=shutil.ignore_patterns("__pycache__", "build",
                                                                                  "*.egg-info"))
    # --no-deps: Debian registers its h5py as the distribution "h5py._debian_h5py_serial", which pip does not take
    # for h5py; the dependencies are there (checked above: numpy and h5py import), and declared (pip show, below).
    run([py, "-m", "pip", "install", "--no-index", "--no-build-isolation", "--no-deps", pkg], env)

    # The installed copy, not the source's: imported from outside the checkout, found in the venv's site-packages.
    p = run([py, "-c", "import capsflow, os; print(os.path.realpath(capsflow.__file__))"], env, cwd=work)
    where = p.stdout.strip()
    if not where.startswith(os.path.realpath(venv) + os.sep):
        sys.exit("FAIL: capsflow imported from %s, not from the venv %s" % (where, venv))
    p = run([py, "-m", "pip", "show", "capsflow"], env)
    for need in ("Version: 0.1.0", "Requires: h5py, numpy"):
        if need not in p.stdout:
            sys.exit("FAIL: pip show capsflow lacks %r:\n%s" % (need, p.stdout))

    # The reader's own tests on the installed copy.
    env_t = dict(env, CAPSFLOW_READER_INSTALLED="1", OMP_NUM_THREADS="1")
    run([py, os.path.join(src, "tests", "python", "test_reader.py"), exe, os.path.join(work, "reader")], env_t,
        cwd=work)
    print("ok: pip installed capsflow into a venv (%s) and test_reader.py passed on that copy" % where)
    return 0


if __name__ == "__main__":
    sys.exit(main())
