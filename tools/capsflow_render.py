"""3D pictures and movie frames of a capsflow run, drawn by ParaView: `capsflow render` runs it under pvbatch.

    pvbatch capsflow_render.py JOB.json

capsflow render checks the run and the options, then writes JOB.json (what to draw and where) and runs this script;
the script only draws. Keys of JOB.json:

    xdmf         the run's ParaView index OUT.xdmf (read with ParaView's "XDMF Reader", which reads every format)
    frame_count  how many frames the run file has
    frames       [{"index": i, "time": t, "png": path}, ...]: the frames to draw (the index must list frame i at
                 strain t), each to its PNG
    color        "species" or a node array: tension_max, tension_min, energy_density, velocity, traction_jump
                 (vectors coloured by their magnitude)
    units        the array's units (the run file's `units` attribute), for the colour bar's title
    range        [lo, hi] of the colour map (the same for every frame of a movie)
    species      species names in index order (the colour bar's labels when colouring by species)
    species_rgb  [[r, g, b], ...] per species index: stiff (smaller Ca) tab:blue, floppy tab:red (the project's palette);
                 absent in an older job: tab10 in species order
    view         "side" (orthographic, looking along z), "top" (orthographic, looking down y) or "oblique"
                 (perspective from +z, above and downstream); absent: oblique
    box          [Lx, H, Lz]
    size         [width, height] in pixels
    title        a line drawn above the picture (the run file's name); the strain is added (a time annotation)
    state        where to save a ParaView state (.pvsm) of the same view (File > Load State in the GUI), or ""

The view: the capsules' triangles (the XDMF index's "capsules" grid) inside the periodic box (a capsule across a
periodic boundary cut there, the part outside drawn on the other side: periodic_pieces), the walls y = 0 and y = H
translucent grey, the periodic box's edges black, the flow direction as an arrow labelled "flow" above the box, and
a length bar of a whole number of capsule radii labelled in a, below it; x (the flow) to the right in every view, y up
in the side and oblique views. One line "capsflow-render: frame K N" per frame drawn goes to stdout (capsflow render's
progress bar). Exit status 0; 3 with
one line on stderr when the index does not list the frames asked for at the run file's strains; 4 with one line when a
picture or the state was not written (whole): ParaView's writers do not fail on a full disk.
"""
import json
import math
import os
import sys
import xml.etree.ElementTree as ET

# matplotlib's tab10, the colours of the species in `capsflow figures` (stiff blue, floppy red, ...).
SPECIES_RGB = ((0.122, 0.467, 0.706), (0.839, 0.153, 0.157), (0.173, 0.627, 0.173), (0.580, 0.404, 0.741),
               (1.000, 0.498, 0.055), (0.549, 0.337, 0.294), (0.890, 0.467, 0.761), (0.498, 0.498, 0.498),
               (0.737, 0.741, 0.133), (0.090, 0.745, 0.812))
VECTORS = ("velocity", "traction_jump")


