#!/usr/bin/env python3
"""Check that the program output quoted in the docs is what the program prints.

A sample is a fenced block right after a marker line

    <!-- sample: ARGS -->

where ARGS are the arguments of the capsflow executable (run from the repository root, OMP_NUM_THREADS=2,
"{tmp}" replaced by a fresh temporary directory). The command must exit with status 0, or with N where the marker
says so (`<!-- sample exit 2: ARGS -->`, a refusal quoted in the docs). Every line of the block must match a line of
the command's output (stdout, then stderr), in order; two kinds of wildcards keep samples readable and
machine-independent:

  - "..." inside a line matches any text (a timing, a memory size, a path);
  - a line that is only "..." skips any number of output lines.

A first block line that is the command as the reader would type it ("capsflow ARGS", "{tmp}/" left out) is not
matched; the rest must quote some output.

    tools/doc_samples.py --binary build/release/capsflow docs/usage.md docs/presets.md     # check: exit 1 on drift

On drift the block, the command and its actual output are printed, so that the doc can be mended by hand. A document
named here that holds no sample fails too (a check of nothing must not pass). Run by ctest (doc_samples) so that
numbers the docs quote from the program cannot drift again; tests/python/test_doc_samples.py holds the checker.
"""
import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile

MARKER = re.compile(r"^<!--\s*sample(?:\s+exit\s+(\d+))?:\s*(.*?)\s*-->\s*$")


def samples(path):
    """(line number, args, expected exit status, block lines) of every marked sample of a markdown file."""
    lines = open(path, encoding="utf-8").read().split("\n")
    out = []
    i = 0
    while i < len(lines):
        m = MARKER.match(lines[i])
        if not m:
            i += 1
            continue
        j = i + 1
        if j >= len(lines) or not lines[j].startswith("```"):
            raise SystemExit(f"{path}:{i + 1}: a sample marker must be followed by a fenced block")
        k = j + 1
        while k < len(lines) and not lines[k].startswith("```"):
            k += 1
        if k >= len(lines):
            raise SystemExit(f"{path}:{j + 1}: the sample's block is not closed")
        block = lines[j + 1:k]
        args = m.group(2)
        if block and block[0].strip() in ("capsflow " + args, "capsflow " + args.replace("{tmp}/", "")):
            block = block[1:]
        if not any(line.strip() and line.strip() != "..." for line in block):
            raise SystemExit(f"{path}:{j + 1}: the sample's block quotes no output of `capsflow {args}`")
        out.append((i + 1, args, int(m.group(1) or 0), block))
        i = k + 1
    return out


def line_pattern(doc_line):
    parts = doc_line.rstrip().split("...")
    return re.compile("^" + ".*?".join(re.escape(p) for p in parts) + r"\s*$")


def matches(block, output_lines):
    """None when every block line matches in order, else the first block line that does not."""
    pos = 0
    skipping = False
    for doc_line in block:
        if doc_line.strip() == "...":
            skipping = True
            continue
        pat = line_pattern(doc_line)
        if skipping:
            while pos < len(output_lines) and not pat.match(output_lines[pos]):
                pos += 1
            if pos == len(output_lines):
                return doc_line
            pos += 1
        else:
            # Without a skip, the next output line must match (blank output lines are skipped).
            while pos < len(output_lines) and not output_lines[pos].strip() and doc_line.strip():
                pos += 1
            if pos == len(output_lines) or not pat.match(output_lines[pos]):
                return doc_line
            pos += 1
        skipping = False
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", required=True, help="the capsflow executable")
    ap.add_argument("--root", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                    help="repository root (the commands run there)")
    ap.add_argument("docs", nargs="+")
    a = ap.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS="2")
    failures = 0
    count = 0
    for doc in a.docs:
        found = samples(doc)
        if not found:
            failures += 1
            print(f"{doc}: no sample (<!-- sample: ARGS --> before a fenced block): a document checked here must "
                  f"quote at least one")
        for line_no, args, status, block in found:
            count += 1
            with tempfile.TemporaryDirectory(prefix="capsflow-doc-sample-") as tmp:
                argv = [a.binary] + [x.replace("{tmp}", tmp) for x in shlex.split(args)]
                r = subprocess.run(argv, cwd=a.root, env=env, capture_output=True, text=True, timeout=600)
                out = (r.stdout + r.stderr).replace(tmp, "{tmp}").split("\n")
            bad = matches(block, out)
            if r.returncode != status:
                failures += 1
                print(f"{doc}:{line_no}: `capsflow {args}` exited with status {r.returncode}, the sample says "
                      f"{status} (`<!-- sample exit N: ... -->` for a command that fails on purpose); it printed:")
                for o in out:
                    print("    | " + o)
            elif bad is not None:
                failures += 1
                print(f"{doc}:{line_no}: the sample of `capsflow {args}` has drifted (exit {r.returncode});"
                      f" first line not printed by the program:\n    {bad}\n  the program printed:")
                for o in out:
                    print("    | " + o)
    print(f"doc_samples: {count} samples checked, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
