// The implementation of icosphere.hpp: icosphere meshes.
#include "host/state/icosphere.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "host/base/errors.hpp"

namespace capsflow {
namespace {

void normalize_node(TriMesh& m, std::size_t i) {
  const double r = std::sqrt(m.x[i] * m.x[i] + m.y[i] * m.y[i] + m.z[i] * m.z[i]);
  m.x[i] /= r;
  m.y[i] /= r;
  m.z[i] /= r;
}

TriMesh base_icosahedron() {
  TriMesh m;
  const double p = (1.0 + std::sqrt(5.0)) / 2.0;
  const double v[12][3] = {{-1, p, 0}, {1, p, 0}, {-1, -p, 0}, {1, -p, 0}, {0, -1, p}, {0, 1, p},
                           {0, -1, -p}, {0, 1, -p}, {p, 0, -1}, {p, 0, 1}, {-p, 0, -1}, {-p, 0, 1}};
  for (const auto& q : v) {
    m.x.push_back(q[0]);
    m.y.push_back(q[1]);
    m.z.push_back(q[2]);
    normalize_node(m, m.x.size() - 1);
  }
  // Counter-clockwise seen from outside (checked by the tests: every face normal points away from the centre).
  m.tri = {0, 11, 5, 0, 5, 1,  0, 1, 7,   0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4,  11, 10, 2, 10, 7, 6, 7, 1, 8,
           3, 9, 4,  3, 4, 2,  3, 2, 6,   3, 6, 8,  3, 8, 9,   4, 9, 5, 2, 4, 11,  6, 2, 10,  8, 6, 7, 9, 8, 1};
  return m;
}

// One 1-to-4 split; a shared midpoint per edge keeps the mesh conforming, and the child triangles inherit
// the parent's orientation.
TriMesh subdivide(const TriMesh& in) {
  TriMesh out;
  out.level = in.level + 1;
  out.x = in.x;
  out.y = in.y;
  out.z = in.z;
  std::map<std::pair<int, int>, int> mid;
  auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    out.x.push_back(0.5 * (in.x[a] + in.x[b]));
    out.y.push_back(0.5 * (in.y[a] + in.y[b]));
    out.z.push_back(0.5 * (in.z[a] + in.z[b]));
    normalize_node(out, out.x.size() - 1);
    const int id = static_cast<int>(out.x.size()) - 1;
    mid.emplace(key, id);
    return id;
  };
  for (int t = 0; t < in.num_triangles(); ++t) {
    const int a = in.tri[3 * t], b = in.tri[3 * t + 1], c = in.tri[3 * t + 2];
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    for (int v : {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca}) out.tri.push_back(v);
  }
  return out;
}

}  // namespace

