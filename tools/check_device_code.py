#!/usr/bin/env python3
"""Checks of the device code an offload build made, without a GPU (ctest label `device-code`; docs/device.md).

    tools/check_device_code.py regions BUILD   # every object with a target region carries device code for it
    tools/check_device_code.py no-fma BUILD    # the cell lists' binning and closest-pair regions have no fused
                                               # multiply-add (their results are compared exactly with the host's)

`regions` (clang builds): a unit with a target region but no device pass still builds and links, and its regions then
run on the host even where a GPU is present (the outlined region is called directly). A host-side region is an
`__omp_offloading_*` symbol, a device pass an `.llvm.offloading` section. (GCC gives every unit the offload flags, and
its host parallel regions share the `*._omp_fn.N` names of its target regions: nothing to check there.)

`no-fma`: the device compilers contract a*b + c into one rounding wherever they may (nvptx always has FMA), the host
build does not (x86-64 without -mfma, and the files that matter are built with -ffp-contract=off), so an element's
centroid, radius and cell, or a squared distance, can differ in the last bit between the device list and the host
list it is compared with. clang: the unit is compiled again for sm_90 with --offload-device-only -S; GCC: the
program test_device_cells is linked again with -save-temps=obj, which keeps its nvptx image.
"""
import json
import os
import re
import subprocess
import sys
import tempfile

# The PTX parsing, the GCC image and clang's device pass are device_ptx.py's (beside this file).
from device_ptx import ToolError, demangle, device_pass, functions, gcc_image, reachable


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def fail(msg):
    print(f"FAIL: {msg}")
    sys.exit(1)


def toolchain(build):
    cache = open(os.path.join(build, "CMakeCache.txt")).read()
    m = re.search(r"^CMAKE_CXX_COMPILER_ID:\w+=(\w+)", cache, re.M)
    if m:
        return m.group(1)
    m = re.search(r"^CMAKE_CXX_COMPILER:\w+=(.*)$", cache, re.M)
    return "Clang" if m and "clang" in m.group(1) else "GNU"


def objects(build):
    for root, _, files in os.walk(build):
        for f in files:
            if f.endswith(".o") and "CMakeFiles" in root:
                yield os.path.join(root, f)


def regions(build):
    if toolchain(build) != "Clang":
        fail(f"{build} is not a clang build (the check is for clang's per-unit device passes)")
    checked, missing = 0, []
    for o in sorted(objects(build)):
        if "__omp_offloading_" not in run(["nm", o]).stdout:
            continue
        checked += 1
        device = ".llvm.offloading" in run(["objdump", "-h", o]).stdout
        if not device:
            missing.append(os.path.relpath(o, build))
    if checked == 0:
        fail(f"no object with a target region under {build} (not an offload build, or not built yet)")
    if missing:
        fail(f"{len(missing)} object(s) hold target regions without device code (their regions would run on the "
             f"host): " + ", ".join(missing) + " (CMakeLists.txt: capsflow_device_sources)")
    print(f"ok: {checked} objects with target regions, each with device code")


def demangled(name):
    return demangle([name])[name]


def device_cells_ptx(build, scratch):
    """The PTX of the cell lists' regions and the name test that picks them."""
    try:
        if toolchain(build) == "Clang":
            db = json.loads(run(["ninja", "-C", build, "-t", "compdb"]).stdout)
            e = next((e for e in db if e["file"].endswith("src/kernels/device_cells.cpp")), None)
            if e is None or "--offload-arch" not in e["command"]:
                fail("src/kernels/device_cells.cpp has no device pass in this build")
            return device_pass(e, os.path.join(scratch, "device_cells.ptx"))
        # The libraries' modules (newlib, libgomp: PTX for sm_30) are not this build's code: their functions are
        # followed, their instructions not judged (newlib's sqrt fuses x*x + x on its infinity path, which changes no
        # result).
        mods = gcc_image(build, "test_device_cells", scratch)
    except ToolError as err:
        fail(str(err))
    return "\n".join(m for m in mods if not re.search(r"^\.target sm_30", m, re.M))


def no_fma(build):
    with tempfile.TemporaryDirectory() as scratch:
        ptx = device_cells_ptx(build, scratch)
    funcs = functions(ptx)
    # The regions of the element and node lists and of the closest pair (kernels/device_cells.cpp), and what they
    # call: the centroid and radius, the cell of a point, the squared distances.
    picked = [n for n, (kind, _) in funcs.items()
              if re.search(r"Device(Element|Node)Cells", demangled(n)) and (kind == "entry" or "_omp_fn" in n)]
    if not picked:
        fail("no region of DeviceElementCells / DeviceNodeCells found in the device code")
    seen = reachable(funcs, picked)
    fused = {n: len(re.findall(r"\bfma\.rn\.f64\b", funcs[n][1])) for n in seen}
    fused = {n: k for n, k in fused.items() if k}
    if fused:
        fail("fused multiply-adds in the cell lists' device code: " +
             "; ".join(f"{demangled(n)} ({n}): {k}" for n, k in fused.items()) +
             " (device_cells.cpp must be compiled with -ffp-contract=off)")
    print(f"ok: {len(picked)} cell-list regions and {len(seen) - len(picked)} functions they call, no fma.rn.f64")


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("regions", "no-fma"):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        sys.exit(2)
    {"regions": regions, "no-fma": no_fma}[sys.argv[1]](sys.argv[2])
