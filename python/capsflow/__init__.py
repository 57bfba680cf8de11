"""Read capsflow's outputs from Python (numpy + h5py).

    import capsflow
    with capsflow.open_run("capsflow-run-demo/demo.h5") as run:    # `capsflow run`'s OUT.h5
        t = run.series.time                                         # [T] strain
        yc = run.series.centroid[:, :, 1] / run.H                   # [T, Np] centre heights y_c/H
        frame = run.frames[-1]                                      # node positions, velocities, triangles
    an = capsflow.open_analysis("capsflow-run-demo/analysis")       # `capsflow analyze`'s DIR (analysis.h5)
    g = an.suspension_groups()[0]
    g.dbar["stiff"].value, g.profile("phi_hat", "floppy").se

Units (docs/usage.md): lengths in the capsule radius a, times in strain units 1/gammadot, velocities in gammadot a.
Layouts: docs/output_format.md (runs) and docs/analysis.md (analyses); examples: docs/usage.md, "Reading outputs
from Python".
"""

from ._files import FormatError, UnsupportedVersionError
from .analysis import Analysis, open_analysis
from .run import Run, open_run

__all__ = ["open_run", "open_analysis", "Run", "Analysis", "FormatError", "UnsupportedVersionError"]