def periodic_pieces(points, triangles, columns, lx, lz):
    """The capsules' surface drawn inside the periodic box: [0, lx] in x and [0, lz] in z (y, across the slit, as it
    is).

    A run keeps each capsule whole, its nodes' mean in the box (PinAndWrap), so a capsule across a periodic boundary
    sticks out of the box on one side. Here every triangle is drawn at each periodic image (shifted by a multiple of
    lx in x and of lz in z) that overlaps the box, clipped to it: the part that sticks out comes back in on the other
    side, and every piece of the surface is drawn once.

    points: (N, 3) node positions; triangles: (M, 3) node indices; columns: (N, C) node data (every point array, its
    components side by side), interpolated linearly where an edge is cut, as the positions are. Returns (points,
    triangles, columns) of the pieces. Triangles inside the box keep their nodes, shared as before, so the shading
    stays smooth; a cut vertex is shared by the two triangles of its edge, so the cut surface has no cracks. A surface
    wholly inside the box is returned as it is.
    """
    import numpy as np

    points = np.asarray(points, dtype=float)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    columns = np.asarray(columns, dtype=float).reshape(len(points), -1)
    period = {0: float(lx), 2: float(lz)}
    tri = points[triangles]                                           # (M, 3, 3)
    # The images of a triangle: shifts k L with k from floor(min / L) to ceil(max / L) - 1 (an image that only touches
    # the box is left out).
    first, count = {}, {}
    for a, length in period.items():
        lo = np.floor(tri[:, :, a].min(axis=1) / length)
        hi = np.ceil(tri[:, :, a].max(axis=1) / length) - 1
        first[a] = lo.astype(np.int64)
        count[a] = np.maximum(hi - lo + 1, 1).astype(np.int64)
    if np.all(first[0] == 0) and np.all(count[0] == 1) and np.all(first[2] == 0) and np.all(count[2] == 1):
        return points, triangles, columns

    # The images, as (triangle, kx, kz): whole ones (inside the box) in bulk, the others clipped one by one.
    whole, cut = [], []
    for dx in range(int(count[0].max())):
        for dz in range(int(count[2].max())):
            t = np.nonzero((dx < count[0]) & (dz < count[2]))[0]
            kx, kz = first[0][t] + dx, first[2][t] + dz
            p = tri[t] - np.stack([kx * period[0], np.zeros(len(t)), kz * period[2]], axis=1)[:, None, :]
            ok = ((p[:, :, 0].min(axis=1) >= 0) & (p[:, :, 0].max(axis=1) <= period[0]) &
                  (p[:, :, 2].min(axis=1) >= 0) & (p[:, :, 2].max(axis=1) <= period[2]))
            whole.append(np.stack([t[ok], kx[ok], kz[ok]], axis=1))
            cut.append(np.stack([t[~ok], kx[~ok], kz[~ok]], axis=1))
    whole, cut = np.concatenate(whole), np.concatenate(cut)

    # The whole triangles' nodes, one per (node, image): shared as in the input.
    keys = np.stack([np.repeat(whole[:, 1], 3), np.repeat(whole[:, 2], 3), triangles[whole[:, 0]].ravel()], axis=1)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    out_points = list(points[unique[:, 2]] - np.stack([unique[:, 0] * period[0], np.zeros(len(unique)),
                                                       unique[:, 1] * period[2]], axis=1))
    out_columns = list(columns[unique[:, 2]])
    out_tris = [tuple(r) for r in inverse.reshape(-1, 3)]
    index = {(int(kx), int(kz), "n", int(n)): j for j, (kx, kz, n) in enumerate(unique)}

    def vertex(key, position, data):
        k = index.get(key)
        if k is None:
            k = index[key] = len(out_points)
            out_points.append(position)
            out_columns.append(data)
        return k

    for t, kx, kz in cut:
        ids = triangles[t]
        p = points[ids] - np.array([kx * period[0], 0.0, kz * period[2]])
        # A polygon of (key, position, data); a key names a vertex whatever the triangle: a node (its index) or a cut
        # (the keys of its edge's ends and the plane), within one image.
        poly = [(("n", int(i)), p[j], columns[i]) for j, i in enumerate(ids)]
        for a, bound, keep_below in ((0, 0.0, False), (0, period[0], True), (2, 0.0, False), (2, period[2], True)):
            poly = _clip(poly, a, bound, keep_below)
            if len(poly) < 3:
                break
        if len(poly) < 3:
            continue
        ks = [vertex((int(kx), int(kz)) + key, pos, data) for key, pos, data in poly]
        out_tris.extend((ks[0], ks[j], ks[j + 1]) for j in range(1, len(ks) - 1))
    return (np.array(out_points, dtype=float).reshape(-1, 3), np.array(out_tris, dtype=np.int64).reshape(-1, 3),
            np.array(out_columns, dtype=float).reshape(-1, columns.shape[1]))


