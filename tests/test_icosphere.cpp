// Icosphere meshes (issue 3): counts, orientation, manifold edges, CSR tables.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <utility>

#include "host/base/errors.hpp"
#include "host/state/icosphere.hpp"
#include "support/vec3.hpp"

using namespace capsflow;

namespace {
using test::Vec;
using test::node;
using test::sub;
using test::cross;
using test::dot;
}  // namespace

TEST(Icosphere, CountsAndEulerCharacteristic) {
  for (int level = 0; level <= 4; ++level) {
    const TriMesh& m = icosphere(level);
    const int p = 1 << (2 * level);  // 4^level
    EXPECT_EQ(m.level, level);
    EXPECT_EQ(m.num_triangles(), 20 * p);
    EXPECT_EQ(m.num_nodes(), 10 * p + 2);
    EXPECT_EQ(m.num_edges(), 30 * p);
    EXPECT_EQ(m.num_nodes() - m.num_edges() + m.num_triangles(), 2);
  }
  EXPECT_EQ(icosphere(2).num_nodes(), 162);
  EXPECT_EQ(icosphere(2).num_triangles(), 320);
  EXPECT_EQ(&icosphere(3), &icosphere(3));  // cached
}

TEST(Icosphere, LevelsOutsideRangeAreInputErrors) {
  EXPECT_THROW(icosphere(-1), InputError);
  EXPECT_THROW(icosphere(5), InputError);
}

TEST(Icosphere, NodesOnUnitSphereAndFacesOutward) {
  for (int level = 0; level <= 4; ++level) {
    const TriMesh& m = icosphere(level);
    for (int i = 0; i < m.num_nodes(); ++i) EXPECT_NEAR(dot(node(m, i), node(m, i)), 1.0, 1e-14);
    double vol = 0.0;
    for (int t = 0; t < m.num_triangles(); ++t) {
      const Vec a = node(m, m.tri[3 * t]), b = node(m, m.tri[3 * t + 1]), c = node(m, m.tri[3 * t + 2]);
      const Vec n = cross(sub(b, a), sub(c, a));
      const Vec centre = {(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3, (a.z + b.z + c.z) / 3};
      ASSERT_GT(dot(n, centre), 0.0) << "level " << level << " triangle " << t << " faces inward";
      vol += dot(a, cross(b, c)) / 6.0;
    }
    EXPECT_GT(vol, 0.0);
  }
}

TEST(Icosphere, EveryEdgeSharedByTwoOppositelyOrientedTriangles) {
  for (int level = 0; level <= 4; ++level) {
    const TriMesh& m = icosphere(level);
    std::map<std::pair<int, int>, int> directed;  // directed half-edge -> count
    for (int t = 0; t < m.num_triangles(); ++t)
      for (int c = 0; c < 3; ++c) ++directed[{m.tri[3 * t + c], m.tri[3 * t + (c + 1) % 3]}];
    for (const auto& [he, count] : directed) {
      ASSERT_EQ(count, 1) << "half-edge used twice: inconsistent orientation";
      ASSERT_EQ(directed.count({he.second, he.first}), 1u) << "boundary or non-manifold edge";
    }
    // The edge list is exactly the set of undirected half-edges.
    std::set<std::pair<int, int>> undirected;
    for (const auto& [he, count] : directed) undirected.insert(std::minmax(he.first, he.second));
    ASSERT_EQ(static_cast<int>(undirected.size()), m.num_edges());
    for (int e = 0; e < m.num_edges(); ++e) {
      EXPECT_LT(m.edges[2 * e], m.edges[2 * e + 1]);
      EXPECT_EQ(undirected.count({m.edges[2 * e], m.edges[2 * e + 1]}), 1u);
    }
  }
}

TEST(Icosphere, IncidenceAndNeighbourTables) {
  for (int level = 0; level <= 3; ++level) {
    const TriMesh& m = icosphere(level);
    const int nv = m.num_nodes();
    ASSERT_EQ(static_cast<int>(m.inc_offsets.size()), nv + 1);
    ASSERT_EQ(m.inc_offsets[nv], 3 * m.num_triangles());
    for (int i = 0; i < nv; ++i) {
      const int valence = m.inc_offsets[i + 1] - m.inc_offsets[i];
      EXPECT_TRUE(valence == 5 || valence == 6) << "node " << i;  // 12 icosahedron vertices have 5
      EXPECT_EQ(m.nbr_offsets[i + 1] - m.nbr_offsets[i], valence);  // closed surface: as many neighbours as faces
      for (int j = m.inc_offsets[i]; j < m.inc_offsets[i + 1]; ++j) {
        EXPECT_EQ(m.tri[3 * m.inc_tri[j] + m.inc_corner[j]], i);
        if (j > m.inc_offsets[i]) {
          EXPECT_LT(m.inc_tri[j - 1], m.inc_tri[j]);
        }
      }
      for (int j = m.nbr_offsets[i]; j < m.nbr_offsets[i + 1]; ++j) {
        const int k = m.nbr[j];
        const int* b = &m.nbr[m.nbr_offsets[k]];
        const int* e = &m.nbr[0] + m.nbr_offsets[k + 1];
        EXPECT_NE(std::find(b, e, i), e) << "neighbour relation not symmetric";
      }
    }
    int five = 0;
    for (int i = 0; i < nv; ++i) five += (m.inc_offsets[i + 1] - m.inc_offsets[i]) == 5;
    EXPECT_EQ(five, 12);
  }
}

TEST(Icosphere, DefaultMeshEdgeLengths) {
  // docs/method.md §2.1: h_min ~ 0.276 a, h_max ~ 0.325 a at level 2.
  const TriMesh& m = icosphere(2);
  double hmin = 1e9, hmax = 0;
  for (int e = 0; e < m.num_edges(); ++e) {
    const double h = std::sqrt(dot(sub(node(m, m.edges[2 * e]), node(m, m.edges[2 * e + 1])),
                                   sub(node(m, m.edges[2 * e]), node(m, m.edges[2 * e + 1]))));
    hmin = std::min(hmin, h);
    hmax = std::max(hmax, h);
  }
  EXPECT_NEAR(hmin, 0.276, 0.002);
  EXPECT_NEAR(hmax, 0.325, 0.002);
}
