#!/usr/bin/env python3
"""Steps and seconds per strain unit of long runs, attempt by attempt, from their run.log (issue 35).

Every `capsflow sweep --task` attempt appends to the point's run.log a header line ("== capsflow sweep ... at TIME:
start|continue from checkpoint", ending with "(capsflow V (commit C))" from 69bf107 on), the run's "from strain A" or
"continuing from strain A", and, when it ends (done, stopped or interrupted), "strain B reached in N steps (T, S
s/step; ...)". This prints one Markdown row per finished attempt: when, the build, strain A -> B, steps per strain,
seconds per step and per strain (wall time of that attempt: it depends on what else shared the machine).

  tools/run_costs.py runs/reproduction_set_a/*/ runs/reproduction/*/     # or docs/reproduction/runs/...
"""
import re
import sys
from pathlib import Path

HEADER = re.compile(r"^== capsflow sweep .* at (\S+ \S+): (start|continue from checkpoint)(?: \((capsflow [^(]*\(commit ([^)]*)\))\))?")
BUILD = re.compile(r"^\s+build capsflow [^(]*\(commit ([^)]*)\)")
FROM = re.compile(r"^\s+(?:from|continuing from) strain ([0-9.eE+-]+) to")
END = re.compile(r"strain ([0-9.eE+-]+) reached in (\d+) steps \(([^,]*), ([0-9.eE+-]+) s/step")


def seconds(text):
    """'4 h 01 min', '37 min 12 s', '52 s' -> seconds."""
    total = 0.0
    for value, unit in re.findall(r"([0-9.]+)\s*(h|min|s)\b", text):
        total += float(value) * {"h": 3600, "min": 60, "s": 1}[unit]
    return total


def attempts(log):
    rows, cur = [], None
    for line in log.read_text(errors="replace").splitlines():
        m = HEADER.match(line)
        if m:
            cur = {"when": m.group(1), "build": m.group(4) or "not logged", "from": None}
            continue
        if cur is None:
            continue
        m = BUILD.match(line)
        if m and cur["build"] == "not logged":  # the run's own header line (from 1780dc9 on)
            cur["build"] = m.group(1)
            continue
        m = FROM.match(line)
        if m and cur["from"] is None:
            cur["from"] = float(m.group(1))
            continue
        m = END.search(line)
        if m and cur["from"] is not None:
            to, steps, wall = float(m.group(1)), int(m.group(2)), seconds(m.group(3))
            # The summary counts this attempt's steps and wall time (run_report.cpp's RunTally).
            cur.update(to=to, steps=steps, wall=wall, s_per_step=float(m.group(4)))
            rows.append(cur)
            cur = None
    return rows


def main(argv):
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__)
        return 0 if argv else 2
    print("| run | attempt began (UTC) | build | strain | steps per strain | s per step | s per strain | wall |")
    print("|---|---|---|---|---|---|---|---|")
    for d in argv:
        log = Path(d) / "run.log"
        if not log.is_file():
            print(f"{sys.argv[0]}: {log}: no run.log", file=sys.stderr)
            return 2
        for a in attempts(log):
            steps = a["steps"]
            span = a["to"] - a["from"]
            sps = steps / span if span > 0 else float("nan")
            print(f"| {Path(d).resolve().parent.name}/{Path(d).name} | {a['when']} | {a['build']} | {a['from']:.1f} -> {a['to']:.1f} | {sps:.1f} | "
                  f"{a['s_per_step']:.3g} | {a['s_per_step'] * sps:.3g} | {a['wall'] / 3600:.2f} h |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
