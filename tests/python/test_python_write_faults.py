#!/usr/bin/env python3
"""Every write of the Python tools under an injected I/O error (issue 55), as tests/test_write_faults.cpp does for the
C++ program: `capsflow figures` (its PNG and SVG files, from a run and from an analysis) and tools/run_store.py (a
save of the base, a save of a part, a restore), each through tools/capsflow_atomic.py; and `capsflow render`'s
outputs, which pvbatch draws (its own writers, not counted) and capsflow puts into place through its atomic-file
helpers (counted by the C++ injection). The render scenario is skipped, with a line saying so, where pvbatch or a
display (or xvfb-run) is missing, unless CAPSFLOW_REQUIRE_RENDER=1.

Each scenario is run once with CAPSFLOW_TEST_FAULT_LOG to count its calls (each write, the syncs, the rename), then
once per call N with CAPSFLOW_TEST_FAULT_AT=N (that call and every later one fail; ENOSPC for even N, EIO for odd N).
For every N:
- exit status 1, and on stderr one line, from the tool, naming the file of the failed call and the system's reason;
- the same first N calls as the run without a fault (the count is a property of the command);
- no temporary `.NAME.tmp.PID.K` (nor render's directory `.render.tmp.PID`) left;
- every file in the folder is as it was before the command, or, where the command had renamed it into place before
  the fault, the complete new file of the run without a fault (a store gains no file: a new base or part whose
  directory sync failed is removed);
- the fault lifted, the same command again gives the files of the run without a fault: figures byte for byte, HDF5
  files in every dataset, attribute and creation property (run_store.describe_differences: a group's creation time,
  which HDF5 stores, differs between two saves).

Which N: every one with CAPSFLOW_TEST_FAULT_STRIDE=1 (ctest label `faults`); otherwise (the default suite, which
must stay short: each figures run takes seconds, each render ten) every call of the run store, calls 1, 6 and 7 of
the run's figure (each kind of call once), call 13 of the study's figures, calls 1, 2 and 5 of the render, the last
call of each, and every second fault rerun.

    tests/python/test_python_write_faults.py CAPSFLOW_BINARY WORKDIR     # exit 77: skipped
"""

import errno
import os
import re
import shutil
import subprocess
import sys

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
STORE_TOOL = os.path.join(SOURCE_DIR, "tools", "run_store.py")
sys.path.insert(0, os.path.join(SOURCE_DIR, "tools"))

try:
    import h5py  # noqa: F401  (run_store needs it)
    import matplotlib  # noqa: F401  (capsflow figures needs it)
    import run_store
except ImportError as e:  # pragma: no cover - depends on the machine
    print("SKIP: needs numpy, h5py and matplotlib (%s)" % e)
    sys.exit(SKIP)

FULL = os.environ.get("CAPSFLOW_TEST_FAULT_STRIDE") == "1"
TEMPORARY = re.compile(r"^\..+\.tmp\.\d+\.\d+$")
TEMPORARY_DIR = re.compile(r"^\.render\.tmp\.\d+$")
REASON = {errno.ENOSPC: "No space left on device", errno.EIO: "Input/output error"}

# The C++ sweep's tiny run: one level-1 capsule, serial, to strain 0.5, records every 0.1, frames and checkpoints
# every 0.25, a coarse grid (a quarter second).
CONFIG = """[domain]
H = 6.0
Lx = 8.0
Lz = 8.0
[ggem]
alpha = 2.0
alpha_hm = 0.5
[run]
backend = "serial"
[capsules]
mesh_level = 1
[[species]]
name = "stiff"
ca = 0.2
[[capsule]]
species = "stiff"
center = [4.0, 3.0, 4.0]
[time]
end = 0.5
[output]
file = "output.h5"
every = 0.1
frames_every = 0.25
checkpoint_every = 0.25
"""

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)
    return cond


def run(cmd, cwd, env_extra=None):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    for k in ("CAPSFLOW_TEST_FAULT_AT", "CAPSFLOW_TEST_FAULT_ERRNO", "CAPSFLOW_TEST_FAULT_LOG"):
        env.pop(k, None)
    env.update(env_extra or {})
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, env=env)


def must(cmd, cwd):
    r = run(cmd, cwd)
    if r.returncode != 0:
        raise AssertionError("%s in %s: exit %d\n%s%s" % (" ".join(cmd), cwd, r.returncode, r.stdout, r.stderr))


def snapshot(folder):
    """Every file below `folder`: relative path -> bytes, the folder's own path in a text file (the ParaView state
    names the run's index by its absolute path) read as "<DIR>", so that copies in two folders compare equal."""
    files = {}
    here = os.path.abspath(folder).encode()
    for root, _, names in os.walk(folder):
        for n in names:
            p = os.path.join(root, n)
            with open(p, "rb") as f:
                data = f.read()
            files[os.path.relpath(p, folder)] = data if p.endswith(".h5") else data.replace(here, b"<DIR>")
    return files


