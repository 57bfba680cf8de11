"""A run's OUT.lock read as capsflow reads it (src/host/run/run_marker.cpp), for the Python tools and the scripts.

capsflow writes OUT.lock beside OUT.h5 before it writes the output and removes it when it returns, whatever the
reason (end, early stop, signal, error): a marker left behind means a process that was killed (kill -9, a lost node,
power). So a marker's existence does not mean a live run; its contents tell (the same rule as capsflow's, which
refuses to start over a live marker and replaces a dead one):
  - no host or no pid (a marker torn by a crash during its first write, or not a marker): dead;
  - this host: live while the pid exists, is not a zombie and has the start time recorded (a reused pid is not it);
  - another host (a cluster's compute node seen from the login node): live while its heartbeat is younger than
    STALE_SECONDS, except that a marker of this process's own Slurm job is dead (the job's earlier run, requeued).
Format: a JSON object {"run_id", "host", "pid", "start_ticks", "started", "heartbeat", "strain", "end", "slurm_job"},
or the `key = value` lines written before 2026-12-07.
"""

import json
import os
import re
import socket
import time

#: A marker on another host older than this counts as dead (run_marker.hpp, kStaleSeconds).
STALE_SECONDS = 900.0

_NUMBER = {int: re.compile(r"\s*[+-]?\d+"),
           float: re.compile(r"\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|\s*[+-]?(inf|nan)", re.I)}
_FIELDS = {"run_id": str, "host": str, "slurm_job": str, "pid": int, "start_ticks": int, "started": float,
           "heartbeat": float, "strain": float, "end": float}


def read_run_marker(path):
    """The marker at `path` as a dict of its fields (absent ones empty or 0), or None when there is no file. A file
    that cannot be parsed reads as a marker with empty fields: dead, as capsflow reads it."""
    try:
        with open(path, "rb") as fh:
            text = fh.read().decode("utf-8", "replace")
    except FileNotFoundError:
        return None
    except IsADirectoryError:
        return {k: t() for k, t in _FIELDS.items()}
    m = {k: t() for k, t in _FIELDS.items()}
    if text.lstrip().startswith("{"):
        try:
            j = json.loads(text)
        except ValueError:
            return m
        if not isinstance(j, dict):
            return m
        for k, t in _FIELDS.items():
            v = j.get(k)
            # A value of the wrong type reads as absent (nlohmann's is_string / is_number_integer / is_number).
            if t is str and isinstance(v, str):
                m[k] = v
            elif t is int and isinstance(v, int) and not isinstance(v, bool) and (k != "start_ticks" or v >= 0):
                m[k] = v
            elif t is float and isinstance(v, (int, float)) and not isinstance(v, bool):
                m[k] = float(v)
        return m
    for line in text.splitlines():
        key, sep, value = line.partition(" = ")
        if not sep or key not in _FIELDS:
            continue
        if _FIELDS[key] is str:
            m[key] = value
            continue
        # std::stol / std::stod read the longest number at the start ("12x" is 12); a torn value reads as absent.
        n = _NUMBER[_FIELDS[key]].match(value)
        if n:
            try:
                m[key] = _FIELDS[key](n.group(0))
            except ValueError:
                pass
    return m


def _proc_stat(pid):
    """(state, start ticks) from /proc/PID/stat; ("?", 0) when unknown. Fields are counted from the last ')': the
    command name may hold spaces and parentheses."""
    try:
        with open("/proc/%d/stat" % pid, "rb") as fh:
            s = fh.read().decode("ascii", "replace")
    except OSError:
        return "?", 0
    rest = s[s.rfind(")") + 1:].split()
    if len(rest) < 20:
        return "?", 0
    try:
        return rest[0][:1], int(rest[19])  # fields 3 and 22
    except ValueError:
        return rest[0][:1], 0


def _process_alive(pid, start_ticks):
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's process: it exists
    state, ticks = _proc_stat(pid)
    if state == "Z":
        return False
    # No /proc (or no start time recorded): the pid's existence is all there is to go on.
    return ticks == 0 or start_ticks == 0 or ticks == start_ticks


def this_host():
    return socket.gethostname() or "unknown"


def marker_is_live(m):
    if not m["host"] or m["pid"] <= 0:
        return False
    if m["host"] == this_host():
        return _process_alive(m["pid"], m["start_ticks"])
    if m["slurm_job"] and m["slurm_job"] == os.environ.get("SLURM_JOB_ID", ""):
        return False
    return time.time() - m["heartbeat"] < STALE_SECONDS


def describe_marker(m):
    """"pid 123 on host h (run id x), last heartbeat 4 s ago at strain 1.2", as capsflow says it."""
    return "pid %d on host %s (run id %s), last heartbeat %.0f s ago at strain %.6g" % (
        m["pid"], m["host"] or "?", m["run_id"] or "?", time.time() - m["heartbeat"], m["strain"])


def lock_status(run_dir, name="output.lock"):
    """("none" | "stale" | "live", one line for the user). "live": a run is writing there (the line names the lock
    file, the process and how to stop it); "stale": a marker left by a run that was killed, which capsflow replaces
    at the run's next start, and which the tools therefore ignore."""
    path = os.path.join(run_dir, name)
    m = read_run_marker(path)
    if m is None:
        return "none", ""
    if marker_is_live(m):
        where = ("this host" if m["host"] == this_host() else
                 "another host, heartbeat within %.0f s; older, it would count as a lost node's" % STALE_SECONDS)
        return "live", ("%s: a run is writing there: %s (live: %s); stop it first (Ctrl-C or SIGINT: it checkpoints)"
                        % (path, describe_marker(m), where))
    return "stale", ("%s: stale, left by a run that was killed (%s); ignored (capsflow replaces it when the run "
                     "continues)" % (path, describe_marker(m)))
