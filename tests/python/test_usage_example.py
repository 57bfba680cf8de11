#!/usr/bin/env python3
"""docs/usage.md's Python example ("Reading outputs from Python") runs as printed on the README demo's outputs.

The demo (`capsflow run` without a configuration) is cut to 0.3 strain and analysed into capsflow-run-demo/analysis,
as tools/demo.sh does; the example's code block is taken from the page and run in that directory with matplotlib's
non-interactive backend, so a renamed path, attribute or call in the example fails here.

    tests/python/test_usage_example.py CAPSFLOW SOURCE_DIR WORKDIR   # as ctest runs it (exit 77: a module missing)
"""
import importlib.util
import os
import shutil
import subprocess
import sys

SKIP = 77
MARK = "With the outputs of the README demo"


def example_code(usage_md):
    """The ```python block that follows MARK on the page."""
    with open(usage_md, encoding="utf-8") as f:
        text = f.read()
    at = text.find(MARK)
    if at < 0:
        sys.exit("FAIL: %s has no paragraph starting %r" % (usage_md, MARK))
    start = text.find("```python\n", at)
    end = text.find("\n```", start + 10)
    if start < 0 or end < 0:
        sys.exit("FAIL: no ```python block after %r in %s" % (MARK, usage_md))
    return text[start + len("```python\n"):end + 1]


def run(cmd, cwd, env):
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        sys.exit("FAIL: %s exited %d\nstdout:\n%s\nstderr:\n%s" % (" ".join(cmd), p.returncode, p.stdout, p.stderr))
    return p


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: test_usage_example.py CAPSFLOW SOURCE_DIR WORKDIR")
    for mod in ("numpy", "h5py", "matplotlib"):
        if importlib.util.find_spec(mod) is None:
            print("SKIP: %s lacks the module %s (python3-%s)" % (sys.executable, mod, mod))
            return SKIP
    exe, src, work = (os.path.abspath(a) for a in sys.argv[1:])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    env = dict(os.environ, OMP_NUM_THREADS="1", MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1",
               PYTHONPATH=os.path.join(src, "python"))
    run([exe, "run", "--end", "0.3", "--progress", "0"], work, env)  # the demo, short: capsflow-run-demo/demo.h5
    run([exe, "analyze", "capsflow-run-demo/demo.h5", "--out", "capsflow-run-demo/analysis"], work, env)
    code = example_code(os.path.join(src, "docs", "usage.md"))
    with open(os.path.join(work, "example.py"), "w", encoding="utf-8") as f:
        f.write(code)
    p = run([sys.executable, "example.py"], work, env)
    if "v-bar_p of the stiff capsules: " not in p.stdout:
        sys.exit("FAIL: the example did not reach its print line:\n" + p.stdout + p.stderr)
    print("ok: docs/usage.md's Python example runs on the demo's run and analysis (%d lines)" % code.count("\n"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
