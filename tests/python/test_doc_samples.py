#!/usr/bin/env python3
"""The docs' sample checker (tools/doc_samples.py) fails where it must: a listed document without a sample, a sample
whose command exits with another status than the marker says, and drifted output; and passes a true sample, a
refusal marked with its status included.

    test_doc_samples.py REPO_ROOT CAPSFLOW_BINARY
"""
import os
import subprocess
import sys
import tempfile


def check(root, binary, doc_text):
    with tempfile.TemporaryDirectory(prefix="capsflow-doc-samples-test-") as tmp:
        doc = os.path.join(tmp, "doc.md")
        with open(doc, "w", encoding="utf-8") as f:
            f.write(doc_text)
        r = subprocess.run([sys.executable, os.path.join(root, "tools", "doc_samples.py"), "--binary", binary, doc],
                           capture_output=True, text=True, timeout=120)
        return r.returncode, r.stdout + r.stderr


def main():
    root, binary = sys.argv[1], sys.argv[2]
    version = subprocess.run([binary, "--version"], capture_output=True, text=True).stdout.split("\n")[0]
    cases = [
        # (what, document, expected exit status of the checker, a text its output must hold)
        ("a true sample", f"<!-- sample: --version -->\n```\n{version}\n```\n", 0, "1 samples checked, 0 failed"),
        ("a document without a sample", "# nothing quoted\n\n```\ncapsflow --version\n```\n", 1, "no sample"),
        ("drifted output", "<!-- sample: --version -->\n```\ncapsflow --version\ncapsflow 99.0\n```\n", 1,
         "has drifted"),
        ("a block that quotes nothing", "<!-- sample: --version -->\n```\ncapsflow --version\n...\n```\n", 1,
         "quotes no output"),
        ("a refusal without its status", "<!-- sample: frobnicate -->\n```\ncapsflow: error: unknown command...\n```\n",
         1, "exited with status 2, the sample says 0"),
        ("a refusal with its status", "<!-- sample exit 2: frobnicate -->\n```\n"
         "capsflow: error: unknown command 'frobnicate'...\n```\n", 0, "0 failed"),
        ("a success marked as a refusal", f"<!-- sample exit 2: --version -->\n```\n{version}\n```\n", 1,
         "exited with status 0, the sample says 2"),
    ]
    bad = 0
    for what, text, want, phrase in cases:
        status, out = check(root, binary, text)
        ok = status == want and phrase in out
        print(f"{'ok  ' if ok else 'FAIL'} {what}: exit {status} (want {want})")
        if not ok:
            bad += 1
            print("  expected '" + phrase + "' in:\n" + "\n".join("    | " + line for line in out.split("\n")))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