def _clip(poly, axis, bound, keep_below):
    """One Sutherland-Hodgman step of periodic_pieces: the part of a convex polygon of (key, position, data) on one
    side of the plane x[axis] = bound. A cut point is computed from its edge's ends in the order of their keys, so that
    the two triangles of an edge get it bit for bit alike."""
    def inside(v):
        return v[1][axis] <= bound if keep_below else v[1][axis] >= bound

    out = []
    for j, cur in enumerate(poly):
        prev = poly[j - 1]
        if inside(cur) != inside(prev):
            a, b = (prev, cur) if prev[0] <= cur[0] else (cur, prev)
            s = (bound - a[1][axis]) / (b[1][axis] - a[1][axis])
            pos = a[1] + s * (b[1] - a[1])
            pos[axis] = bound  # on the plane exactly
            out.append((("c", a[0], b[0], axis, bound), pos, a[2] + s * (b[2] - a[2])))
        if inside(cur):
            out.append(cur)
    return out


def wrap_script(lx, lz):
    """The ProgrammableFilter's script that draws the capsules through periodic_pieces: the functions' own text, so
    that the saved state draws the same without this file. The input's leaves (the capsules' triangles of each frame's
    blocks) are joined into one polygonal output (not by MergeBlocks: see main)."""
    import inspect
    code = inspect.getsource(periodic_pieces) + "\n\n" + inspect.getsource(_clip) + """

import numpy as np
from vtkmodules.util import numpy_support as ns
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkCompositeDataSet

source = self.GetInputDataObject(0, 0)
leaves = []
if source.IsA("vtkCompositeDataSet"):
    it = source.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        leaves.append(it.GetCurrentDataObject())
        it.GoToNextItem()
else:
    leaves.append(source)
leaves = [d for d in leaves if d is not None and d.GetNumberOfPoints() > 0 and d.GetNumberOfPolys() > 0]
result = self.GetOutputDataObject(0)
if leaves:
    names = [leaves[0].GetPointData().GetArrayName(i) for i in range(leaves[0].GetPointData().GetNumberOfArrays())]
    names = [n for n in names if n and all(d.GetPointData().GetArray(n) is not None for d in leaves)]
    pts, tris, cols, base = [], [], [], 0
    for d in leaves:
        p = ns.vtk_to_numpy(d.GetPoints().GetData()).astype(float)
        t = ns.vtk_to_numpy(d.GetPolys().GetConnectivityArray()).reshape(-1, 3)
        c = [ns.vtk_to_numpy(d.GetPointData().GetArray(n)).reshape(len(p), -1).astype(float) for n in names]
        pts.append(p)
        tris.append(t + base)
        cols.append(np.hstack(c) if c else np.zeros((len(p), 0)))
        base += len(p)
    p, t, c = periodic_pieces(np.vstack(pts), np.vstack(tris), np.vstack(cols), %r, %r)
    points = vtkPoints()
    points.SetData(ns.numpy_to_vtk(np.ascontiguousarray(p), deep=1))
    result.SetPoints(points)
    polys = vtkCellArray()
    polys.SetData(ns.numpy_to_vtkIdTypeArray(np.arange(0, 3 * len(t) + 1, 3, dtype=np.int64), deep=1),
                  ns.numpy_to_vtkIdTypeArray(np.ascontiguousarray(t.ravel(), dtype=np.int64), deep=1))
    result.SetPolys(polys)
    col = 0
    for n in names:
        a = leaves[0].GetPointData().GetArray(n)
        k = a.GetNumberOfComponents()
        values = c[:, col:col + k]
        col += k
        kind = ns.vtk_to_numpy(a).dtype
        if kind.kind in "iu":  # a node's species or capsule: one value per capsule, kept exactly
            values = np.rint(values)
        out = ns.numpy_to_vtk(np.ascontiguousarray(values.astype(kind) if k > 1 else values[:, 0].astype(kind)),
                              deep=1)
        out.SetName(n)
        result.GetPointData().AddArray(out)
""" % (float(lx), float(lz))
    # Run in a namespace of its own: ParaView's script namespace has numpy's all, max, min, ... over Python's.
    return "exec(%r, {'__name__': 'capsflow_periodic_pieces', 'self': self})\n" % code


