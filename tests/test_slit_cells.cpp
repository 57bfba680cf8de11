// Node cell list of the slit (kernels/slit_cells, and its device twin DeviceNodeCells): the time step's smallest node
// distance between capsules against a brute-force scan of all node pairs, across the periodic seams, on every backend
// through the harness (exact on each: a minimum is independent of the order).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "kernels/ggem_kernels.hpp"
#include "kernels/device_cells.hpp"
#include "kernels/slit_cells.hpp"
#include "support/backends.hpp"

using namespace capsflow;

namespace {

struct Cloud {
  int nc = 0, nv = 0;
  std::vector<double> x, y, z;
};

// nc "capsules" of nv points each: points scattered in a ball of radius 1 about a random centre, so that capsules
// overlap, straddle the periodic seams and sit against the walls.
Cloud random_cloud(int nc, int nv, double Lx, double H, double Lz, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud c;
  c.nc = nc;
  c.nv = nv;
  for (int k = 0; k < nc; ++k) {
    const double cx = Lx * u(rng) - 0.5, cy = 1.0 + (H - 2.0) * u(rng), cz = Lz * u(rng) + 0.5;
    for (int i = 0; i < nv; ++i) {
      c.x.push_back(cx + 2.0 * u(rng) - 1.0);
      c.y.push_back(cy + 2.0 * u(rng) - 1.0);
      c.z.push_back(cz + 2.0 * u(rng) - 1.0);
    }
  }
  return c;
}

double brute_force(const Cloud& c, double Lx, double Lz) {
  double best = std::numeric_limits<double>::infinity();
  const std::size_t n = c.x.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if (static_cast<int>(i) / c.nv == static_cast<int>(j) / c.nv) continue;
      const double dx = min_image(c.x[i] - c.x[j], Lx), dy = c.y[i] - c.y[j], dz = min_image(c.z[i] - c.z[j], Lz);
      best = std::min(best, dx * dx + dy * dy + dz * dz);
    }
  return std::sqrt(best);
}

// The closest pair of nodes of different capsules below `limit` on backend b: the host list and scan, or the list
// binned and scanned on the device.
double min_distance(Backend b, const Cloud& c, int nv, double Lx, double H, double Lz, double limit) {
  if (b == Backend::Device) {
    DeviceNodeCells dev(b);
    dev.build(Lx, H, Lz, limit, c.x.size(), c.x.data(), c.y.data(), c.z.data());
    return dev.min_node_distance_between_capsules(nv, c.x.data(), c.y.data(), c.z.data(), limit);
  }
  SlitCells cells;
  bin_points(cells, Lx, H, Lz, limit, c.x.size(), c.x.data(), c.y.data(), c.z.data());
  return min_node_distance_between_capsules(b, cells, nv, c.x.data(), c.y.data(), c.z.data(), limit);
}

}  // namespace

class NodeCellList : public test::OnEachBackend {};

TEST_P(NodeCellList, MinNodeDistanceMatchesBruteForce) {
  const double Lx = 7.3, H = 6.1, Lz = 5.2;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const Cloud c = random_cloud(12, 40, Lx, H, Lz, seed);
    const double exact = brute_force(c, Lx, Lz);
    for (double limit : {0.5 * exact, 1.0000001 * exact, 0.3, 2.5}) {
      const double d = min_distance(backend(), c, c.nv, Lx, H, Lz, limit);
      if (exact < limit)
        EXPECT_EQ(d, exact) << "seed " << seed << " limit " << limit;  // the same expression: bit for bit
      else
        EXPECT_TRUE(std::isinf(d)) << "seed " << seed << " limit " << limit;
    }
  }
}

// A box with fewer than 3 cells along x and z (every cell visited once) and one capsule: no pair at all.
TEST_P(NodeCellList, SmallBoxAndSingleCapsule) {
  const double Lx = 2.0, H = 3.0, Lz = 2.0;
  Cloud c = random_cloud(3, 20, Lx, H, Lz, 7);
  SlitCells cells;
  bin_points(cells, Lx, H, Lz, 0.9, c.x.size(), c.x.data(), c.y.data(), c.z.data());
  EXPECT_LT(cells.ncx, 3);
  const double exact = brute_force(c, Lx, Lz);
  ASSERT_LT(exact, 0.9);
  EXPECT_EQ(min_distance(backend(), c, c.nv, Lx, H, Lz, 0.9), exact);
  // All points in one capsule: nothing between capsules.
  EXPECT_TRUE(std::isinf(min_distance(backend(), c, 60, Lx, H, Lz, 0.9)));
  EXPECT_THROW(bin_points(cells, Lx, H, Lz, 0.0, c.x.size(), c.x.data(), c.y.data(), c.z.data()),
               std::invalid_argument);
}

CAPSFLOW_ON_EACH_BACKEND(NodeCellList);
