#!/usr/bin/env python3
"""tools/capsflow_render.py's periodic_pieces without ParaView (issue 52, item 11): the capsules that `capsflow
render` draws are cut at the periodic box and the parts that stick out come back in on the other side.

A closed triangulated sphere of radius 1 (an octahedron refined three times, 512 triangles) in a box of 6 x 6, carrying
two node arrays as capsflow's frames do (its unwrapped position as a 3-component "velocity", its capsule as an integer
"capsule"), placed
- inside the box: returned as it was;
- across x = 0, across x = Lx (its nodes' mean inside, as a run keeps it), across the corner x = 0, z = Lz, and across
  both x = 0 and x = Lx in a box narrower than the sphere is wide (the two images of a triangle in one axis):
  every point inside the box; the area that of the sphere (every piece drawn once); pieces on both sides of each cut
  boundary; every edge shared by two triangles except on the box's faces (no cracks along the cut); each point's data
  the linear interpolation of the nodes' (the position carried as data equals the point's own up to a whole period in
  x and z); the integer array's values kept.

    tests/python/test_render_wrap.py      # exit 0 passed, 1 failed, 77 skipped (no numpy)
"""

import os
import sys
import unittest

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "tools"))

try:
    import numpy as np
except ImportError as e:  # pragma: no cover - depends on the machine
    print("SKIP: needs numpy (%s)" % e)
    sys.exit(SKIP)

import capsflow_render  # noqa: E402  (imports no ParaView at module level)

L = 6.0


def sphere(levels=3):
    """A unit sphere: an octahedron, each triangle split in four `levels` times, the nodes pushed onto the sphere."""
    pts = [np.array(p, dtype=float) for p in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))]
    tris = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(levels):
        mid, new = {}, []

        def m(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                p = pts[a] + pts[b]
                pts.append(p / np.linalg.norm(p))
                mid[key] = len(pts) - 1
            return mid[key]
        for a, b, c in tris:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            new += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        tris = new
    return np.array(pts), np.array(tris)


def area(points, triangles):
    p = points[triangles]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()


class PeriodicPieces(unittest.TestCase):
    def setUp(self):
        self.unit, self.tris = sphere()

    def pieces(self, centre, lx=L, lz=L):
        pts = self.unit + np.array(centre, dtype=float)
        capsule = np.full(len(pts), 7.0)
        columns = np.column_stack([pts, capsule])  # "velocity" (x, y, z), then "capsule"
        out = capsflow_render.periodic_pieces(pts, self.tris, columns, lx, lz)
        return pts, out

    def test_a_capsule_inside_the_box_is_drawn_as_it_is(self):
        pts, (p, t, c) = self.pieces([3.0, 3.0, 3.0])
        np.testing.assert_array_equal(p, pts)
        np.testing.assert_array_equal(t, self.tris)
        self.assertEqual(c.shape, (len(pts), 4))

    def check_wrapped(self, centre, lx=L, lz=L, crossings=()):
        pts, (p, t, c) = self.pieces(centre, lx, lz)
        eps = 1e-12
        # Inside the box, y as it was.
        self.assertGreaterEqual(p[:, 0].min(), -eps)
        self.assertLessEqual(p[:, 0].max(), lx + eps)
        self.assertGreaterEqual(p[:, 2].min(), -eps)
        self.assertLessEqual(p[:, 2].max(), lz + eps)
        self.assertAlmostEqual(p[:, 1].min(), pts[:, 1].min(), delta=eps)
        # Every piece once: the area of the sphere (the refined octahedron's, not 4 pi).
        self.assertAlmostEqual(area(p, t), area(pts, self.tris), delta=1e-10)
        # Pieces on both sides of each boundary crossed.
        for axis, length in crossings:
            self.assertTrue(np.any(p[:, axis] < 0.1 * length), "nothing near %s = 0" % "xyz"[axis])
            self.assertTrue(np.any(p[:, axis] > 0.9 * length), "nothing near %s = L" % "xyz"[axis])
        # No crack: an edge off the box's faces belongs to two triangles.
        edges = {}
        for tri in t:
            for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
                edges[(min(a, b), max(a, b))] = edges.get((min(a, b), max(a, b)), 0) + 1

        def on_face(i):
            x, z = p[i, 0], p[i, 2]
            return min(abs(x), abs(x - lx), abs(z), abs(z - lz)) < 1e-12

        def same_face(a, b):
            return any(abs(p[a, ax] - v) < 1e-12 and abs(p[b, ax] - v) < 1e-12 for ax, v in
                       ((0, 0.0), (0, lx), (2, 0.0), (2, lz)))
        bad = [e for e, n in edges.items() if n != 2 and not (on_face(e[0]) and on_face(e[1]) and same_face(*e))]
        self.assertEqual(bad, [], "edges not shared by two triangles off the box's faces")
        # The data interpolated as the positions: the carried position differs from the point's by whole periods.
        d = c[:, :3] - p
        for axis, length in ((0, lx), (2, lz)):
            k = np.round(d[:, axis] / length)
            np.testing.assert_allclose(d[:, axis], k * length, atol=1e-9)
        np.testing.assert_allclose(d[:, 1], 0.0, atol=1e-12)
        np.testing.assert_array_equal(c[:, 3], 7.0)
        return p, t

    def test_a_capsule_across_x_0(self):
        self.check_wrapped([0.3, 3.0, 3.0], crossings=[(0, L)])

    def test_a_capsule_across_x_lx(self):
        self.check_wrapped([5.6, 3.0, 3.0], crossings=[(0, L)])

    def test_a_capsule_across_a_corner(self):
        self.check_wrapped([0.4, 3.0, 5.5], crossings=[(0, L), (2, L)])

    def test_a_capsule_wider_than_the_box(self):
        # Lx 1.5 < the diameter 2: triangles near x = 0 and near x = Lx at once, pieces from three images.
        self.check_wrapped([0.75, 3.0, 3.0], lx=1.5, crossings=[(0, 1.5)])


def main():
    prog = unittest.main(argv=[sys.argv[0]], exit=False, verbosity=2)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main())
