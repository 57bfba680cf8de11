#!/usr/bin/env python3
"""tools/run_store.py (a long run's output kept as a base and append-only parts) on real runs of the built capsflow.

A tiny run (4 capsules of mesh level 1) goes to strain 0.3, 0.6 and 0.9 by restarts, saved into a store after each
stretch, once restored onto a fresh folder in between as on a new machine; the outputs are checked:
- the restored file equals the run's own output in every dataset, attribute and creation property (finished runs
  compress their series, a restart makes them plain again: the join follows both), its frame views included;
- a restart from the restored file continues the run: the series, frames and events of the stored-and-restored run
  equal, bit for bit, those of the same run made in one go (restart continuity through the store);
- each part holds only the records written since the previous save (the store grows by what the run added);
- `capsflow analyze` reads the restored file;
- refusals with exit 2 and one line: another run's output, an output behind the store, a store with a missing part,
  a restore over an output that went on past the store (--force keeps it aside); a save with nothing new writes
  nothing; a changed number is found by the comparison;
- a checksum per file of the store (issue 52, item 2), a table of damage: a flipped byte in a part's plain dataset,
  a deflated chunk or the base, a manifest that lists a missing part, lacks a part's line or has a malformed one: restore
  (with --force too) and status refuse naming the file, exit 2, nothing written; a store saved before checksums restores
  (said unchecked), and a damaged chunk in it is refused naming the part;
- output.lock read as capsflow reads it (issue 52, item 6), a table of markers: a live run's (a real capsflow's while
  it runs, this host's live pid, another host's fresh heartbeat) refuses save, restore, `lock-status` and
  tools/reproduction_runs.sh save; one capsflow counts as dead (the real run's after kill -9, an ended or reused pid,
  a heartbeat older than 900 s elsewhere, this Slurm job's own, a torn file) is stale: said, and the commands go on.

    tests/python/test_run_store.py CAPSFLOW_BINARY WORKDIR     # as ctest runs it (exit 77: skipped)
"""

import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.dirname(os.path.dirname(HERE))
TOOL = os.path.join(SOURCE_DIR, "tools", "run_store.py")
sys.path.insert(0, os.path.join(SOURCE_DIR, "tools"))

try:
    import numpy as np
    import h5py
    import run_store
    import run_marker
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"SKIP: needs numpy and h5py ({e})")
    sys.exit(SKIP)

import tiny_run  # noqa: E402  (the shared tiny run, beside this file: never a reason to skip)

CONFIG = tiny_run.config(0.9, 0.02, 0.2, file="output.h5", output_extra="checkpoint_every = 0.1\n")

from tiny_run import capsflow, check, failures  # noqa: E402  (the shared helpers)


def tool(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)


def records(path):
    """The growing datasets' values (series, frames, events) of an output."""
    with h5py.File(path, "r") as f:
        return {p: f[p][...] for p in run_store.growing(f)}


def marker(host, pid, start_ticks=0, heartbeat_age=0.0, slurm_job="", old_format=False):
    """The text of an output.lock as capsflow writes it (src/host/run/run_marker.cpp), or in the key = value lines
    written before 2026-12-07."""
    fields = {"run_id": "test", "host": host, "pid": pid, "start_ticks": start_ticks, "started": time.time() - 10,
              "heartbeat": time.time() - heartbeat_age, "strain": 0.5, "end": 1.0, "slurm_job": slurm_job}
    if old_format:
        return "".join(f"{k} = {v}\n" for k, v in fields.items())
    return json.dumps(fields, indent=2) + "\n"