void build_mesh_connectivity(TriMesh& m) {
  const int nv = m.num_nodes(), nt = m.num_triangles();
  std::vector<std::pair<int, int>> e;
  e.reserve(3 * static_cast<std::size_t>(nt));
  for (int t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c) e.push_back(std::minmax(m.tri[3 * t + c], m.tri[3 * t + (c + 1) % 3]));
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  m.edges.clear();
  for (const auto& [a, b] : e) {
    m.edges.push_back(a);
    m.edges.push_back(b);
  }

  m.inc_offsets.assign(nv + 1, 0);
  for (int v : m.tri) ++m.inc_offsets[v + 1];
  for (int i = 0; i < nv; ++i) m.inc_offsets[i + 1] += m.inc_offsets[i];
  m.inc_tri.assign(m.tri.size(), 0);
  m.inc_corner.assign(m.tri.size(), 0);
  std::vector<int> fill(m.inc_offsets.begin(), m.inc_offsets.end() - 1);
  for (int t = 0; t < nt; ++t)  // ascending t: the gather order (and so the sums) is fixed
    for (int c = 0; c < 3; ++c) {
      const int v = m.tri[3 * t + c];
      m.inc_tri[fill[v]] = t;
      m.inc_corner[fill[v]] = c;
      ++fill[v];
    }

  m.nbr_offsets.assign(nv + 1, 0);
  for (const auto& [a, b] : e) {
    ++m.nbr_offsets[a + 1];
    ++m.nbr_offsets[b + 1];
  }
  for (int i = 0; i < nv; ++i) m.nbr_offsets[i + 1] += m.nbr_offsets[i];
  m.nbr.assign(2 * e.size(), 0);
  std::vector<int> nf(m.nbr_offsets.begin(), m.nbr_offsets.end() - 1);
  for (const auto& [a, b] : e) {
    m.nbr[nf[a]++] = b;
    m.nbr[nf[b]++] = a;
  }
  for (int i = 0; i < nv; ++i) std::sort(m.nbr.begin() + m.nbr_offsets[i], m.nbr.begin() + m.nbr_offsets[i + 1]);

  // Edge quads: the triangle holding the directed edge a -> b gives c, the one holding b -> a gives d.
  std::map<std::pair<int, int>, int> opposite;  // directed edge -> the third node of its triangle
  for (int t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = m.tri[3 * t + c], b = m.tri[3 * t + (c + 1) % 3], o = m.tri[3 * t + (c + 2) % 3];
      if (!opposite.emplace(std::make_pair(a, b), o).second)
        throw InputError("mesh: directed edge " + std::to_string(a) + "->" + std::to_string(b) +
                         " is in two triangles (not a consistently oriented closed surface)");
    }
  const int ne = static_cast<int>(e.size());
  m.edge_quad.assign(4 * static_cast<std::size_t>(ne), 0);
  for (int k = 0; k < ne; ++k) {
    const auto [a, b] = e[k];
    const auto ab = opposite.find({a, b}), ba = opposite.find({b, a});
    if (ab == opposite.end() || ba == opposite.end()) {  // an open surface (test sheets): no bending stencil
      m.edge_quad.clear();
      m.einc_offsets.clear();
      m.einc_edge.clear();
      m.einc_slot.clear();
      return;
    }
    const int q[4] = {a, b, ab->second, ba->second};
    std::copy(q, q + 4, m.edge_quad.begin() + 4 * k);
  }
  m.einc_offsets.assign(nv + 1, 0);
  m.einc_edge.clear();
  m.einc_slot.clear();
  for (int v : m.edge_quad) ++m.einc_offsets[v + 1];
  for (int i = 0; i < nv; ++i) m.einc_offsets[i + 1] += m.einc_offsets[i];
  m.einc_edge.assign(m.edge_quad.size(), 0);
  m.einc_slot.assign(m.edge_quad.size(), 0);
  std::vector<int> ef(m.einc_offsets.begin(), m.einc_offsets.end() - 1);
  for (int k = 0; k < ne; ++k)  // ascending k: a fixed gather order
    for (int s = 0; s < 4; ++s) {
      const int v = m.edge_quad[4 * k + s];
      m.einc_edge[ef[v]] = k;
      m.einc_slot[ef[v]] = s;
      ++ef[v];
    }
}

const TriMesh& icosphere(int level) {
  if (level < 0 || level > kMaxIcosphereLevel)
    throw InputError("icosphere: mesh level " + std::to_string(level) + " is outside 0.." +
                     std::to_string(kMaxIcosphereLevel));
  static std::array<std::unique_ptr<TriMesh>, kMaxIcosphereLevel + 1> cache;
  static std::once_flag once;
  std::call_once(once, [] {
    TriMesh m = base_icosahedron();
    for (int l = 0; l <= kMaxIcosphereLevel; ++l) {
      if (l > 0) m = subdivide(m);
      auto built = std::make_unique<TriMesh>(m);
      build_mesh_connectivity(*built);
      cache[l] = std::move(built);
    }
  });
  return *cache[level];
}

}  // namespace capsflow
