#!/usr/bin/env python3
"""The installed tree: `cmake --install BUILD --prefix PREFIX` lays out what a user runs, and it works from there.

Checks the layout (bin/capsflow; share/capsflow with the figure script, examples and docs; the Python package under
lib/python3.X/dist-packages), that an install to the prefix /usr (as the .deb's: CPack installs with the prefix /usr into
a DESTDIR) puts the package under the version-independent lib/python3/dist-packages, then, with nothing from the source or build tree on any path: the installed capsflow
runs the embedded demo for a few steps, `capsflow figures` draws the run's diagnostics with the installed script
(found as <bin>/../share/capsflow), `capsflow analyze` and `capsflow figures` turn the run into the study's figures,
and `import capsflow` from the installed package reads the run and the analysis back.

    tests/python/test_install.py BUILD_DIR WORKDIR     # as ctest runs it (exit 77: skipped, a module missing)
"""
import importlib.util
import os
import shutil
import subprocess
import sys

SKIP = 77


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def run(cmd, cwd, env):
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        fail("%s exited %d\nstdout:\n%s\nstderr:\n%s" % (" ".join(cmd), p.returncode, p.stdout, p.stderr))
    return p


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: test_install.py BUILD_DIR WORKDIR")
    for mod in ("numpy", "h5py", "matplotlib"):
        if importlib.util.find_spec(mod) is None:
            print("SKIP: %s lacks the module %s (python3-%s)" % (sys.executable, mod, mod))
            return SKIP
    build, work = (os.path.abspath(a) for a in sys.argv[1:])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    prefix = os.path.join(work, "prefix")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "CAPSFLOW_PYTHON")}
    env["OMP_NUM_THREADS"] = "1"
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    run(["cmake", "--install", build, "--prefix", prefix], work, env)

    exe = os.path.join(prefix, "bin", "capsflow")
    share = os.path.join(prefix, "share", "capsflow")
    for path in (exe, os.path.join(share, "capsflow_figures.py"), os.path.join(share, "capsflow_render.py"),
                 os.path.join(share, "capsflow_flow.py"),
                 os.path.join(share, "capsflow_atomic.py"),
                 os.path.join(share, "README.md"), os.path.join(share, "LICENSE"), os.path.join(share, "CITATION.cff"),
                 os.path.join(prefix, "share", "doc", "capsflow", "copyright"),
                 os.path.join(share, "examples", "presets", "set_a.toml"),
                 os.path.join(share, "examples", "sweeps", "reproduction.toml"),
                 os.path.join(share, "docs", "usage.md"), os.path.join(share, "docs", "output_format.md")):
        if not os.path.isfile(path):
            fail("not installed: " + os.path.relpath(path, prefix))
    if not os.access(exe, os.X_OK):
        fail("bin/capsflow is not executable")
    site = [os.path.join(prefix, "lib", d, "dist-packages") for d in os.listdir(os.path.join(prefix, "lib"))
            if d.startswith("python3")]
    site = [d for d in site if os.path.isfile(os.path.join(d, "capsflow", "__init__.py"))]
    if len(site) != 1:
        fail("expected the package capsflow under exactly one lib/python3*/dist-packages, found %d" % len(site))
    if "__pycache__" in os.listdir(os.path.join(site[0], "capsflow")):
        fail("a __pycache__ was installed with the package")

    # The prefix /usr, as CPack's DEB generator installs (DESTDIR set): Debian's version-independent
    # lib/python3/dist-packages, which every python3 3.X searches; nothing under a lib/python3.X (issue 37, finding 7).
    stage = os.path.join(work, "stage")
    run(["cmake", "--install", build, "--prefix", "/usr"], work, dict(env, DESTDIR=stage))
    usr_lib = os.path.join(stage, "usr", "lib")
    if not os.path.isfile(os.path.join(usr_lib, "python3", "dist-packages", "capsflow", "__init__.py")):
        fail("an install to /usr lacks lib/python3/dist-packages/capsflow/__init__.py: " + str(os.listdir(usr_lib)))
    versioned = [d for d in os.listdir(usr_lib) if d.startswith("python3.")]
    if versioned:
        fail("an install to /usr wrote under a Python minor version: " + ", ".join(versioned))
    shutil.rmtree(stage)

    # The installed program, from a directory outside the source and build trees.
    run([exe, "run", "--end", "0.3", "--output", "demo/demo.h5", "--progress", "0"], work, env)
    run([exe, "analyze", "demo/demo.h5", "--out", "analysis"], work, env)
    run([exe, "figures", "analysis", "demo/demo.h5", "--out", "figures"], work, env)
    for f in ("demo_run_diagnostics.png", "demo_run_diagnostics.svg"):
        if not os.path.getsize(os.path.join(work, "figures", f)):
            fail("figures/%s is empty" % f)

    # The installed render script, where ParaView is (tests/python/test_render.py checks the pictures themselves).
    if shutil.which("pvbatch") and (os.environ.get("DISPLAY") or shutil.which("xvfb-run")):
        run([exe, "render", "demo/demo.h5", "--out", "pictures", "--size", "320x240", "-q"], work, env)
        if not os.path.getsize(os.path.join(work, "pictures", "demo_species_f0000.png")):
            fail("pictures/demo_species_f0000.png is empty")

    # The installed package, on the path by PYTHONPATH (the prefix is not the system's).
    code = ("import capsflow, sys\n"
            "assert capsflow.__file__.startswith(sys.argv[1]), capsflow.__file__\n"
            "with capsflow.open_run('demo/demo.h5') as r:\n"
            "    assert r.series.time[-1] >= 0.3, r.series.time[-1]\n"
            "    assert r.series.centroid.shape[1] == 8, r.series.centroid.shape\n"
            "a = capsflow.open_analysis('analysis')\n"
            "assert len(a.suspension_groups()) == 1\n"
            "print('ok', capsflow.__file__)\n")
    penv = dict(env, PYTHONPATH=site[0])
    out = run([sys.executable, "-c", code, site[0]], work, penv).stdout
    if not out.startswith("ok"):
        fail("the installed package did not read the run: " + out)
    print("installed tree works: " + prefix)
    return 0


if __name__ == "__main__":
    sys.exit(main())