def read_log(path):
    calls = []
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            for line in f:
                _, kind, name = line.rstrip("\n").split(" ", 2)
                calls.append((kind, name))
    return calls


def target_of(name):
    """The file a call's path stands for: a temporary's target, else the path itself."""
    folder, leaf = os.path.split(name)
    if TEMPORARY.match(leaf):
        leaf = leaf[1:leaf.index(".tmp.")]
    return os.path.join(folder, leaf)


def same_file(rel, a, b):
    """Two versions of a file the same: HDF5 files in content (every dataset, attribute, creation property), others
    byte for byte. None: absent."""
    if a is None or b is None:
        return a is None and b is None
    if rel.endswith(".h5") and a != b:
        import io
        return run_store.describe_differences(io.BytesIO(a), io.BytesIO(b)) == []
    return a == b


class Scenario:
    def __init__(self, name, setup, command, prefix, results, sample):
        self.name, self.setup, self.command, self.prefix = name, setup, command, prefix
        self.results = results      # files (relative) the rerun must give as the run without a fault did
        self.sample = sample        # n, calls -> whether the default suite fails call n


def sweep(s, work):
    base, ref = os.path.join(work, "base"), os.path.join(work, "reference")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(base)
    s.setup(base)
    before = snapshot(base)
    shutil.copytree(base, ref)
    count_log = os.path.join(work, "count.log")
    r = run(s.command, ref, {"CAPSFLOW_TEST_FAULT_LOG": count_log})
    if not check(r.returncode == 0, "%s: the run without a fault: exit %d: %s" % (s.name, r.returncode, r.stderr)):
        return 0
    calls = read_log(count_log)
    check(len(calls) > 0, "%s: no call counted: the injection is not reached" % s.name)
    want = snapshot(ref)
    for rel in s.results:
        check(rel in want, "%s: the run without a fault did not write %s" % (s.name, rel))

    failed = rerun = 0
    for n in range(1, len(calls) + 1):
        if not (FULL or s.sample(n, len(calls)) or n == len(calls)):
            continue
        failed += 1
        err = errno.EIO if n % 2 else errno.ENOSPC
        kind, name = calls[n - 1]
        what = "%s: call %d of %d (%s %s, %s)" % (s.name, n, len(calls), kind, name, errno.errorcode[err])
        d = os.path.join(work, "n")
        shutil.rmtree(d, ignore_errors=True)
        shutil.copytree(base, d)
        log = os.path.join(work, "n.log")
        if os.path.exists(log):
            os.remove(log)
        r = run(s.command, d, {"CAPSFLOW_TEST_FAULT_AT": str(n), "CAPSFLOW_TEST_FAULT_ERRNO": errno.errorcode[err],
                               "CAPSFLOW_TEST_FAULT_LOG": log})
        # Exit 1 and one line naming the file and the reason.
        check(r.returncode == 1, "%s: exit %d, not 1: %s" % (what, r.returncode, r.stderr))
        lines = r.stderr.splitlines()
        line = lines[0] if lines else ""
        check(len(lines) == 1, "%s: %d lines on stderr, not one: %r" % (what, len(lines), r.stderr))
        check(line.startswith(s.prefix), "%s: the line does not start with %r: %r" % (what, s.prefix, line))
        check(REASON[err] in line, "%s: the reason %r is not in %r" % (what, REASON[err], line))
        done = read_log(log)
        if not check([k for k, _ in done[:n]] == [k for k, _ in calls[:n]],
                     "%s: the faulted run did not make the same first %d calls as the run without a fault" % (what, n)):
            break
        name = done[n - 1][1]  # its own temporary's name (the process id in it)
        check(name in line or target_of(name) in line, "%s: the file %s is not named in %r" % (what, name, line))
        after = snapshot(d)
        for rel in after:
            check(not TEMPORARY.match(os.path.basename(rel)) and
                  not any(TEMPORARY_DIR.match(c) for c in rel.split(os.sep)), "%s: temporary left: %s" % (what, rel))
        # Each file as it was, or the complete new one where the command had renamed it into place before the fault.
        renamed = {os.path.normpath(f) for k, f in done[:n - 1] if k == "rename"}
        for rel in sorted(set(before) | set(after)):
            if TEMPORARY.match(os.path.basename(rel)):
                continue
            old, new = before.get(rel), after.get(rel)
            if old == new:
                continue
            check(os.path.normpath(rel) in renamed and same_file(rel, new, want.get(rel)),
                  "%s: %s changed (%s) without being renamed into place complete" %
                  (what, rel, "removed" if new is None else "created" if old is None else "rewritten"))
        if not FULL and (failed - 1) % 2 and n != len(calls):
            continue
        rerun += 1
        r = run(s.command, d)
        if check(r.returncode == 0, "%s: the rerun: exit %d: %s" % (what, r.returncode, r.stderr)):
            again = snapshot(d)
            for rel in s.results:
                check(same_file(rel, again.get(rel), want.get(rel)),
                      "%s: the rerun's %s differs from the run without a fault's" % (what, rel))
    print("[ faults   ] %s: %d counted calls; %d failed one by one, %d of them rerun and compared%s"
          % (s.name, len(calls), failed, rerun, " (the full sweep)" if FULL else ""), flush=True)
    return len(calls)


