# Loads a capsflow run's XDMF index with every ParaView reader for the format and checks what each shows.
#
#   pvbatch check_xdmf.py OUT.xdmf POINTS CELLS FRAMES
#
# Each reader (XDMF Reader, Xdmf3ReaderS, Xdmf3ReaderT) must list FRAMES time steps and, at every one, show a
# multiblock of three grids: the capsules (POINTS points, CELLS triangles, node arrays species, capsule, velocity and
# the membrane fields), the walls (8 points, 2 quadrilaterals at y = 0 and y = H) and the box (8 points, 12 edges),
# with the capsules between the walls. Exit 0 when all do, 1 otherwise, with one line per reader and time step.
# (tests/CMakeLists.txt runs it on the embedded demo: ctest -L paraview.)
import os
import sys

import paraview.simple as pv
from paraview import servermanager

path, points, cells, frames = os.path.abspath(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
ARRAYS = ("species", "capsule", "velocity", "traction_jump", "tension_max", "tension_min", "energy_density")


def leaves(data):
    """The data sets of a multiblock (or the data set itself), in order."""
    if not data.IsA("vtkMultiBlockDataSet"):
        return [data]
    out, it = [], data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    return out


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
        grids = [(d.GetNumberOfPoints(), d.GetNumberOfCells(), d) for d in leaves(servermanager.Fetch(reader))]
        shape = [(p, c) for p, c, _ in grids]
        ok = shape == [(points, cells), (8, 2), (8, 12)]
        arrays = []
        if ok:
            caps, walls = grids[0][2], grids[1][2]
            pd = caps.GetPointData()
            arrays = sorted(pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays()))
            wy, cy = walls.GetBounds()[2:4], caps.GetBounds()[2:4]
            ok = all(a in arrays for a in ARRAYS) and wy[0] == 0.0 and wy[0] < cy[0] and cy[1] < wy[1]
        failures += 0 if ok else 1
        print(f"{name}: time {t:g}: grids (points, cells) {shape}, capsule point arrays {arrays}: "
              f"{'ok' if ok else 'WRONG'} (expected [({points}, {cells}), (8, 2), (8, 12)], capsules between walls)")
sys.exit(1 if failures else 0)
