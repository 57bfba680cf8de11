// Node velocities of capsule membranes (local element integrals + GGEM global part + imposed flow).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "host/capsule_velocity.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace {

const SlitGeometry kBox{6.0, 6.0, 6.0, 1.0};  // a = 1: Lx = Lz = 2 (r_c + 2a) at alpha = 4 (pitfall P5)

double max_abs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

}  // namespace

// Physics on every backend (the backends harness): exact answers, no serial oracle.
class CapsuleVelocityPhysics : public test::OnEachBackend {};

TEST_P(CapsuleVelocityPhysics, UnstressedCapsuleMovesWithTheImposedFlow) {
  MembraneParameters p;
  p.inflation = 0.0;  // reference shape = current shape: no membrane force at all
  CapsuleState s(1, p);
  s.add_capsule({3.0, 2.0, 3.0}, 1.0, s.add_species(0.2));
  s.compute_membrane_forces(backend());
  EXPECT_LT(max_abs(s.fx), 1e-12);  // rounding of C = I only
  CapsuleVelocitySolver solver(kBox, GgemOptions{}, backend());
  for (FlowType type : {FlowType::Poiseuille, FlowType::Shear, FlowType::None}) {
    FlowOptions flow{type, 0.7};
    std::vector<double> ux, uy, uz;
    solver.node_velocities(s, flow, ux, uy, uz);
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

TEST_P(CapsuleVelocityPhysics, PreInflatedCapsuleAtRestStaysAtRest) {
  // Isotropic tension on a sphere produces no flow (method-spec 3.1): the computed velocities are discretisation
  // error only, small against the velocity scale |f| a / mu of the tension and falling with the mesh level.
  double prev = 1.0;
  for (int level : {1, 2, 3}) {
    CapsuleState s(level);
    s.add_capsule({3.0, 3.0, 3.0}, 1.0, s.add_species(0.2));
    s.compute_membrane_forces(backend());
    CapsuleVelocitySolver solver(kBox, GgemOptions{}, backend());
    std::vector<double> ux, uy, uz;
    solver.node_velocities(s, FlowOptions{FlowType::None, 1.0}, ux, uy, uz);
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

CAPSFLOW_ON_EACH_BACKEND(CapsuleVelocityPhysics);

class CapsuleVelocityBackends : public test::OnEachBackend {};

TEST_P(CapsuleVelocityBackends, MatchSerialOnDeformedCapsules) {
  CapsuleState s(1);
  const int sp = s.add_species(0.3);
  s.add_capsule({1.0, 2.0, 5.5}, 1.0, sp);  // straddles the periodic seams
  s.add_capsule({3.6, 3.9, 3.0}, 1.0, sp);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> d(-0.05, 0.05);
  for (auto* v : {&s.x, &s.y, &s.z})
    for (double& c : *v) c += d(rng);
  s.compute_membrane_forces(Backend::Serial);
  std::vector<double> ur[3], uo[3];
  CapsuleVelocitySolver ref(kBox, GgemOptions{}, Backend::Serial);
  CapsuleVelocitySolver other(kBox, GgemOptions{}, GetParam());
  const FlowOptions flow{FlowType::Poiseuille, 1.0};
  ref.node_velocities(s, flow, ur[0], ur[1], ur[2]);
  other.node_velocities(s, flow, uo[0], uo[1], uo[2]);
  for (int c = 0; c < 3; ++c) EXPECT_LT(test::max_rel_error(uo[c], ur[c]), 1e-12) << "component " << c;
}

CAPSFLOW_ON_PARALLEL_BACKENDS(CapsuleVelocityBackends);
