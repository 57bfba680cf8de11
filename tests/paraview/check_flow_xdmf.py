# Loads the ParaView index of `capsflow flow`'s output and checks what ParaView shows: a plane's structured grid (or
# the points' vertex cells) with the velocity, disturbance and capsule arrays, and streamlines traced through it.
#
#   pvbatch check_flow_xdmf.py FLOW.xdmf POINTS CELLS
#
# Exit 0 when Xdmf3ReaderS shows POINTS points, CELLS cells, the three arrays and (for a grid) a stream tracer seeded
# on it produces lines; 1 otherwise, with one line saying what differs. (tests/CMakeLists.txt: ctest -L paraview.)
import os
import sys

import paraview.simple as pv
from paraview import servermanager

path, points, cells = os.path.abspath(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
reader = pv.Xdmf3ReaderS(FileName=[path])
reader.UpdatePipeline()
data = servermanager.Fetch(reader)
problems = []
if data.GetNumberOfPoints() != points or data.GetNumberOfCells() != cells:
    problems.append("%d points and %d cells, expected %d and %d" % (data.GetNumberOfPoints(), data.GetNumberOfCells(),
                                                                    points, cells))
names = [data.GetPointData().GetArrayName(i) for i in range(data.GetPointData().GetNumberOfArrays())]
for name in ("velocity", "disturbance", "capsule"):
    if name not in names:
        problems.append("no point array %s (has %s)" % (name, names))
if data.IsA("vtkStructuredGrid") and not problems:
    line = pv.Line(Point1=data.GetPoint(0), Point2=data.GetPoint(points - 1), Resolution=20)
    tracer = pv.StreamTracerWithCustomSource(Input=reader, SeedSource=line)
    tracer.Vectors = ["POINTS", "velocity"]
    tracer.UpdatePipeline()
    if servermanager.Fetch(tracer).GetNumberOfPoints() == 0:
        problems.append("the stream tracer drew no line")
print("check_flow_xdmf: %s: %s" % (path, "; ".join(problems) if problems else "ok"))
sys.exit(1 if problems else 0)