def main(binary, work):
    if not os.access(binary, os.X_OK):
        print("SKIP: no capsflow executable at %s" % binary)
        return SKIP
    py = sys.executable
    store = [py, STORE_TOOL]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    every = lambda n, calls: True  # noqa: E731  (a scenario of a few calls: all of them)

    def tiny_run(d):
        os.makedirs(d, exist_ok=True)
        with open(os.path.join(d, "c.toml"), "w") as f:
            f.write(CONFIG)
        must([binary, "run", "c.toml", "-q", "--progress", "0"], d)

    def figures_of_a_run(d):
        tiny_run(d)
        # Files the figures replace (--force): old contents that must stay until their rename.
        os.makedirs(os.path.join(d, "figs"))
        for ext in ("png", "svg"):
            with open(os.path.join(d, "figs", "output_run_diagnostics." + ext), "w") as f:
                f.write("an older figure\n")

    def render_of_a_run(d):
        tiny_run(d)
        os.makedirs(os.path.join(d, "pics"))
        for name in ("output_species_f0002.png", "output_species.pvsm"):
            with open(os.path.join(d, "pics", name), "w") as f:
                f.write("an older picture\n")

    def figures_of_an_analysis(d):
        tiny_run(os.path.join(d, "r"))
        must([binary, "analyze", "r", "--out", "a", "-q"], d)

    def stored_run(d):
        """r/ continued to 0.75 after its base was saved into s/."""
        tiny_run(os.path.join(d, "r"))
        must(store + ["save", "r", "s"], d)
        must([binary, "run", "--restart", "output.checkpoint.h5", "--end", "0.75", "-q", "--progress", "0"],
             os.path.join(d, "r"))

    def store_to_restore(d):
        """s/ holding a base and a part; q/output.h5 an older output (the base's run) that the restore replaces."""
        stored_run(d)
        must(store + ["save", "r", "s"], d)
        os.makedirs(os.path.join(d, "q"))
        shutil.copyfile(os.path.join(d, "s", "output.h5"), os.path.join(d, "q", "output.h5"))

    scenarios = [
        Scenario("capsflow figures of a run", figures_of_a_run,
                 [binary, "figures", "output.h5", "--out", "figs", "--force"], "capsflow: error: ",
                 ["figs/output_run_diagnostics.png", "figs/output_run_diagnostics.svg"],
                 lambda n, calls: n in (1, 6, 7)),  # the PNG's write, the SVG's sync and rename (and the last)
        Scenario("capsflow figures of an analysis", figures_of_an_analysis,
                 [binary, "figures", "a", "--out", "figs", "--force"], "capsflow: error: ",
                 ["figs/fig03_dbar_t.png", "figs/fig03_dbar_t.svg", "figs/fig09_pdf.svg"],
                 lambda n, calls: n == 13),  # a write in the middle of the study (and the last call)
        Scenario("run_store.py save (the base)", lambda d: tiny_run(os.path.join(d, "r")),
                 store + ["save", "r", "s"], "run_store.py: ", ["s/output.h5"], every),
        Scenario("run_store.py save (a part)", stored_run, store + ["save", "r", "s"], "run_store.py: ",
                 ["s/output.h5", "s/output.part-001.h5"], every),
        Scenario("run_store.py restore", store_to_restore, store + ["restore", "s", "q"], "run_store.py: ",
                 ["q/output.h5"], every),
    ]
    lack = [p for p in ("pvbatch",) if shutil.which(p) is None]
    if not os.environ.get("DISPLAY") and shutil.which("xvfb-run") is None:
        lack.append("xvfb-run (no DISPLAY)")
    if lack and os.environ.get("CAPSFLOW_REQUIRE_RENDER") == "1":
        check(False, "capsflow render: needs %s (CAPSFLOW_REQUIRE_RENDER=1)" % ", ".join(lack))
    elif lack:
        print("[ faults   ] capsflow render: skipped (no %s)" % ", ".join(lack))
    else:
        # Calls: the folder's lock's write, the job's write, then the picture's write, sync, rename and the
        # directory's sync, then the state's sync, rename and the directory's. A render takes seconds: the default
        # suite fails the lock's write, the job's write, the picture's rename and the last call.
        scenarios.append(Scenario("capsflow render", render_of_a_run,
                                  [binary, "render", "output.h5", "--out", "pics", "--force", "-q"],
                                  "capsflow: error: ", ["pics/output_species_f0002.png", "pics/output_species.pvsm"],
                                  lambda n, calls: n in (1, 2, 5)))
    only = os.environ.get("CAPSFLOW_TEST_FAULT_SCENARIO")  # a name's start: one scenario (the full sweep's split)
    for i, s in enumerate(scenarios):
        if only and not s.name.startswith(only):
            continue
        sweep(s, os.path.join(work, str(i)))
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    print("python write faults: passed")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])))
