#pragma once
// Icosphere meshes: the regular icosahedron, subdivided `level` times (each triangle into four, edge
// midpoints projected to the unit sphere). Level L has 20*4^L triangles, 10*4^L + 2 nodes and 30*4^L edges;
// level 2 (162 nodes, 320 triangles, 480 edges) is the project's default capsule mesh (docs/method.md §2.1).
//
// All triangles are ordered counter-clockwise seen from outside, so (x1 - x0) x (x2 - x0) points outward.
// Connectivity is flat (int arrays) so kernels can use it directly; CSR tables give, per node, its incident
// (triangle, local corner) pairs in increasing triangle order and its neighbour nodes in increasing order.
//
// Usage:  const TriMesh& m = icosphere(2);  for (int t = 0; t < m.num_triangles(); ++t) m.tri[3*t + c] ...
#include <vector>

namespace capsflow {

struct TriMesh {
  int level = 0;
  std::vector<double> x, y, z;      // node positions on the unit sphere
  std::vector<int> tri;             // 3 * ntri node indices, counter-clockwise seen from outside
  std::vector<int> edges;           // 2 * nedge node indices, first < second, sorted
  std::vector<int> inc_offsets;     // nv + 1: node i's incident triangles are [inc_offsets[i], inc_offsets[i+1])
  std::vector<int> inc_tri;         // incident triangle index
  std::vector<int> inc_corner;      // local corner (0, 1, 2) of node i in that triangle
  std::vector<int> nbr_offsets;     // nv + 1: node i's neighbours are nbr[nbr_offsets[i] .. nbr_offsets[i+1])
  std::vector<int> nbr;             // neighbour node indices (ascending per node)
  // Edge k's two triangles (the bending stencil, kernels/bending_forces.hpp): 4 * nedge nodes (a, b, c, d) with
  // (a, b, c) and (b, a, d) the two triangles, both counter-clockwise from outside; {a, b} = edges[2k .. 2k+1].
  std::vector<int> edge_quad;
  std::vector<int> einc_offsets;    // nv + 1: node i's places in edge quads are [einc_offsets[i], einc_offsets[i+1])
  std::vector<int> einc_edge;       // the edge (ascending per node)
  std::vector<int> einc_slot;       // node i's slot in that edge's quad: 0 a, 1 b, 2 c, 3 d

  int num_nodes() const { return static_cast<int>(x.size()); }
  int num_triangles() const { return static_cast<int>(tri.size() / 3); }
  int num_edges() const { return static_cast<int>(edges.size() / 2); }
};

constexpr int kMaxIcosphereLevel = 4;

// The unit icosphere of the given level (0..4), built once and cached (thread-safe first use).
// Throws InputError for levels outside 0..kMaxIcosphereLevel.
const TriMesh& icosphere(int level);

// Fills edges, edge quads and the CSR tables of a mesh from its triangles (also used for non-spherical test meshes).
// An open surface (an edge with one triangle) gets no edge quads (edge_quad and einc_* empty). Throws InputError
// when a directed edge is in two triangles (orientation not consistent).
void build_mesh_connectivity(TriMesh& mesh);

}  // namespace capsflow
