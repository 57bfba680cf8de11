#!/usr/bin/env python3
"""What the device compilers make of capsflow's target regions, measured without a GPU (docs/device.md, "What the
device compilers make of the kernels"; issue 48).

For each target region (a kernel entry in the PTX): its PTX size with every function it calls in the same image, the
time ptxas takes on them at -O3 for sm_90 (what the driver's JIT pays when a GCC-built program starts; what clang's
build pays once), and the registers, stack frame and spills ptxas reports.

    tools/device_ptx.py gcc build/offload-gcc test_local_single_layer     # one program's whole nvptx image
    tools/device_ptx.py clang build/offload-clang                         # every unit compiled for the device
    tools/device_ptx.py clang build/offload-clang local_single_layer      # units whose path contains the word
    options: --json FILE (the table as JSON), --ptxas PATH (default /usr/local/cuda/bin/ptxas), --top N

GCC: the image is PTX that libgomp hands to the driver at start-up (JIT); the program's link is repeated with
-save-temps=obj into a scratch folder, which keeps mkoffload's linked image (`*.mkoffload`: one PTX module per
object and library, separated by NUL bytes). Library modules say `.target sm_30`, which CUDA 13's ptxas no longer
accepts: they are measured as sm_80 (the JIT compiles them for the card either way). clang: each unit that holds
target regions is compiled again with `--offload-device-only -S` for sm_90 (the per-unit PTX that its build turns into
a cubin; device LTO across units is not included).
"""
import argparse
import json
import os
import re
import resource
import shlex
import subprocess
import sys
import tempfile

FUNC_START = re.compile(r"^(?:\.visible\s+|\.weak\s+|\.extern\s+)*\.(entry|func)\s+(?:\([^)]*\)\s*)?([\w$.]+)", re.M)
# A function reaches another by a call or by its address (clang hands a region's parallel body to the runtime as
# a function pointer): any mention of a defined function's name counts.
CALL = re.compile(r"[A-Za-z_$][\w$.]*")


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def demangle(names):
    """c++filt on the mangled part of each name (GCC adds $_omp_fn$N, clang wraps in __omp_offloading_..._lN)."""
    cores = []
    for n in names:
        m = re.match(r"^__omp_offloading_[0-9a-f]+_[0-9a-f]+_(.*)_l(\d+)$", n)
        core = m.group(1) if m else n.split("$")[0]
        cores.append(core)
    out = run(["c++filt"], input="\n".join(cores) + "\n").stdout.splitlines()
    res = {}
    for n, core, d in zip(names, cores, out + [""] * len(names)):
        m = re.match(r"^__omp_offloading_[0-9a-f]+_[0-9a-f]+_(.*)_l(\d+)$", n)
        suffix = f" (line {m.group(2)})" if m else n[len(core):]
        d = (d or core).replace("(anonymous namespace)", "{anon}")
        d = re.sub(r"\((?:[^()]|\([^()]*\))*\)( const)?$", "(...)", d)  # the parameter list only
        res[n] = d + suffix
    return res


def block_end(ptx, open_at):
    """Index of the '}' that closes the '{' at open_at (GCC nests blocks at column 0; vector operands brace too)."""
    depth = 0
    for m in re.compile(r"[{}]").finditer(ptx, open_at):
        depth += 1 if m.group() == "{" else -1
        if depth == 0:
            return m.start() - 1
    return -1


def functions(ptx):
    """name -> (kind, text) of every function defined in a PTX module (a body: from its header to the closing brace
    at column 0)."""
    out = {}
    for m in FUNC_START.finditer(ptx):
        # A header's parameters hold no ';': a ';' before the body's '{' makes it a declaration.
        brace = ptx.find("\n{", m.end())
        semi = ptx.find(";", m.end())
        if brace < 0 or 0 <= semi < brace:
            continue
        end = block_end(ptx, brace + 1)
        if end >= 0:
            out[m.group(2)] = (m.group(1), ptx[m.start():end + 2])
    return out


def reachable(funcs, roots):
    """The functions of `funcs` (functions()'s map) that the roots reach, the roots included."""
    seen, todo = set(roots), list(roots)
    while todo:
        for c in (set(CALL.findall(funcs[todo.pop()][1])) & funcs.keys()) - seen:
            seen.add(c)
            todo.append(c)
    return seen


class ToolError(Exception):
    """A build that cannot be measured (no such program, a failed link or device pass): one line for the user."""


