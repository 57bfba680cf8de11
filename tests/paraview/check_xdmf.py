# Loads a capsflow run's XDMF index with every ParaView reader for the format and checks what each shows.
#
#   pvbatch check_xdmf.py OUT.xdmf POINTS CELLS FRAMES
#
# Each reader (XDMF Reader, Xdmf3ReaderS, Xdmf3ReaderT) must list FRAMES time steps and, at every one, show POINTS
# points and CELLS triangles with the node arrays species, capsule and velocity. Exit 0 when all do, 1 otherwise,
# with one line per reader and time step. (tests/CMakeLists.txt runs it on the embedded demo: ctest -L paraview.)
import os
import sys

import paraview.simple as pv

path, points, cells, frames = os.path.abspath(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
failures = 0
for name, key in [("XDMFReader", "FileNames"), ("Xdmf3ReaderS", "FileName"), ("Xdmf3ReaderT", "FileName")]:
    reader = getattr(pv, name)(**{key: [path]})
    reader.UpdatePipelineInformation()
    ts = reader.TimestepValues
    times = list(ts) if hasattr(ts, "__len__") else ([ts] if ts is not None else [])
    if len(times) != frames:
        print(f"{name}: {len(times)} time steps, expected {frames}")
        failures += 1
    for t in times:
        reader.UpdatePipeline(t)
        info = reader.GetDataInformation()
        arrays = sorted(reader.PointData.keys())
        ok = (info.GetNumberOfPoints() == points and info.GetNumberOfCells() == cells
              and all(a in arrays for a in ("species", "capsule", "velocity")))
        failures += 0 if ok else 1
        print(f"{name}: time {t:g}: {info.GetNumberOfPoints()} points, {info.GetNumberOfCells()} cells, "
              f"point arrays {arrays}: {'ok' if ok else 'WRONG'} (expected {points} points, {cells} cells)")
sys.exit(1 if failures else 0)
