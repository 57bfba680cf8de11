// The velocity operator of capsule membranes (SingleLayerPlan: local element integrals + GGEM global part), with
// the imposed flow added as Simulation adds it.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <random>

#include "host/physics/config.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/solver/single_layer_plan.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_single_layer.hpp"
#include "kernels/step_update.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace {

const SlitGeometry kBox{6.0, 6.0, 6.0, 1.0};  // a = 1: Lx = Lz = 2 (r_c + 2a) at alpha = 4 (the smallest box allowed)

int flow_code(FlowType t) {
  return t == FlowType::Poiseuille ? kImposedPoiseuille : t == FlowType::Shear ? kImposedShear : kImposedNone;
}

// u = u_inf + S[f] for the state's current load, as Simulation::evaluate computes it.
void node_velocities(SingleLayerPlan& plan, const CapsuleState& s, const FlowOptions& flow, std::vector<double>& ux,
                     std::vector<double>& uy, std::vector<double>& uz) {
  plan.set_geometry(s);
  plan.apply(s, ux, uy, uz);
  add_imposed_flow_x(plan.backend(), ux.size(), flow_code(flow.type), flow.shear_rate, plan.geometry().H, s.y.data(),
                     ux.data());
}

// Two deformed capsules, one across the periodic seams, with their membrane load.
CapsuleState deformed_pair(unsigned seed = 3) {
  CapsuleState s(1);
  const int sp = s.add_species(0.3);
  s.add_capsule({1.0, 2.0, 5.5}, 1.0, sp);
  s.add_capsule({3.6, 3.9, 3.0}, 1.0, sp);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(-0.05, 0.05);
  for (auto* v : {&s.x, &s.y, &s.z})
    for (double& c : *v) c += d(rng);
  s.compute_membrane_forces(Backend::Serial);
  return s;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](double x, double y) {
           return std::memcmp(&x, &y, sizeof x) == 0;
         });
}

// Bit for bit on serial and threads; on the device within 1e-12 relative, since its spreading adds with atomics in
// an order that changes from call to call.
void expect_same(Backend backend, const std::vector<double>& a, const std::vector<double>& b, int c) {
  if (backend == Backend::Device)
    EXPECT_LE(test::max_rel_error(a, b), 1e-12) << "component " << c;
  else
    EXPECT_TRUE(same_bits(a, b)) << "component " << c;
}

double max_abs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

}  // namespace

// Physics on every backend (the backends harness): exact answers, no serial oracle.
class SingleLayerPhysics : public test::OnEachBackend {};

TEST_P(SingleLayerPhysics, UnstressedCapsuleMovesWithTheImposedFlow) {
  MembraneParameters p;
  p.inflation = 0.0;  // reference shape = current shape: no membrane force at all
  CapsuleState s(1, p);
  s.add_capsule({3.0, 2.0, 3.0}, 1.0, s.add_species(0.2));
  s.compute_membrane_forces(backend());
  EXPECT_LT(max_abs(s.fx), 1e-12);  // rounding of C = I only
  SingleLayerPlan solver(kBox, GgemOptions{}, backend());
  for (FlowType type : {FlowType::Poiseuille, FlowType::Shear, FlowType::None}) {
    FlowOptions flow{type, 0.7};
    std::vector<double> ux, uy, uz;
    node_velocities(solver, s, flow, ux, uy, uz);
    for (std::size_t i = 0; i < ux.size(); ++i) {
      const double y = s.y[i], H = kBox.H;
      const double expect = type == FlowType::Poiseuille ? 0.7 * y * (1.0 - y / H)
                            : type == FlowType::Shear    ? 0.7 * (y - 0.5 * H)
                                                         : 0.0;
      ASSERT_NEAR(ux[i], expect, 1e-12);
      ASSERT_NEAR(uy[i], 0.0, 1e-12);
      ASSERT_NEAR(uz[i], 0.0, 1e-12);
    }
  }
}

