#!/usr/bin/env python3
"""Docs that stand alone: no file of the repository points outside it, and no Markdown link points at nothing.

A clone has only what is committed, so every reference a reader may follow must resolve inside the checkout. This
tool reads every text file that git tracks (or, outside a git checkout, every file under the tree) and fails on:

  - a path into the development machine's shared folder (`../shared/...`, `shared/docs/...`, `shared/reference/...`)
    or an absolute path under /work/ (a workspace a clone does not have);
  - a relative Markdown link `[text](target)` (in a *.md file) whose target leaves the repository or does not exist
    (web links, mail links and in-page anchors are not checked; `path#anchor` checks the path).

    tools/check_links.py [ROOT]        # exit 0: clean; 1: each offence printed as FILE:LINE: what
    tools/check_links.py --self-test   # plants a bad link and an outside path in a temporary tree; exit 0 if both
                                       # are found (ctest doc_links runs both)

Binary files (a NUL byte or not UTF-8) are skipped.
"""
import os
import re
import subprocess
import sys
import tempfile

# A path leaving the repository: the shared folder beside the checkouts, or an absolute /work/ path.
OUTSIDE = re.compile(r"(?<![\w/.-])(?:\.\./)+shared(?:/|\b)|(?<![\w/.-])shared/(?:docs|reference)/|(?<![\w.~-])/work/")
# [text](target "title"): the target up to a space or the closing parenthesis. Images ![..](..) too.
MD_LINK = re.compile(r"!?\[[^\]\n]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def tracked_files(root):
    """Files git tracks under ROOT (what a clone has); every file when ROOT is not a git checkout."""
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], capture_output=True, check=True).stdout
        return [p for p in out.decode("utf-8", "replace").split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, dirs, names in os.walk(root):
            dirs[:] = [x for x in dirs if x not in (".git", "build")]
            files += [os.path.relpath(os.path.join(d, n), root) for n in names]
        return files


def read_text(path):
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return None
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


def check(root):
    root = os.path.realpath(root)
    problems = []
    for rel in sorted(tracked_files(root)):
        path = os.path.join(root, rel)
        if rel == "tools/check_links.py" or not os.path.isfile(path):
            continue  # this file names the patterns it looks for
        text = read_text(path)
        if text is None:
            continue
        fenced = False
        for n, line in enumerate(text.splitlines(), 1):
            for m in OUTSIDE.finditer(line):
                problems.append("%s:%d: a path outside the repository: %r" % (rel, n, line[m.start():m.start() + 60]))
            if not rel.endswith(".md"):
                continue
            if line.lstrip().startswith("```"):
                fenced = not fenced
            if fenced or line.startswith(("    ", "\t")):
                continue  # Markdown renders no link in a code block or a code span: `S[f](x_i)` is a formula
            for m in MD_LINK.finditer(re.sub(r"`[^`]*`", "", line)):
                target = m.group(1)
                if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
                    continue  # a web or mail link, or an anchor on this page
                file_part = target.split("#", 1)[0]
                if file_part.startswith("/"):
                    problems.append("%s:%d: an absolute link: %s" % (rel, n, target))
                    continue
                resolved = os.path.realpath(os.path.join(os.path.dirname(path), file_part))
                if resolved != root and not resolved.startswith(root + os.sep):
                    problems.append("%s:%d: a link leaving the repository: %s" % (rel, n, target))
                elif not os.path.exists(resolved):
                    problems.append("%s:%d: a link to a file that does not exist: %s" % (rel, n, target))
    return problems


def self_test():
    """The checker finds what it is for: a planted bad link, a link out of the tree and an outside path."""
    with tempfile.TemporaryDirectory() as d:
        os.makedirs(os.path.join(d, "docs"))
        with open(os.path.join(d, "docs", "good.md"), "w") as f:
            f.write("[ok](good.md) [web](https://example.org) [anchor](#x) [up](../README.md) `S[f](x_i)`\n"
                    "```\nu = S[f](x)\n```\n\n    K[q](x) = S[f](x)\n")
        with open(os.path.join(d, "README.md"), "w") as f:
            f.write("see [docs](docs/good.md#top)\n")
        clean = check(d)
        if clean:
            print("FAIL: a clean tree reported:\n  " + "\n  ".join(clean))
            return 1
        with open(os.path.join(d, "docs", "bad.md"), "w") as f:
            f.write("[missing](nothere.md)\n[out](../../elsewhere.md)\nsee ../shared/docs/spec.md\n")
        with open(os.path.join(d, "tool.py"), "w") as f:
            f.write("# defined in /work/shared/x\n")
        found = check(d)
        want = ["docs/bad.md:1: a link to a file that does not exist", "docs/bad.md:2: a link leaving the repository",
                "docs/bad.md:3: a path outside the repository", "tool.py:1: a path outside the repository"]
        missing = [w for w in want if not any(p.startswith(w) for p in found)]
        if missing or len(found) != len(want):
            print("FAIL: expected %s, found %s" % (want, found))
            return 1
    print("ok: the checker finds a missing link target, a link out of the tree and paths outside the repository")
    return 0


def main():
    args = sys.argv[1:]
    if args == ["--self-test"]:
        return self_test()
    if len(args) > 1 or (args and args[0].startswith("-")):
        print("usage: check_links.py [ROOT] | --self-test", file=sys.stderr)
        return 2
    root = args[0] if args else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    if not os.path.isdir(root):
        print("check_links.py: error: %s is not a directory" % root, file=sys.stderr)
        return 2
    problems = check(root)
    for p in problems:
        print(p)
    if problems:
        print("check_links.py: %d reference(s) leave the repository or lead nowhere" % len(problems))
        return 1
    print("ok: no reference leaves the repository, every Markdown link resolves")
    return 0


if __name__ == "__main__":
    sys.exit(main())