def gcc_image(build, target, scratch):
    """GCC's nvptx image of a program: its link repeated with -save-temps=obj into scratch keeps mkoffload's image,
    one PTX module per object and library (NUL-separated), returned as they are."""
    cmds = run(["ninja", "-C", build, "-t", "commands", target]).stdout.strip().splitlines()
    # Ninja writes a link as ": && COMPILER ... -o PROG ... && :".
    parts = [p for p in cmds[-1].split("&&") if " -o " in p] if cmds else []
    link = shlex.split(parts[0]) if parts else []
    if "-o" not in link:
        raise ToolError(f"no link command for '{target}' in {build}")
    # Drop a compiler launcher (ccache) and send the output and mkoffload's temporaries to the scratch folder.
    while link and os.path.basename(link[0]) in ("ccache", "env"):
        link = link[1:]
    link[link.index("-o") + 1] = os.path.join(scratch, "prog")
    r = run(link + ["-save-temps=obj"], cwd=build)
    if r.returncode != 0:
        raise ToolError(f"the link of {target} with -save-temps failed: {r.stderr[-800:]}")
    images = [f for f in os.listdir(scratch) if f.endswith(".mkoffload") and "nvptx" in f]
    if not images:
        raise ToolError("mkoffload kept no nvptx image (is this an offload-gcc build?)")
    data = open(os.path.join(scratch, images[0]), "rb").read().decode("utf-8", "replace")
    return [m for m in data.split("\0") if ".target" in m]


def device_pass(entry, out):
    """Compiles one unit of a clang offload build (a `ninja -t compdb` entry) for sm_90 only, device code only, as
    PTX into out (no launcher, no dependency file, the build's own --offload-arch dropped)."""
    args, keep, skip = shlex.split(entry["command"]), [], False
    while args and os.path.basename(args[0]) == "ccache":
        args = args[1:]
    for a in args:
        if skip:
            skip = False
        elif a in ("-o", "-MF", "-MT"):
            skip = True
        elif not (a.startswith("--offload-arch") or a in ("-MD", "-c")):
            keep.append(a)
    r = run(keep + ["--offload-arch=sm_90", "--offload-device-only", "-S", "-c", "-o", out], cwd=entry["directory"])
    if r.returncode != 0:
        raise ToolError(f"the device pass of {entry['file']} failed: {r.stderr[-800:]}")
    return open(out).read()


