#!/usr/bin/env python3
"""How capsflow is cited and licensed: CITATION.cff is valid YAML in the Citation File Format 1.2.0 with the fields
citation tools read, it cites Kumar & Graham's paper (the study capsflow reproduces) as an article, LICENSE is the
BSD-3-Clause text, and the program names the same paper in `capsflow --version` and `capsflow --help`, as README.md
and docs/reproduction.md do.

    tests/python/test_citation.py SOURCE_DIR CAPSFLOW     # as ctest runs it (exit 77: skipped, PyYAML missing)
"""
import importlib.util
import os
import subprocess
import sys

SKIP = 77
TITLE = "Segregation by membrane rigidity in flowing binary suspensions of elastic capsules"
ARXIV = "1109.6601"

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: test_citation.py SOURCE_DIR CAPSFLOW")
    if importlib.util.find_spec("yaml") is None:
        print("SKIP: %s lacks the module yaml (python3-yaml)" % sys.executable)
        return SKIP
    import yaml

    src, exe = sys.argv[1], sys.argv[2]
    with open(os.path.join(src, "CITATION.cff"), encoding="utf-8") as f:
        cff = yaml.safe_load(f)
    check(isinstance(cff, dict), "CITATION.cff is not a YAML mapping")
    # The keys CFF 1.2.0 requires of every file, and what a software entry must say.
    for key in ("cff-version", "message", "title", "authors"):
        check(key in cff, "CITATION.cff lacks the required key " + key)
    check(cff.get("cff-version") == "1.2.0", "cff-version is %r, not 1.2.0" % cff.get("cff-version"))
    check(cff.get("type") == "software", "type is %r, not software" % cff.get("type"))
    check("capsflow" in str(cff.get("title", "")), "the title does not name capsflow")
    check(cff.get("license") == "BSD-3-Clause", "license is %r" % cff.get("license"))
    check(all(isinstance(a, dict) and ("name" in a or "family-names" in a) for a in cff.get("authors", [])) and
          cff.get("authors"), "authors must be a non-empty list of persons or entities")

    refs = cff.get("references") or []
    papers = [r for r in refs if TITLE.lower() in str(r.get("title", "")).lower()]
    check(len(papers) == 1, "references hold %d entries titled %r, not one" % (len(papers), TITLE))
    if papers:
        p = papers[0]
        check(p.get("type") == "article", "the paper's type is %r, not article" % p.get("type"))
        names = [(a.get("given-names"), a.get("family-names")) for a in p.get("authors", [])]
        check(names == [("Amit", "Kumar"), ("Michael D.", "Graham")], "the paper's authors are %r" % names)
        check(p.get("journal") == "Physical Review E", "journal is %r" % p.get("journal"))
        check(p.get("volume") == 84, "volume is %r, not 84" % p.get("volume"))
        check(p.get("year") == 2011, "year is %r, not 2011" % p.get("year"))
        ids = " ".join(str(i.get("value")) for i in p.get("identifiers", [])) + " " + str(p.get("url", ""))
        check(ARXIV in ids, "the paper's identifiers do not name arXiv " + ARXIV)

    with open(os.path.join(src, "LICENSE"), encoding="utf-8") as f:
        licence = f.read()
    check("BSD 3-Clause License" in licence and "Copyright (c) 2026, the capsflow developers" in licence and
          "Neither the name of the copyright holder" in licence, "LICENSE is not the BSD-3-Clause text of capsflow")

    for args in (["--version"], ["--help"]):
        p = subprocess.run([exe] + args, capture_output=True, text=True, timeout=60)
        check(p.returncode == 0, "capsflow %s exited %d" % (args[0], p.returncode))
        out = " ".join(p.stdout.split())  # the help text may wrap
        for part in (TITLE, "Kumar", "Graham", "Phys. Rev. E 84", ARXIV, "BSD-3-Clause"):
            check(part in out, "capsflow %s does not name %r:\n%s" % (args[0], part, p.stdout))
    for doc in ("README.md", os.path.join("docs", "reproduction.md")):
        with open(os.path.join(src, doc), encoding="utf-8") as f:
            text = " ".join(f.read().split())
        for part in (TITLE, ARXIV):
            check(part in text, "%s does not cite the paper (%r)" % (doc, part))

    if failures:
        print("FAIL:\n  " + "\n  ".join(failures))
        return 1
    print("ok: CITATION.cff, LICENSE, --version, --help, README.md and docs/reproduction.md cite the paper")
    return 0


if __name__ == "__main__":
    sys.exit(main())
