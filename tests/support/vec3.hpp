#pragma once
// A 3-vector for the mesh tests' independent geometry (face normals, volumes), written apart from the kernels' code.
#include <cmath>

#include "host/state/icosphere.hpp"

namespace capsflow::test {

struct Vec {
  double x, y, z;
};
inline Vec node(const TriMesh& m, int i) { return {m.x[i], m.y[i], m.z[i]}; }
inline Vec sub(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec cross(Vec a, Vec b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline double norm(Vec a) { return std::sqrt(dot(a, a)); }

}  // namespace capsflow::test
