// Cell lists binned on the device (kernels/device_cells): the element cell list of the local sums and the node cell
// list of the step-size rule must be the host lists exactly (grid, cell starts, ids in order, per-slot centroids and
// radii), and the device's closest node pair of different capsules the host's value exactly (a minimum), on set-A-like
// capsules straddling the periodic seams and on random clouds, over repeated builds that move the nodes and change the
// cell grid (the resident arrays are re-used, and re-attached when the grid changes). Device only: on the host
// fallback without a GPU (ctest sets CAPSFLOW_TEST_DEVICE_HOST_FALLBACK=1); on a GPU an FMA-contracted centroid may
// differ in the last bit, which these exact comparisons would then report (docs/device.md "Resident data").
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "host/state/capsule_state.hpp"
#include "kernels/device_cells.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_single_layer.hpp"
#include "kernels/slit_cells.hpp"
#include "support/backends.hpp"

namespace capsflow::test {
namespace {

struct Box {
  double Lx, H, Lz;
};

// Set A's box (H = 10.15, L = 10.2) with ncap radius-1 capsules of mesh level `level`, centres at random without
// overlap (centre distance >= 2.1, minimum image) and >= 1.05 from the walls, the first three on a seam, a seam line
// and the corner. Odd capsules keep their nodes unwrapped (x, z beyond [0, L)), even ones have each node wrapped into
// the box, so their elements straddle the seams node by node; every node is jittered by up to `jitter`.
CapsuleState seam_capsules(int level, int ncap, const Box& b, double jitter, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::array<double, 3>> centres = {
      {0.0, 3.0, 5.0}, {5.0, 6.5, b.Lz - 0.01}, {b.Lx - 0.02, 8.0, 0.03}};
  while (static_cast<int>(centres.size()) < ncap) {
    const std::array<double, 3> c = {b.Lx * u(rng), 1.05 + (b.H - 2.1) * u(rng), b.Lz * u(rng)};
    bool ok = true;
    for (const auto& o : centres) {
      const double dx = min_image(c[0] - o[0], b.Lx), dy = c[1] - o[1], dz = min_image(c[2] - o[2], b.Lz);
      ok = ok && dx * dx + dy * dy + dz * dz >= 2.1 * 2.1;
    }
    if (ok) centres.push_back(c);
  }
  CapsuleState s(level);
  const int sp = s.add_species(0.3);
  for (const auto& c : centres) s.add_capsule(c, 1.0, sp);
  const int nv = s.nodes_per_capsule();
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    s.x[i] += jitter * (2.0 * u(rng) - 1.0);
    s.y[i] += jitter * (2.0 * u(rng) - 1.0);
    s.z[i] += jitter * (2.0 * u(rng) - 1.0);
    if ((static_cast<int>(i) / nv) % 2 == 0) {
      s.x[i] -= b.Lx * std::floor(s.x[i] / b.Lx);
      s.z[i] -= b.Lz * std::floor(s.z[i] / b.Lz);
    }
  }
  return s;
}

class DeviceCells : public OnEachBackend {};

void expect_same_element_list(const ElementCellList& d, const ElementCellList& h, const char* what) {
  EXPECT_EQ(d.ncx, h.ncx) << what;
  EXPECT_EQ(d.ncy, h.ncy) << what;
  EXPECT_EQ(d.ncz, h.ncz) << what;
  EXPECT_EQ(d.cx, h.cx) << what;
  EXPECT_EQ(d.cy, h.cy) << what;
  EXPECT_EQ(d.cz, h.cz) << what;
  EXPECT_EQ(d.max_radius, h.max_radius) << what;
  EXPECT_EQ(d.start, h.start) << what;
  EXPECT_EQ(d.elem, h.elem) << what;
  EXPECT_EQ(d.ex, h.ex) << what;
  EXPECT_EQ(d.ey, h.ey) << what;
  EXPECT_EQ(d.ez, h.ez) << what;
  EXPECT_EQ(d.er, h.er) << what;
}

void expect_same_node_list(const SlitCells& d, const SlitCells& h, const char* what) {
  EXPECT_EQ(d.ncx, h.ncx) << what;
  EXPECT_EQ(d.ncy, h.ncy) << what;
  EXPECT_EQ(d.ncz, h.ncz) << what;
  EXPECT_EQ(d.start, h.start) << what;
  EXPECT_EQ(d.index, h.index) << what;
  EXPECT_EQ(d.cell, h.cell) << what;
}

TEST_P(DeviceCells, ElementListEqualsTheHostList) {
  const Box b{10.2, 10.15, 10.2};
  DeviceElementCells dev(backend());
  // Set A (50 level-2 capsules), then the nodes moved, then a longer cutoff (another grid), then level 1 (another
  // element count): the list's device arrays are re-used or re-attached as the sizes require.
  struct Case {
    int level, ncap;
    double jitter, cutoff;
    unsigned seed;
  };
  for (const Case& c : {Case{2, 50, 0.0, 1.0, 1}, Case{2, 50, 0.08, 1.0, 2}, Case{2, 50, 0.08, 1.7, 3},
                        Case{1, 20, 0.15, 0.6, 4}}) {
    const CapsuleState s = seam_capsules(c.level, c.ncap, b, c.jitter, c.seed);
    const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
    const int* tri = s.mesh().tri.data();
    ElementCellList host;
    build_element_cell_list(host, b.Lx, b.H, b.Lz, c.cutoff, ncap, nv, ntri, tri, s.x.data(), s.y.data(), s.z.data());
    const ElementCellList& built =
        dev.build(b.Lx, b.H, b.Lz, c.cutoff, ncap, nv, ntri, tri, s.x.data(), s.y.data(), s.z.data());
    EXPECT_EQ(&built, &dev.list());
    const ElementCellList& d = dev.pull();
    expect_same_element_list(d, host, ("seed " + std::to_string(c.seed)).c_str());
    // Cells hold tens of elements at set A's sizes: the per-cell sort has work to do.
    int most = 0;
    for (std::size_t k = 0; k + 1 < host.start.size(); ++k) most = std::max(most, host.start[k + 1] - host.start[k]);
    if (c.level == 2) {
      EXPECT_GE(most, 10);
    }
  }
}

TEST_P(DeviceCells, ElementListRejectsABoxTooSmallLikeTheHost) {
  const Box b{10.2, 10.15, 10.2};
  const CapsuleState s = seam_capsules(1, 3, b, 0.0, 5);
  DeviceElementCells dev(backend());
  ElementCellList host;
  for (double L : {2.2, 0.0}) {
    EXPECT_THROW(build_element_cell_list(host, L, b.H, L, 1.0, s.num_capsules(), s.nodes_per_capsule(),
                                         s.triangles_per_capsule(), s.mesh().tri.data(), s.x.data(), s.y.data(),
                                         s.z.data()),
                 std::invalid_argument);
    EXPECT_THROW(dev.build(L, b.H, L, 1.0, s.num_capsules(), s.nodes_per_capsule(), s.triangles_per_capsule(),
                           s.mesh().tri.data(), s.x.data(), s.y.data(), s.z.data()),
                 std::invalid_argument);
  }
}

// Random clouds (test_slit_cells.cpp's: "capsules" of points in balls straddling the seams and touching the walls)
// and set-A capsules: the same list and the same h (and whether a pair set it) for limits below, at and above the
// closest pair.
TEST_P(DeviceCells, NodeListAndClosestPairEqualTheHost) {
  const Box b{7.3, 6.1, 5.2};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  DeviceNodeCells dev(backend());
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<double> x, y, z;
    Box box = b;
    int nv = 40;
    if (trial < 4) {
      for (int k = 0; k < 12; ++k) {
        const double cx = b.Lx * u(rng) - 0.5, cy = 1.0 + (b.H - 2.0) * u(rng), cz = b.Lz * u(rng) + 0.5;
        for (int i = 0; i < nv; ++i) {
          x.push_back(cx + 2.0 * u(rng) - 1.0);
          y.push_back(cy + 2.0 * u(rng) - 1.0);
          z.push_back(cz + 2.0 * u(rng) - 1.0);
        }
      }
    } else {
      box = Box{10.2, 10.15, 10.2};
      const CapsuleState s = seam_capsules(2, 50, box, 0.05, 11);
      x = s.x;
      y = s.y;
      z = s.z;
      nv = s.nodes_per_capsule();
    }
    SlitCells full;
    bin_points(full, box.Lx, box.H, box.Lz, 1.0, x.size(), x.data(), y.data(), z.data());
    const double exact = min_node_distance_between_capsules(Backend::Serial, full, nv, x.data(), y.data(), z.data(),
                                                            std::min(box.Lx, box.Lz) / 2.0);
    for (double limit : {0.5 * exact, exact, 1.0000001 * exact, 0.3, 2.5}) {
      SlitCells host;
      bin_points(host, box.Lx, box.H, box.Lz, limit, x.size(), x.data(), y.data(), z.data());
      dev.build(box.Lx, box.H, box.Lz, limit, x.size(), x.data(), y.data(), z.data());
      const double dh = min_node_distance_between_capsules(Backend::Serial, host, nv, x.data(), y.data(), z.data(),
                                                           limit);
      const double dd = dev.min_node_distance_between_capsules(nv, x.data(), y.data(), z.data(), limit);
      EXPECT_EQ(dd, dh) << "trial " << trial << " limit " << limit;
      EXPECT_EQ(dd < limit, dh < limit) << "trial " << trial << " limit " << limit;
      expect_same_node_list(dev.pull(), host, "node list");
    }
    EXPECT_TRUE(std::isfinite(exact));
  }
}

TEST(DeviceCellsBackend, RefusesTheHostBackends) {
  for (Backend b : {Backend::Serial, Backend::Threads}) {
    EXPECT_THROW(DeviceElementCells{b}, std::invalid_argument);
    EXPECT_THROW(DeviceNodeCells{b}, std::invalid_argument);
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, DeviceCells, ::testing::Values(Backend::Device), backend_param_name);

}  // namespace
}  // namespace capsflow::test