TEST_P(SingleLayerPhysics, PreInflatedCapsuleAtRestStaysAtRest) {
  // Isotropic tension on a sphere produces no flow (docs/method.md §2.3): the computed velocities are discretisation
  // error only, small against the velocity scale |f| a / mu of the tension and falling with the mesh level.
  double prev = 1.0;
  for (int level : {1, 2, 3}) {
    CapsuleState s(level);
    s.add_capsule({3.0, 3.0, 3.0}, 1.0, s.add_species(0.2));
    s.compute_membrane_forces(backend());
    SingleLayerPlan solver(kBox, GgemOptions{}, backend());
    std::vector<double> ux, uy, uz;
    node_velocities(solver, s, FlowOptions{FlowType::None, 1.0}, ux, uy, uz);
    const double scale = std::max({max_abs(s.fx), max_abs(s.fy), max_abs(s.fz)}) / kBox.viscosity;
    const double umax = std::max({max_abs(ux), max_abs(uy), max_abs(uz)});
    std::vector<double> U, omega;
    compute_mean_velocity(s, Backend::Serial, ux, uy, uz, U, omega);
    const double Umag = std::sqrt(U[0] * U[0] + U[1] * U[1] + U[2] * U[2]);
    std::printf("level %d: max |u| / (|f| a / mu) = %.2e, |U_capsule| / scale = %.2e\n", level, umax / scale,
                Umag / scale);
    EXPECT_LT(umax / scale, 0.05) << "level " << level;
    EXPECT_LT(umax / scale, prev) << "level " << level;
    EXPECT_LT(Umag / scale, 1e-3) << "level " << level;  // centred capsule: no net motion by symmetry
    prev = umax / scale;
  }
}

CAPSFLOW_ON_EACH_BACKEND(SingleLayerPhysics);

// The plan's life cycle on every backend: an apply repeated on one geometry gives the same bits (device: see
// expect_same); the stages called one
// by one give apply's bits; apply before set_geometry is refused.
class SingleLayerLifeCycle : public test::OnEachBackend {};

TEST_P(SingleLayerLifeCycle, TwoAppliesOnOneGeometryGiveTheSameBits) {
  const CapsuleState s = deformed_pair();
  SingleLayerPlan plan(kBox, GgemOptions{}, backend());
  plan.set_geometry(s);
  std::vector<double> a[3], b[3];
  plan.apply(s, a[0], a[1], a[2]);
  // Another density in between: the pack and the grids must not keep anything of it.
  std::vector<double> gx(s.fx.size(), 0.3), gy(s.fx.size(), -0.1), gz(s.fx.size(), 0.2), w[3];
  plan.apply(NodeField{gx, gy, gz}, NodeField{gx, gy, gz}, NodeFieldOut{w[0], w[1], w[2]});
  plan.apply(s, b[0], b[1], b[2]);
  for (int c = 0; c < 3; ++c) expect_same(backend(), a[c], b[c], c);
  EXPECT_GT(max_abs(a[0]) + max_abs(a[1]) + max_abs(a[2]), 0.0);
}

