#pragma once
// Views for the local layer sums (architecture review R6): plain aggregates of flat arrays and their sizes, in place
// of two dozen positional arguments, in the style of the membrane kernels' MeshTopology and MembraneReference. They
// own nothing and are trivially copyable. Device regions do not take them in: an entry maps the arrays one by one as
// before and builds the views inside the region from the mapped pointers (an OpenMP target region translates a
// mapped pointer variable, not a pointer stored inside a copied struct).
#include <cstddef>

namespace capsflow {

// ncap capsules sharing one triangulation, and their node positions: what the layer sums integrate over.
struct SurfaceView {
  int ncap = 0;               // capsules
  int nv = 0;                 // nodes per capsule
  int ntri = 0;               // triangles per capsule
  const int* tri = nullptr;   // 3 * ntri local node ids
  const double* x = nullptr;  // ncap * nv node positions (x and z possibly outside the box)
  const double* y = nullptr;
  const double* z = nullptr;
};

// A 3-vector field read from three flat arrays (a nodal density: the single layer's f, the double layer's q; node
// velocities): one entry per node or point.
struct Vec3In {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
};

// The points a sum is evaluated at: n points, and for each the global node index when it is a membrane node (the
// singular element test), else -1; node == nullptr means all -1.
struct TargetView {
  std::size_t n = 0;
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
  const int* node = nullptr;
};

// A 3-vector field written to three flat arrays (the sums add to them): one entry per target.
struct Vec3Out {
  double* x = nullptr;
  double* y = nullptr;
  double* z = nullptr;
};

// The local half of the GGEM split: the screening parameter, the cutoff of the local sum and the factor the sum is
// multiplied by (1/(8 pi mu) for the single layer, 1/(8 pi) for the double layer).
struct LocalSplit {
  double alpha = 0.0;
  double cutoff = 0.0;
  double scale = 0.0;
};

// An element cell list's arrays (ElementCellList, kernels/local_single_layer.hpp): the cell grid and, in cell order,
// the global element ids, centroids and bounding radii.
struct ElementCellsView {
  int ncx = 1, ncy = 1, ncz = 1;
  double cx = 0.0, cy = 0.0, cz = 0.0;  // cell sizes
  double Lx = 0.0, Lz = 0.0;            // periods
  const int* start = nullptr;           // ncells + 1
  const int* elem = nullptr;            // ne global element ids (capsule k, triangle t: k * ntri + t)
  const double* ex = nullptr;           // ne centroids and bounding radii
  const double* ey = nullptr;
  const double* ez = nullptr;
  const double* er = nullptr;
};

}  // namespace capsflow