def main(job_path):
    with open(job_path, encoding="utf-8") as f:
        job = json.load(f)
    import paraview.simple as pv  # after the job is read: a bad job fails before ParaView's start-up

    reader = pv.XDMFReader(FileNames=[job["xdmf"]])
    reader.UpdatePipelineInformation()
    ts = reader.TimestepValues
    times = list(ts) if hasattr(ts, "__len__") else ([ts] if ts is not None else [])
    for fr in job["frames"]:
        k, t = fr["index"], fr["time"]
        if k >= len(times) or abs(times[k] - t) > 1e-9 * max(1.0, abs(t)):
            sys.stderr.write("capsflow-render: %s does not list frame %d at strain %.17g as the run file does (%d "
                             "frames listed, %d in the run file): it is the index of another run or of an earlier "
                             "part of this one\n" % (job["xdmf"], k, t, len(times), job["frame_count"]))
            return 3

    # Each time step is a multiblock of the capsules (triangles), the walls (quadrilaterals) and the box (line
    # segments); the block names carry the frame number with some readers, so the blocks are told apart by cell type.
    # (Not merged: with MergeBlocks in the pipeline Debian's pvbatch 5.11 aborts at exit under Xvfb.)
    def blocks(cell_type):
        return pv.ExtractCellsByType(Input=reader, CellTypes=[cell_type])

    # The capsules cut at the periodic box, the parts outside it drawn inside on the other side (periodic_pieces),
    # then normals from the triangles: smooth (Gouraud) shading of the level-2 meshes instead of facets.
    wrapped = pv.ProgrammableFilter(Input=pv.ExtractSurface(Input=blocks("Triangle")))
    wrapped.OutputDataSetType = "vtkPolyData"
    wrapped.Script = wrap_script(job["box"][0], job["box"][2])
    pv.RenameSource("capsules in the periodic box", wrapped)
    capsules = pv.GenerateSurfaceNormals(Input=wrapped)
    walls, box = blocks("Quadrilateral"), blocks("Polyline")
    pv.RenameSource("capsules", capsules)
    pv.RenameSource("walls", walls)
    pv.RenameSource("box", box)

    width, height = job["size"]
    view = pv.CreateView("RenderView")
    view.ViewSize = [width, height]
    view.OrientationAxesVisibility = 1
    view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    view.OrientationAxesLabelColor = [0.0, 0.0, 0.0]

    cd = pv.Show(capsules, view)
    cd.Representation = "Surface"
    cd.Specular = 0.25
    color = job["color"]
    if color == "species":
        pv.ColorBy(cd, ("POINTS", "species"))
        lut = pv.GetColorTransferFunction("species")
        lut.InterpretValuesAsCategories = 1
        names = job["species"]
        lut.Annotations = [x for k, n in enumerate(names) for x in (str(k), n)]
        rgb = job.get("species_rgb") or [SPECIES_RGB[k % len(SPECIES_RGB)] for k in range(len(names))]
        lut.IndexedColors = [c for k in range(len(names)) for c in rgb[k]]
        title = "species"
    else:
        pv.ColorBy(cd, ("POINTS", color, "Magnitude") if color in VECTORS else ("POINTS", color))
        lut = pv.GetColorTransferFunction(color)
        lut.ApplyPreset("Viridis (matplotlib)", True)
        lut.AutomaticRescaleRangeMode = "Never"
        lo, hi = job["range"]
        lut.RescaleTransferFunction(lo, hi)
        pv.GetOpacityTransferFunction(color).RescaleTransferFunction(lo, hi)
        title = "|%s| [%s]" % (color, job["units"]) if color in VECTORS else "%s [%s]" % (color, job["units"])
    cd.SetScalarBarVisibility(view, True)
    bar = pv.GetScalarBar(lut, view)
    bar.Title = title
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0.0, 0.0, 0.0]
    bar.TitleFontSize = bar.LabelFontSize = 14
    bar.WindowLocation = "Any Location"
    bar.Position = [0.89, 0.15]
    bar.ScalarBarLength = 0.6
    bar.RangeLabelFormat = bar.LabelFormat = "%-#.3g"
    if color == "species":
        bar.TextPosition = "Ticks left/bottom, annotations right/top"  # the names outside, clear of the box
        bar.Position = [0.86, 0.15]

    wd = pv.Show(walls, view)
    wd.ColorArrayName = ["POINTS", ""]
    wd.AmbientColor = wd.DiffuseColor = [0.6, 0.6, 0.6]
    wd.Opacity = 0.25
    bd = pv.Show(box, view)
    bd.ColorArrayName = ["POINTS", ""]
    bd.AmbientColor = bd.DiffuseColor = [0.0, 0.0, 0.0]
    bd.LineWidth = 2.0

    # The strain from the time annotation, so that the title follows the GUI's time controls in the saved state.
    label = pv.AnnotateTimeFilter(Input=reader)
    label.Format = job["title"].replace("{", "{{").replace("}", "}}") + "   strain {time:.4g}"
    pv.RenameSource("title", label)
    ld = pv.Show(label, view)
    ld.WindowLocation = "Upper Left Corner"
    ld.FontSize = 16
    ld.Color = [0.0, 0.0, 0.0]

    lx, h, lz = job["box"]
    view_kind = job.get("view", "oblique")
    size = max(lx, h, lz)

    # The flow direction (+x) as an arrow above the box, and a length bar of a whole number of radii a below it
    # (in the top view beside the front edge), each with its label in 3D so that it scales with the picture.
    def label3d(text, at, height):
        src = pv.a3DText(Text=text)
        disp = pv.Show(src, view)
        disp.ColorArrayName = ["POINTS", ""]
        disp.AmbientColor = disp.DiffuseColor = [0.0, 0.0, 0.0]
        disp.Scale = [height, height, height]
        disp.Position = at
        if view_kind == "top":
            disp.Orientation = [-90.0, 0.0, 0.0]  # lying in the x-z plane, read from above
        return src

    bar = max(1, int(round(lx / 5.0)))  # radii: about a fifth of the box
    text_h = 0.045 * size
    if view_kind == "top":
        bar_y, bar_z, arrow_y, arrow_z = 0.0, lz + 0.08 * size, h, -0.1 * size
    else:  # the oblique view looks from above: its arrow higher, clear of the box's top edges
        bar_y, bar_z, arrow_z = -0.08 * size, lz, lz
        arrow_y = h + (0.08 if view_kind == "side" else 0.2) * size
    line = pv.Line(Point1=[0.0, bar_y, bar_z], Point2=[float(bar), bar_y, bar_z])
    pv.RenameSource("length bar", line)
    lb = pv.Show(line, view)
    lb.ColorArrayName = ["POINTS", ""]
    lb.AmbientColor = lb.DiffuseColor = [0.0, 0.0, 0.0]
    lb.LineWidth = 4.0
    label3d("%d a" % bar, [bar + 0.03 * size, bar_y - 0.4 * text_h if view_kind != "top" else bar_y,
                           bar_z + (0.4 * text_h if view_kind == "top" else 0.0)], text_h)
    arrow = pv.Arrow(TipLength=0.25, TipRadius=0.08, ShaftRadius=0.025)
    pv.RenameSource("flow direction", arrow)
    ad = pv.Show(arrow, view)
    ad.ColorArrayName = ["POINTS", ""]
    ad.AmbientColor = ad.DiffuseColor = [0.25, 0.25, 0.25]
    ad.Scale = [0.3 * lx, 0.3 * lx, 0.3 * lx]
    ad.Position = [0.35 * lx, arrow_y, arrow_z]
    label3d("flow", [0.68 * lx, arrow_y - 0.4 * text_h if view_kind != "top" else arrow_y,
                     arrow_z + (0.4 * text_h if view_kind == "top" else 0.0)], text_h)

    centre = [lx / 2.0, h / 2.0, lz / 2.0]
    view.CameraFocalPoint = centre
    if view_kind == "oblique":
        # From the +z side, a little from above and from downstream: x (the flow) to the right, y (across the slit)
        # up, so that the walls are the top and bottom of the picture and the capsules' depth shows.
        d = [0.45, 0.3, 1.0]
        n = math.sqrt(sum(c * c for c in d))
        view.CameraPosition = [centre[k] + 3.0 * size * d[k] / n for k in range(3)]
        view.CameraViewUp = [0.0, 1.0, 0.0]
        view.CameraParallelProjection = 0
        pv.ResetCamera(view)
        view.CameraViewAngle = 30.0
        pv.GetActiveCamera().Dolly(1.15)  # ResetCamera leaves a wide margin
    else:
        # Orthographic: side looks along -z (x right, y up: the walls at the top and bottom, where the species sit
        # across the slit shows at a glance); top looks down -y onto the x-z plane (x right, z down).
        if view_kind == "side":
            view.CameraPosition = [centre[0], centre[1], centre[2] + 3.0 * size]
            view.CameraViewUp = [0.0, 1.0, 0.0]
            across = h + 0.35 * size  # the box with the arrow above and the bar below
        else:
            view.CameraPosition = [centre[0], centre[1] + 3.0 * size, centre[2]]
            view.CameraViewUp = [0.0, 0.0, -1.0]
            across = lz + 0.45 * size
        view.CameraParallelProjection = 1
        pv.ResetCamera(view)
        view.CameraFocalPoint = centre
        aspect = width / float(height)
        # Half the visible height: the box across the picture, or along it (x) where the picture is narrower.
        view.CameraParallelScale = 0.55 * max(across, 1.2 * lx / aspect)

    # The time through the animation scene, not the view alone: the saved state then opens at the last frame drawn,
    # with the GUI's time controls on the run's frames.
    scene = pv.GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    frames = job["frames"]
    for k, fr in enumerate(frames):
        t = times[fr["index"]]
        scene.AnimationTime = t
        view.ViewTime = t
        pv.Render(view)
        saved = pv.SaveScreenshot(fr["png"], view, ImageResolution=[width, height], TransparentBackground=0)
        # Checked: on a full disk ParaView's PNG writer deletes what it wrote, logs an error and carries on.
        if saved is False or not os.path.isfile(fr["png"]) or os.path.getsize(fr["png"]) == 0:
            sys.stderr.write("capsflow-render: %s not written (ParaView's PNG writer failed)\n" % fr["png"])
            return 4
        print("capsflow-render: frame %d %d" % (k + 1, len(frames)), flush=True)
    if job.get("state"):
        pv.SaveState(job["state"])
        # Checked: on a full disk ParaView leaves a state cut short without a word.
        try:
            ET.parse(job["state"])
        except (OSError, ET.ParseError) as e:
            sys.stderr.write("capsflow-render: %s not written whole (%s)\n" % (job["state"], e))
            return 4
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    # main runs from this file imported as a module of its own: pvbatch runs the ProgrammableFilter's script in the
    # namespace of __main__, and its preamble puts numpy's max, min, all, ... over Python's there.
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    sys.dont_write_bytecode = True  # no __pycache__ beside the installed script
    import capsflow_render
    # Only a failure exits through sys.exit: under Xvfb, Debian's pvbatch 5.11 tears its GLX context down badly after
    # a SystemExit and exits 1 even after sys.exit(0).
    status = capsflow_render.main(sys.argv[1])
    if status:
        sys.exit(status)