TEST_P(SingleLayerLifeCycle, StagesOneByOneGiveApplysBits) {
  const CapsuleState s = deformed_pair();
  SingleLayerPlan plan(kBox, GgemOptions{}, backend());
  plan.set_geometry(s);
  std::vector<double> a[3];
  plan.apply(s, a[0], a[1], a[2]);
  const std::size_t n = s.fx.size();
  std::vector<double> u[3] = {std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  const NodeField f{s.fx, s.fy, s.fz}, F{s.Fx, s.Fy, s.Fz};
  plan.local_at_nodes(f, NodeFieldOut{u[0], u[1], u[2]});
  plan.local_at_walls(f);
  // The wall data is the local part at the wall points: nonzero for capsules 0.8a from a wall.
  EXPECT_GT(max_abs(plan.wall_local_velocity(0)), 0.0);
  plan.global(F, NodeFieldOut{u[0], u[1], u[2]});
  for (int c = 0; c < 3; ++c) expect_same(backend(), a[c], u[c], c);
}

TEST_P(SingleLayerLifeCycle, ApplyBeforeSetGeometryIsALogicError) {
  const CapsuleState s = deformed_pair();
  SingleLayerPlan plan(kBox, GgemOptions{}, backend());
  std::vector<double> u[3];
  EXPECT_THROW(plan.apply(s, u[0], u[1], u[2]), std::logic_error);
  const CapsuleState other = deformed_pair(4);
  plan.set_geometry(other);
  EXPECT_THROW(plan.apply(s, u[0], u[1], u[2]), std::logic_error);  // not the state of set_geometry
}

// The plan's sum equals the free kernels' composition (the local sums packed per call, the global stages of a
// point-force GgemSolver with the same wall data), bit for bit on this backend.
TEST_P(SingleLayerLifeCycle, EqualsTheKernelComposition) {
  const CapsuleState s = deformed_pair();
  SingleLayerPlan plan(kBox, GgemOptions{}, backend());
  plan.set_geometry(s);
  std::vector<double> a[3];
  plan.apply(s, a[0], a[1], a[2]);

  GgemSolver ggem(kBox, GgemOptions{}, backend());
  const GgemGrid& g = ggem.grid();
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  const std::size_t n = s.x.size(), nw = ggem.wall_points(0).size();
  ElementCellList cl;
  build_element_cell_list(cl, kBox.Lx, kBox.H, kBox.Lz, g.cutoff, ncap, nv, ntri, tri, s.x.data(), s.y.data(),
                          s.z.data());
  std::vector<int> ids(n);
  for (std::size_t i = 0; i < n; ++i) ids[i] = static_cast<int>(i);
  const double scale = 1.0 / (8.0 * kPi * kBox.viscosity);
  std::vector<double> u[3] = {std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  std::vector<double> wl[3] = {std::vector<double>(nw, 0.0), std::vector<double>(nw, 0.0),
                               std::vector<double>(nw, 0.0)};
  const SurfaceView surface{ncap, nv, ntri, tri, s.x.data(), s.y.data(), s.z.data()};
  const Vec3In f{s.fx.data(), s.fy.data(), s.fz.data()};
  local_single_layer_velocity(backend(), cl, LocalSplit{g.alpha, g.cutoff, scale}, surface, f, QuadratureOrders{},
                              TargetView{n, s.x.data(), s.y.data(), s.z.data(), ids.data()},
                              Vec3Out{u[0].data(), u[1].data(), u[2].data()});
  local_single_layer_velocity(
      backend(), cl, LocalSplit{g.alpha, g.cutoff, scale}, surface, f, QuadratureOrders{},
      TargetView{nw, ggem.wall_points(0).data(), ggem.wall_points(1).data(), ggem.wall_points(2).data(), nullptr},
      Vec3Out{wl[0].data(), wl[1].data(), wl[2].data()});
  const double* wall[3] = {wl[0].data(), wl[1].data(), wl[2].data()};
  GgemGlobalPart& gp = ggem.global();
  gp.set_walls(wall);
  gp.spread(n, s.x.data(), s.y.data(), s.z.data(), s.Fx.data(), s.Fy.data(), s.Fz.data());
  gp.solve();
  gp.interpolate(n, s.x.data(), s.y.data(), s.z.data(), u[0].data(), u[1].data(), u[2].data());
  for (int c = 0; c < 3; ++c) expect_same(backend(), a[c], u[c], c);
}

CAPSFLOW_ON_EACH_BACKEND(SingleLayerLifeCycle);

class SingleLayerBackends : public test::OnEachBackend {};

TEST_P(SingleLayerBackends, MatchSerialOnDeformedCapsules) {
  const CapsuleState s = deformed_pair();
  std::vector<double> ur[3], uo[3];
  SingleLayerPlan ref(kBox, GgemOptions{}, Backend::Serial);
  SingleLayerPlan other(kBox, GgemOptions{}, GetParam());
  const FlowOptions flow{FlowType::Poiseuille, 1.0};
  node_velocities(ref, s, flow, ur[0], ur[1], ur[2]);
  node_velocities(other, s, flow, uo[0], uo[1], uo[2]);
  for (int c = 0; c < 3; ++c) EXPECT_LT(test::max_rel_error(uo[c], ur[c]), 1e-12) << "component " << c;
}

CAPSFLOW_ON_PARALLEL_BACKENDS(SingleLayerBackends);