def ptxas_info(ptxas, module_path, arch):
    """ptxas -v on one module: per function compile ms, registers, stack frame, spill bytes; and its CPU time."""
    # CPU seconds of ptxas, not wall time: the figure should not depend on what else the machine runs.
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = run([ptxas, f"-arch={arch}", "-O3", "-c", "-v", module_path, "-o", os.devnull])
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    if r.returncode != 0:
        raise RuntimeError(f"ptxas failed on {module_path}: {r.stderr.strip()[:400]}")
    info, cur = {}, None
    for line in r.stderr.splitlines():
        m = re.search(r"(?:Function properties for|Compiling entry function) '?([\w$.]+)'?", line)
        if m:
            cur = info.setdefault(m.group(1), {"ms": 0.0, "regs": None, "stack": 0, "spill_st": 0, "spill_ld": 0})
            continue
        if cur is None:
            continue
        m = re.search(r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill loads", line)
        if m:
            cur["stack"], cur["spill_st"], cur["spill_ld"] = map(int, m.groups())
        m = re.search(r"Used (\d+) registers", line)
        if m:
            cur["regs"] = int(m.group(1))
        m = re.search(r"Compile time = ([\d.]+) ms", line)
        if m:
            cur["ms"] += float(m.group(1))
    return info, wall


def regions(modules, ptxas, arch, scratch):
    """Per kernel entry: PTX bytes and ptxas ms of the entry and everything it calls (within the image), its
    registers, the largest stack frame and spills along its calls. Also the image's totals."""
    funcs, info, total_wall, total_bytes = {}, {}, 0.0, 0
    for i, ptx in enumerate(modules):
        total_bytes += len(ptx)
        path = os.path.join(scratch, f"module{i}.ptx")
        with open(path, "w") as f:
            f.write(ptx)
        inf, wall = ptxas_info(ptxas, path, arch)
        total_wall += wall
        info.update(inf)
        funcs.update(functions(ptx))
    rows = []
    for name, (kind, body) in funcs.items():
        if kind != "entry":
            continue
        seen = reachable(funcs, [name])
        own = info.get(name, {})
        rows.append({
            "entry": name,
            "ptx_bytes": sum(len(funcs[n][1]) for n in seen),
            "functions": len(seen),
            "ptxas_ms": round(sum(info.get(n, {}).get("ms", 0.0) for n in seen), 1),
            "registers": max([info.get(n, {}).get("regs") or 0 for n in seen]),
            "entry_registers": own.get("regs"),
            "stack_bytes": max(info.get(n, {}).get("stack", 0) for n in seen),
            "spill_bytes": sum(info.get(n, {}).get("spill_st", 0) for n in seen),
        })
    return rows, {"modules": len(modules), "ptx_bytes": total_bytes, "ptxas_cpu_s": round(total_wall, 2)}


def gcc_modules(build, target, scratch):
    # Library modules (newlib, libgomp) are PTX for sm_30, which CUDA 13's ptxas rejects.
    return [re.sub(r"^\.target sm_[0-9]+$", ".target sm_80", re.sub(r"^\.version [0-9.]+$", ".version 7.0", m,
                                                                      flags=re.M), flags=re.M)
            for m in gcc_image(build, target, scratch)]


def clang_units(build, words, scratch):
    db = json.loads(run(["ninja", "-C", build, "-t", "compdb"]).stdout)
    out = []
    for e in db:
        cmd = e.get("command", "")
        if "--offload-arch" not in cmd or not e["file"].endswith(".cpp"):
            continue
        if words and not any(w in e["file"] for w in words):
            continue
        unit = os.path.splitext(os.path.basename(e["file"]))[0]
        ptx = device_pass(e, os.path.join(scratch, unit + ".ptx"))
        out.append((unit, ptx))
    if not out:
        sys.exit(f"device_ptx.py: no unit with --offload-arch in {build} (an offload-clang build?)")
    return out


def print_rows(title, rows, totals, top):
    names = demangle([r["entry"] for r in rows])
    rows.sort(key=lambda r: -r["ptx_bytes"])
    print(f"{title}: {totals['modules']} module(s), {totals['ptx_bytes'] / 1024:.0f} KB of PTX, ptxas -O3 sm_90 "
          f"{totals['ptxas_cpu_s']:.2f} s of CPU")
    print(f"  {'PTX KB':>7} {'ptxas ms':>8} {'regs':>4} {'stack B':>7} {'spill B':>7}  region")
    for r in rows[:top]:
        print(f"  {r['ptx_bytes'] / 1024:7.0f} {r['ptxas_ms']:8.0f} {r['registers']:4d} {r['stack_bytes']:7d} "
              f"{r['spill_bytes']:7d}  {names[r['entry']][:110]}")
    if len(rows) > top:
        print(f"  ... {len(rows) - top} more region(s)")
    for r in rows:
        r["name"] = names[r["entry"]]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("toolchain", choices=["gcc", "clang"])
    ap.add_argument("build")
    ap.add_argument("what", nargs="*", help="gcc: the program; clang: words that pick units (default: all)")
    ap.add_argument("--json")
    ap.add_argument("--ptxas", default="/usr/local/cuda/bin/ptxas")
    ap.add_argument("--top", type=int, default=12)
    a = ap.parse_args()
    if not os.access(a.ptxas, os.X_OK):
        sys.exit(f"device_ptx.py: no ptxas at {a.ptxas} (CUDA's; --ptxas PATH)")
    report = {"toolchain": a.toolchain, "build": a.build, "images": []}
    with tempfile.TemporaryDirectory() as scratch:
        if a.toolchain == "gcc":
            if len(a.what) != 1:
                sys.exit("device_ptx.py gcc BUILD PROGRAM: one program")
            mods = gcc_modules(a.build, a.what[0], scratch)
            rows, totals = regions(mods, a.ptxas, "sm_90", scratch)
            print_rows(f"GCC image of {a.what[0]}", rows, totals, a.top)
            report["images"].append({"name": a.what[0], "totals": totals, "regions": rows})
        else:
            for unit, ptx in clang_units(a.build, a.what, scratch):
                rows, totals = regions([ptx], a.ptxas, "sm_90", scratch)
                print_rows(f"clang unit {unit}", rows, totals, a.top)
                report["images"].append({"name": unit, "totals": totals, "regions": rows})
    if a.json:
        with open(a.json, "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    try:
        main()
    except ToolError as err:
        sys.exit(f"device_ptx.py: {err}")