def lock_cases(binary, work, run, store):
    """output.lock in a run's folder, read as capsflow reads it (issue 52, item 6): a live run's marker refuses a
    save of the folder and a restore onto it (exit 2, one line naming the lock, nothing written); a marker left by a
    run that was killed, or one capsflow would count as dead, is stale: the save and the restore go on and say so.
    The first two markers are a real run's: its own while it runs, then the one it leaves when killed (kill -9)."""
    lock = os.path.join(run, "output.lock")
    original = os.path.join(work, "lock-cases-original.h5")
    shutil.copy(os.path.join(run, "output.h5"), original)
    store_files = sorted(os.listdir(store))
    env = dict(os.environ, SLURM_JOB_ID="777")

    def try_marker(what, text, live):
        with open(os.path.join(run, "output.h5"), "rb") as fh:
            output = fh.read()
        with open(lock, "w") as fh:
            fh.write(text)
        r = subprocess.run([sys.executable, TOOL, "lock-status", run], capture_output=True, text=True, env=env)
        if live:
            check(r.returncode == 2 and lock in r.stderr and "a run is writing there" in r.stderr
                  and len(r.stderr.strip().splitlines()) == 1, f"lock-status, {what}: {r.returncode} {r.stderr}")
        else:
            check(r.returncode == 0 and "stale" in r.stdout and "killed" in r.stdout,
                  f"lock-status, {what}: {r.returncode} {r.stdout}{r.stderr}")
        for cmd in (("save", run, store), ("restore", store, run)):
            r = subprocess.run([sys.executable, TOOL, *cmd], capture_output=True, text=True, env=env)
            if live:
                check(r.returncode == 2 and lock in r.stderr and len(r.stderr.strip().splitlines()) == 1,
                      f"{cmd[0]} with {what}: refused: {r.returncode} {r.stderr}")
            else:
                check(r.returncode == 0 and "stale" in r.stdout, f"{cmd[0]} with {what}: goes on, saying the lock is "
                      f"stale: {r.returncode} {r.stdout}{r.stderr}")
        if live:
            with open(os.path.join(run, "output.h5"), "rb") as fh:
                check(fh.read() == output, f"{what}: the run's output is as it was")
        else:   # restored from the store, which holds the same records
            diffs = run_store.describe_differences(original, os.path.join(run, "output.h5"))
            check(diffs == [], f"{what}: the restored output is the run's: {diffs}")
        check(sorted(os.listdir(store)) == store_files, f"{what}: nothing written into the store")

    live_dir = os.path.join(work, "live")
    os.makedirs(live_dir)
    with open(os.path.join(live_dir, "run.toml"), "w") as fh:
        fh.write(tiny_run.config(1000.0, 0.02, 0.2, file="output.h5"))
    proc = subprocess.Popen([binary, "run", "run.toml", "-q"], cwd=live_dir, env=dict(os.environ, OMP_NUM_THREADS="1"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    live_lock = os.path.join(live_dir, "output.lock")
    try:
        for _ in range(600):
            if os.path.exists(live_lock) or proc.poll() is not None:
                break
            time.sleep(0.1)
        with open(live_lock) as fh:
            try_marker("a running capsflow's marker", fh.read(), True)
    finally:
        proc.kill()   # SIGKILL: no clean end, the marker stays (what kill -9 or a lost node leaves)
        proc.wait()
    with open(live_lock) as fh:
        killed = fh.read()
    me = socket.gethostname()
    ticks = run_marker._proc_stat(os.getpid())[1]
    dead = subprocess.Popen(["true"])
    dead.wait()
    cases = [
        # (what, the marker's text, live?)
        ("a killed capsflow's marker", killed, False),
        ("this host, a live pid", marker(me, os.getpid(), ticks), True),
        ("this host, a live pid, the older key = value text", marker(me, os.getpid(), ticks, old_format=True), True),
        ("this host, a pid that has ended", marker(me, dead.pid), False),
        ("this host, a pid reused by another process (start time differs)", marker(me, os.getpid(), ticks + 1), False),
        ("this host, an ended pid, the older text", marker(me, dead.pid, old_format=True), False),
        ("another host, a fresh heartbeat", marker("node-elsewhere", 4242, heartbeat_age=5), True),
        ("another host, a heartbeat older than 900 s", marker("node-elsewhere", 4242, heartbeat_age=1000), False),
        ("another host, this process's own Slurm job (requeued)",
         marker("node-elsewhere", 4242, heartbeat_age=5, slurm_job="777"), False),
        ("an empty file (torn at its first write)", "", False),
        ("not a marker", "{[garbage", False),
    ]
    for what, text, live in cases:
        try_marker(what, text, live)
    os.remove(lock)
    reproduction_script_cases(work, run, killed, marker(me, os.getpid(), ticks))


def flip_byte(path, dataset, at=0, chunk=False):
    """One byte of `dataset`'s stored bytes inverted in place: of its contiguous data, or (chunk) of its first chunk as
    deflated on disk. The HDF5 structure stays intact: only what a reader gets from it changes, or fails to inflate."""
    with h5py.File(path, "r") as f:
        d = f[dataset]
        if chunk:
            info = d.id.get_chunk_info(0)
            check(d.compression == "gzip", f"{path}: /{dataset} is deflated")
            offset = info.byte_offset + info.size // 2
        else:
            check(d.chunks is None, f"{path}: /{dataset} is plain (contiguous)")
            offset = d.id.get_offset() + at
    with open(path, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)
        fh.seek(offset)
        fh.write(bytes([b[0] ^ 0xFF]))


def checksum_cases(work, store, want):
    """A checksum per file of the store, written by save and checked by restore before it writes anything (issue 52,
    item 2): a flipped byte in a part's plain dataset (/capsules/ca read 0.1016 for 0.2 and the restore said nothing),
    in a deflated chunk, in the base, is refused in one line naming the damaged file, exit 2, no output written; so
    are a manifest that lists a missing file, a part after a checksummed one without its own (a save that did not
    finish) and a malformed manifest. A store saved before checksums (no output.sha256) still restores, said to be
    unchecked, and a damaged chunk in it is refused naming the part (zlib's error had not said which file)."""
    manifest = os.path.join(store, "output.sha256")
    check(os.path.isfile(manifest), "save writes the store's checksums (output.sha256)")
    if os.path.isfile(manifest) and shutil.which("sha256sum"):
        r = subprocess.run(["sha256sum", "--check", "--strict", "output.sha256"], cwd=store, capture_output=True,
                           text=True)
        check(r.returncode == 0 and r.stdout.count(": OK") == 3, f"sha256sum --check reads it: {r.stdout}{r.stderr}")
    part1, part2 = "output.part-001.h5", "output.part-002.h5"

    def manifest_lines(d, edit):
        path = os.path.join(d, "output.sha256")
        lines = open(path).read().splitlines() if os.path.exists(path) else []
        with open(path, "w") as fh:
            fh.write("".join(line + "\n" for line in edit(lines)))

    def old_store(d):
        if os.path.exists(os.path.join(d, "output.sha256")):
            os.remove(os.path.join(d, "output.sha256"))

    cases = [
        # (what, the edit of a copy of the store, exit status, the damaged file named (None: none), words)
        ("intact", lambda d: None, 0, None, []),
        ("a flipped byte in the last part's /capsules/ca (plain)",
         lambda d: flip_byte(os.path.join(d, part2), "capsules/ca", 6), 2, part2, ["damaged", "output.sha256"]),
        ("a flipped byte in a deflated chunk of part 1",
         lambda d: flip_byte(os.path.join(d, part1), "series/centroid", chunk=True), 2, part1, ["damaged"]),
        ("a flipped byte in the base's /capsules/ca",
         lambda d: flip_byte(os.path.join(d, "output.h5"), "capsules/ca", 6), 2, "output.h5", ["damaged"]),
        ("the manifest lists a missing part",
         lambda d: os.remove(os.path.join(d, part2)), 2, part2, ["output.sha256", "missing"]),
        ("a part without a checksum after one with one (a save that did not finish)",
         lambda d: manifest_lines(d, lambda ls: [x for x in ls if not x.endswith(part2)]), 2, part2,
         ["no checksum", "output.sha256"]),
        ("a malformed line in the manifest",
         lambda d: manifest_lines(d, lambda ls: ls + ["not a checksum"]), 2, "output.sha256", ["line 4"]),
        ("a store saved before checksums", old_store, 0, None, ["unchecked: stored before checksums"]),
        ("a store saved before checksums, a deflated chunk of part 1 damaged",
         lambda d: (old_store(d), flip_byte(os.path.join(d, part1), "series/centroid", chunk=True)), 2, part1,
         ["cannot be read"]),
    ]
    for i, (what, edit, status, named, words) in enumerate(cases):
        d, run = os.path.join(work, "ck", str(i), "store"), os.path.join(work, "ck", str(i), "run")
        shutil.copytree(store, d)
        edit(d)
        r = tool("restore", d, run)
        out = os.path.join(run, "output.h5")
        if status == 0:
            check(r.returncode == 0 and all(w in r.stdout for w in words),
                  f"restore, {what}: {r.returncode} {r.stdout}{r.stderr}")
            diffs = run_store.describe_differences(want, out) if os.path.exists(out) else ["no output"]
            check(diffs == [], f"restore, {what}: the run's output: {diffs}")
            continue
        check(r.returncode == 2 and os.path.join(d, named) in r.stderr and all(w in r.stderr for w in words)
              and len(r.stderr.strip().splitlines()) == 1, f"restore, {what}: refused naming {named}: "
              f"{r.returncode} {r.stdout}{r.stderr}")
        check(not os.path.exists(run), f"restore, {what}: nothing written ({run} not made)")
        # --force replaces nothing either: the output it would set aside stays where it was.
        shutil.rmtree(run, ignore_errors=True)
        os.makedirs(run)
        shutil.copy(want, out)
        r = tool("restore", d, run, "--force")
        check(r.returncode == 2 and sorted(os.listdir(run)) == ["output.h5"],
              f"restore --force, {what}: refused, the output left in place: {r.returncode} {r.stderr} "
              f"{sorted(os.listdir(run))}")
        r = tool("status", d)
        if "cannot be read" in words:   # unchecked: status reads no more than each file's strains
            check(r.returncode == 0 and "unchecked" in r.stdout, f"status, {what}: {r.returncode} {r.stdout}{r.stderr}")
        else:
            check(r.returncode == 2 and os.path.join(d, named) in r.stderr and len(r.stderr.strip().splitlines()) == 1,
                  f"status, {what}: {r.returncode} {r.stderr}")


def fragment_cases(binary, work, store):
    """A file of a store is not a run (issue 52, item 10): a part opened as one read as a 6-record run starting
    mid-way, with no hint. The Python reader raises FormatError and `capsflow analyze` and `render` refuse (exit 2, one line,
    no --out written), each naming the file, which part of how many, and the restore that makes the run; so for the
    base of a store with parts beside it (the records to the first save only), a part saved before the mark (known by
    its /_store group and its name), and a directory holding a store."""
    import capsflow
    old = os.path.join(work, "fragments")
    shutil.copytree(store, old)
    with h5py.File(os.path.join(old, "output.part-001.h5"), "r+") as f:   # as saved before the mark
        for k in ("part", "note"):
            if k in f["_store"].attrs:
                del f["_store"].attrs[k]
    with h5py.File(os.path.join(store, "output.part-001.h5"), "r") as f:
        start = int(f["_store"].attrs["series/time"])
    cases = [
        # (the file or folder, the words the refusal holds)
        (os.path.join(store, "output.part-002.h5"), ["part 2 of 2", "run store", "run_store.py restore " + store]),
        (os.path.join(store, "output.part-001.h5"), ["part 1 of 2", f"from record {start}"]),
        (os.path.join(old, "output.part-001.h5"), ["part 1 of 2", "run_store.py restore " + old]),
        (os.path.join(store, "output.h5"), ["base of a run store", "2 part(s)", "run_store.py restore " + store]),
    ]
    for i, (path, words) in enumerate(cases):
        try:
            capsflow.open_run(path).close()
            check(False, f"the reader opens {path} as a run")
        except capsflow.FormatError as e:
            msg = str(e)
            check(path in msg and all(w in msg for w in words) and "\n" not in msg,
                  f"the reader on {path}: {words} in {msg}")
        out = os.path.join(work, f"fragment-analysis-{i}")
        r = subprocess.run([binary, "analyze", path, "--out", out, "-q"], capture_output=True, text=True)
        check(r.returncode == 2 and path in r.stderr and all(w in r.stderr for w in words)
              and len(r.stderr.strip().splitlines()) == 1 and not os.path.exists(out),
              f"capsflow analyze {path}: refused, {words}: {r.returncode} {r.stderr}")
        # `capsflow render` draws a run's frames: a part's frames are a stretch of the run, drawn as if all of it.
        pics = os.path.join(work, f"fragment-pictures-{i}")
        r = subprocess.run([binary, "render", path, "--out", pics], capture_output=True, text=True)
        check(r.returncode == 2 and path in r.stderr and all(w in r.stderr for w in words)
              and len(r.stderr.strip().splitlines()) == 1 and not os.path.exists(pics),
              f"capsflow render {path}: refused, {words}: {r.returncode} {r.stderr}")
    out = os.path.join(work, "fragment-analysis-dir")
    r = subprocess.run([binary, "analyze", store, "--out", out, "-q"], capture_output=True, text=True)
    check(r.returncode == 2 and "run store" in r.stderr and "run_store.py restore" in r.stderr
          and len(r.stderr.strip().splitlines()) == 1 and not os.path.exists(out),
          f"capsflow analyze of a store's folder: refused: {r.returncode} {r.stderr}")


def reproduction_script_cases(work, run, stale, live):
    """tools/reproduction_runs.sh save reads a point's lock as capsflow does (issue 52, item 6): a killed run's
    leftover does not stop the save; a live run's stops it before anything is copied (exit 2, the lock named). The
    script runs on a copy of the tools in a scratch tree (it works on runs/ and docs/reproduction/runs/ of its tree)."""
    tree = os.path.join(work, "tree")
    os.makedirs(os.path.join(tree, "tools"))
    for name in ("reproduction_runs.sh", "run_store.py", "capsflow_atomic.py", "run_marker.py"):
        shutil.copy(os.path.join(SOURCE_DIR, "tools", name), os.path.join(tree, "tools", name))
    subprocess.run(["git", "init", "-q", tree], check=True)
    point = os.path.join(tree, "runs", "reproduction_set_a", "fractions-1_0__seed-1")
    saved = os.path.join(tree, "docs", "reproduction", "runs", "reproduction_set_a", "fractions-1_0__seed-1")
    os.makedirs(point)
    for name in ("output.h5", "output.checkpoint.h5", "run.toml"):
        shutil.copy(os.path.join(run, name), os.path.join(point, name))
    for what, text, live in (("a live run's marker", live, True), ("a killed run's marker", stale, False)):
        with open(os.path.join(point, "output.lock"), "w") as fh:
            fh.write(text)
        r = subprocess.run(["bash", os.path.join(tree, "tools", "reproduction_runs.sh"), "save"], capture_output=True,
                           text=True)
        if live:
            check(r.returncode == 2 and "output.lock" in r.stderr and "a run is writing there" in r.stderr
                  and not os.path.exists(saved), f"reproduction_runs.sh save, {what}: refused, nothing copied: "
                  f"{r.returncode} {r.stdout}{r.stderr}")
        else:
            check(r.returncode == 0 and os.path.isfile(os.path.join(saved, "output.h5"))
                  and os.path.isfile(os.path.join(saved, "output.checkpoint.h5")),
                  f"reproduction_runs.sh save, {what}: saved: {r.returncode} {r.stdout}{r.stderr}")


def main(binary, work):
    if not os.access(binary, os.X_OK):
        print(f"SKIP: no capsflow executable at {binary}")
        return SKIP
    shutil.rmtree(work, ignore_errors=True)
    a, b, c, ref, store = (os.path.join(work, n) for n in ("a", "b", "c", "ref", "store"))
    for d in (a, ref):
        os.makedirs(d)
        with open(os.path.join(d, "run.toml"), "w") as fh:
            fh.write(CONFIG)
    capsflow(binary, ref, "run", "run.toml", "-q")                       # the run in one go, to 0.9

    # Stretch 1 (0 -> 0.3), saved: the base.
    capsflow(binary, a, "run", "run.toml", "--end", "0.3", "-q")
    r = tool("save", a, store)
    check(r.returncode == 0 and "the base" in r.stdout, f"first save: {r.returncode} {r.stdout}{r.stderr}")
    # Stretch 2 (0.3 -> 0.6) in place, saved: part 1, only the new records.
    capsflow(binary, a, "run", "--restart", "output.checkpoint.h5", "--end", "0.6", "-q")
    r = tool("save", a, store)
    check(r.returncode == 0 and os.path.isfile(os.path.join(store, "output.part-001.h5")),
          f"second save: {r.returncode} {r.stdout}{r.stderr}")
    with h5py.File(os.path.join(store, "output.h5"), "r") as base, \
            h5py.File(os.path.join(store, "output.part-001.h5"), "r") as p1, h5py.File(os.path.join(a, "output.h5")) as o:
        n0, n1, n = base["series/time"].shape[0], p1["series/time"].shape[0], o["series/time"].shape[0]
        check(n0 > 0 and n1 > 0 and n0 + n1 == n, f"part 1 holds the records since the base: {n0} + {n1} != {n}")
        check(int(p1["_store"].attrs["series/time"]) == n0, "part 1 starts at the base's record count")
    r = tool("save", a, store)
    check(r.returncode == 0 and "nothing new" in r.stdout
          and not os.path.exists(os.path.join(store, "output.part-002.h5")),
          f"a save with nothing new writes nothing: {r.returncode} {r.stdout}{r.stderr}")

    # A new machine: the store restored onto a fresh folder equals the run's output, and analyze reads it.
    r = tool("restore", store, b)
    check(r.returncode == 0, f"restore: {r.returncode} {r.stderr}")
    check(run_store.describe_differences(os.path.join(a, "output.h5"), os.path.join(b, "output.h5")) == [],
          "the restored output equals the run's: " +
          "; ".join(run_store.describe_differences(os.path.join(a, "output.h5"), os.path.join(b, "output.h5"))))
    for name in ("output.checkpoint.h5", "run.toml"):
        shutil.copy(os.path.join(a, name), os.path.join(b, name))
    capsflow(binary, b, "analyze", "output.h5", "--out", "analysis", "-q")
    check(os.path.isfile(os.path.join(b, "analysis", "summary.json")), "analyze reads the restored output")

    # Stretch 3 (0.6 -> 0.9) from the restored output, saved: part 2; restored again onto another folder.
    capsflow(binary, b, "run", "--restart", "output.checkpoint.h5", "--end", "0.9", "-q")
    r = tool("save", b, store)
    check(r.returncode == 0 and os.path.isfile(os.path.join(store, "output.part-002.h5")),
          f"third save: {r.returncode} {r.stdout}{r.stderr}")
    r = tool("restore", store, c)
    check(r.returncode == 0, f"second restore: {r.returncode} {r.stderr}")
    diffs = run_store.describe_differences(os.path.join(b, "output.h5"), os.path.join(c, "output.h5"))
    check(diffs == [], "the restored output equals the continued run's: " + "; ".join(diffs))
    got, want = records(os.path.join(c, "output.h5")), records(os.path.join(ref, "output.h5"))
    check(sorted(got) == sorted(want), f"same growing datasets as the run in one go: {sorted(got)} {sorted(want)}")
    for p in sorted(set(got) & set(want)):
        same = got[p].shape == want[p].shape and np.array_equal(got[p], want[p], equal_nan=got[p].dtype.kind == "f")
        check(same, f"/{p}: stored-and-restored run equals the run in one go (shapes {got[p].shape} {want[p].shape})")
    with h5py.File(os.path.join(c, "output.h5"), "r") as f:
        frames = f["frames/time"].shape[0]
        views = sorted(int(k) for k in f["xdmf/positions"].keys())
        check(views == list(range(frames)), f"a view per frame: {views} for {frames} frames")
        check(np.array_equal(f["xdmf/positions"][str(frames - 1)][...], f["frames/positions"][frames - 1]),
              "the last frame's view shows the last frame")

    # Refusals (exit 2, one line naming the file), and nothing written by them.
    before = sorted(os.listdir(store))
    r = tool("save", a, store)     # a is at 0.6, the store at 0.9
    check(r.returncode == 2 and "caught up" in r.stderr and len(r.stderr.strip().splitlines()) == 1,
          f"an output behind the store: {r.returncode} {r.stderr}")
    r = tool("save", ref, store)   # another run
    check(r.returncode == 2 and "another run" in r.stderr, f"another run's output: {r.returncode} {r.stderr}")
    lock_cases(binary, work, b, store)
    check(sorted(os.listdir(store)) == before, "refused saves write nothing")
    gap = os.path.join(work, "gap")
    shutil.copytree(store, gap)
    os.remove(os.path.join(gap, "output.part-001.h5"))
    r = tool("restore", gap, os.path.join(work, "d"))
    check(r.returncode == 2 and "part 1 is missing" in r.stderr, f"a store with a gap: {r.returncode} {r.stderr}")
    check(not os.path.exists(os.path.join(work, "d", "output.h5")), "a refused restore writes no output")
    checksum_cases(work, store, os.path.join(b, "output.h5"))
    fragment_cases(binary, work, store)

    # A restore never goes backwards (issue 52, 1): c continued past the store (0.9 -> 1.2) is refused, both counts
    # and strains named, the output untouched; --force replaces it and keeps it aside.
    for name in ("output.checkpoint.h5", "run.toml"):
        shutil.copy(os.path.join(b, name), os.path.join(c, name))
    capsflow(binary, c, "run", "--restart", "output.checkpoint.h5", "--end", "1.2", "-q")
    with open(os.path.join(c, "output.h5"), "rb") as fh:
        newer = fh.read()
    r = tool("restore", store, c)
    check(r.returncode == 2 and "newer work" in r.stderr and "to strain" in r.stderr
          and len(r.stderr.strip().splitlines()) == 1, f"a restore over newer work: {r.returncode} {r.stderr}")
    with open(os.path.join(c, "output.h5"), "rb") as fh:
        check(fh.read() == newer, "a refused restore leaves the newer output as it was")
    r = tool("restore", store, c, "--force")
    kept = [n for n in os.listdir(c) if n.startswith("output.replaced-")]
    check(r.returncode == 0 and len(kept) == 1, f"restore --force: {r.returncode} {r.stderr} {kept}")
    if kept:
        with open(os.path.join(c, kept[0]), "rb") as fh:
            check(fh.read() == newer, "restore --force keeps the output it replaced, bit for bit")
    diffs = run_store.describe_differences(os.path.join(b, "output.h5"), os.path.join(c, "output.h5"))
    check(diffs == [], "restore --force gives the store's output: " + "; ".join(diffs))

    # A store saved before checksums (issue 52, item 2) takes the next part: output.sha256 starts with it, and the
    # store restores, its older files said to be unchecked.
    old, newer_run = os.path.join(work, "old-store"), os.path.join(work, "newer")
    shutil.copytree(store, old)
    os.remove(os.path.join(old, "output.sha256"))
    os.makedirs(newer_run)
    if kept:
        shutil.copy(os.path.join(c, kept[0]), os.path.join(newer_run, "output.h5"))
    r = tool("save", newer_run, old)
    manifest = os.path.join(old, "output.sha256")
    lines = open(manifest).read().splitlines() if os.path.exists(manifest) else []
    check(r.returncode == 0 and "unchecked: stored before checksums" in r.stdout and len(lines) == 1
          and lines[0].endswith("  output.part-003.h5"), f"a save onto a store from before checksums: {r.returncode} "
          f"{r.stdout}{r.stderr} {lines}")
    r = tool("restore", old, os.path.join(work, "old-restored"))
    diffs = run_store.describe_differences(os.path.join(newer_run, "output.h5"),
                                           os.path.join(work, "old-restored", "output.h5"))
    check(r.returncode == 0 and "unchecked: stored before checksums: output.h5, output.part-001.h5, "
          "output.part-002.h5" in r.stdout and diffs == [], f"its restore: {r.returncode} {r.stdout}{r.stderr} {diffs}")

    # The comparison behind the save's self-check sees one changed number.
    changed = os.path.join(work, "changed.h5")
    shutil.copy(os.path.join(c, "output.h5"), changed)
    with h5py.File(changed, "r+") as f:
        f["series/centroid"][3, 1, 1] += 1e-12
    diffs = run_store.describe_differences(os.path.join(c, "output.h5"), changed)
    check(diffs == ["/series/centroid: values differ"], f"a changed number found: {diffs}")

    print("run_store:", "FAILED" if failures else "passed")
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print("usage: test_run_store.py CAPSFLOW_BINARY WORKDIR", file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
