"""The tiny run the Python tests make with the real capsflow: four level-1 capsules of two species (stiff Ca 0.2,
floppy Ca 0.8) in a 6 x 6 x 6 slit under Poiseuille flow, serial backend, a fraction of a strain unit. One
configuration text for every test that needs such a run (test_reader, test_render, test_run_diagnostics,
test_run_store), so a change of the file format or of a key is made once.

Also the two helpers of the tests that drive real runs and collect failures (test_run_store, test_set_checkpoint_cfl):
`check` (records a failure and goes on) and `capsflow` (runs the binary, one thread, raising on a non-zero exit).
"""

import os
import subprocess

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


def capsflow(binary, cwd, *args):
    r = subprocess.run([binary, *args], cwd=cwd, capture_output=True, text=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    if r.returncode != 0:
        raise AssertionError(f"capsflow {' '.join(args)} in {cwd}: exit {r.returncode}\n{r.stdout}{r.stderr}")


SPECIES = ["stiff", "floppy", "floppy", "stiff"]
CENTRES = [[1.5, 1.5, 1.5], [4.5, 2.4, 1.5], [1.5, 3.9, 4.5], [4.5, 4.4, 4.5]]
CA = {"stiff": 0.2, "floppy": 0.8}


def config(end, every, frames_every, file="tiny.h5", species=SPECIES, centres=CENTRES, ca=CA, H=6.0,
           mesh_level=1, output_extra=""):
    """The run's TOML text: [time] end, [output] file / every / frames_every, and any further [output] lines."""
    capsules = "".join('\n[[capsule]]\nspecies = "%s"\ncenter = [%r, %r, %r]\n' % (s, *c)
                       for s, c in zip(species, centres))
    return """
[domain]
H = %(H)r
Lx = 6.0
Lz = 6.0

[run]
backend = "serial"

[flow]
type = "poiseuille"

[capsules]
mesh_level = %(level)d

[[species]]
name = "stiff"
ca = %(ca_s)r

[[species]]
name = "floppy"
ca = %(ca_f)r
%(capsules)s
[time]
end = %(end)r

[output]
file = "%(file)s"
every = %(every)r
frames_every = %(frames)r
%(extra)s""" % {"H": H, "level": mesh_level, "ca_s": ca["stiff"], "ca_f": ca["floppy"], "capsules": capsules,
                "end": end, "file": file, "every": every, "frames": frames_every, "extra": output_extra}
