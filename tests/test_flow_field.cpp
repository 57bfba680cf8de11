// `capsflow flow` (issue 53, run/flow_field.hpp): the fluid velocity of a frame at points off the membranes by the
// solver's own operator. Checked against what must hold exactly (no load: the imposed slit flow; the walls: no
// disturbance; x = 0 and x = Lx: the same point of the periodic box), against the solver's node velocities (at the
// nodes themselves: the same sums; elsewhere on the membrane: the node values interpolated, to the discretisation),
// for the velocity's continuity across the membrane (the double layer's jump at a viscosity ratio != 1 included), and
// for the files and refusals of the command.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/base/h5_file.hpp"
#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"
#include "host/run/flow_field.hpp"
#include "host/run/frame_start.hpp"
#include "host/run/run_driver.hpp"
#include "host/state/icosphere.hpp"
#include "kernels/step_update.hpp"
#include "support/cli_runner.hpp"
#include "support/run_files.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

// Runs `c` in `dir` and returns its last frame (its configuration with the run's backend).
FrameStart last_frame(const test::TempDir& dir, const Config& c) {
  EXPECT_EQ(run_simulation(c, test::quiet_run(dir.path / "run.h5"), std::cerr).exit_code, 0);
  return read_frame_start((dir.path / "run.h5").string(), -1, "");
}

double max_abs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// Points on capsule k's membrane: its triangles' centroids, with their unit normals (outward).
void triangle_centroids(const FrameStart& f, std::size_t k0, FlowTargets& t, std::vector<double>& normal) {
  const TriMesh& m = icosphere(f.source.capsules.mesh_level);
  const std::vector<double>& p = f.state.positions;
  const std::size_t first = k0 * m.x.size();
  for (std::size_t e = 0; 3 * e < m.tri.size(); ++e) {
    double v[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) v[k][c] = p[3 * (first + static_cast<std::size_t>(m.tri[3 * e + k])) + c];
    const double a[3] = {v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]};
    const double b[3] = {v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]};
    double n[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (double& c : n) c /= len;
    t.x.push_back((v[0][0] + v[1][0] + v[2][0]) / 3.0);
    t.y.push_back((v[0][1] + v[1][1] + v[2][1]) / 3.0);
    t.z.push_back((v[0][2] + v[1][2] + v[2][2]) / 3.0);
    normal.insert(normal.end(), n, n + 3);
  }
  t.nu = t.x.size();
}

// The targets moved by `eps` along their normals.
FlowTargets moved(const FlowTargets& t, const std::vector<double>& normal, double eps) {
  FlowTargets m = t;
  for (std::size_t p = 0; p < t.size(); ++p) {
    m.x[p] += eps * normal[3 * p];
    m.y[p] += eps * normal[3 * p + 1];
    m.z[p] += eps * normal[3 * p + 2];
  }
  return m;
}

// No membrane load (capsules uninflated at their reference shape: the membrane forces are zero up to the rounding of
// the deformation gradient of an undeformed element, ~1e-17), so S[f] vanishes to rounding and the velocity everywhere,
// inside the capsules too, is the imposed slit flow: equal to 1e-14 of its scale, Poiseuille and shear alike.
TEST(FlowField, WithoutALoadTheImposedSlitFlow) {
  for (const char* type : {"poiseuille", "shear"}) {
    SCOPED_TRACE(type);
    test::TempDir dir;
    Config c = test::small_serial_config(0.01);
    c.capsules.membrane.inflation = 0.0;
    c.flow.type = std::string(type) == "shear" ? FlowType::Shear : FlowType::Poiseuille;
    c.flow.shear_rate = 1.7;
    ASSERT_EQ(run_simulation(c, test::quiet_run(dir.path / "run.h5"), std::cerr).exit_code, 0);
    const FrameStart f = read_frame_start((dir.path / "run.h5").string(), 0, "");
    const FlowField u = frame_flow(f, f.source, plane_targets(f.source, "z=3.1", 0.2));
    ASSERT_GT(std::count(u.capsule.begin(), u.capsule.end(), 0), 10);  // the plane cuts the capsules
    const int code = c.flow.type == FlowType::Shear ? kImposedShear : kImposedPoiseuille;
    const double tol = 1e-14 * 1.7 * c.domain.H;
    for (std::size_t p = 0; p < u.at.size(); ++p) {
      ASSERT_NEAR(u.ux[p], imposed_flow_x(code, 1.7, c.domain.H, u.at.y[p]), tol) << p;
      ASSERT_NEAR(u.uy[p], 0.0, tol) << p;
      ASSERT_NEAR(u.uz[p], 0.0, tol) << p;
    }
  }
}

// On the walls the disturbance vanishes (the walls' correction), x = 0 and x = Lx are one point of the periodic box,
// and the plane z = 3.1 through both capsules' centres is a mirror plane of the problem: u_z vanishes on it up to the
// mesh's own asymmetry (the icosahedral mesh is not mirror-symmetric in z, and the capsules have deformed with it).
TEST(FlowField, WallsPeriodicityAndTheMirrorPlane) {
  test::TempDir dir;
  const FrameStart f = last_frame(dir, test::small_serial_config(0.2));
  const FlowField u = frame_flow(f, f.source, plane_targets(f.source, "z=3.1", 0.1));
  const std::size_t nu = u.at.nu, nv = u.at.nv;
  const double scale = std::max(max_abs(u.dx), max_abs(u.dy));
  ASSERT_GT(scale, 0.1);  // the capsules disturb the flow
  for (std::size_t i = 0; i < nu; ++i)
    for (std::size_t j : {std::size_t{0}, nv - 1}) {
      const std::size_t p = j * nu + i;
      EXPECT_LT(std::abs(u.dx[p]) + std::abs(u.dy[p]) + std::abs(u.dz[p]), 1e-12 * scale) << "wall point " << p;
    }
  for (std::size_t j = 0; j < nv; ++j) {
    const std::size_t a = j * nu, b = j * nu + nu - 1;
    EXPECT_NEAR(u.ux[a], u.ux[b], 1e-12 * scale);
    EXPECT_NEAR(u.uy[a], u.uy[b], 1e-12 * scale);
  }
  EXPECT_LT(max_abs(u.uz), 1e-4 * scale);
}

// At the nodes (the points given as the frame's node positions, bit for bit) the solver's own node velocities come
// back: the same local sums with the singular rule at the node, the same global part interpolated at the same point.
// Elsewhere on the membrane (triangle centroids, which no node is) the field is the node values interpolated up to
// the discretisation: the near-singular rule on the target's own element against the linear interpolation of a
// curved field over elements of h ~ 0.3 a (mesh level 2), both O(h^2): measured 1.2 % of the velocity's range at
// level 2 (10 % at level 1); 2 % allowed.
TEST(FlowField, OnTheMembraneTheSolversNodeVelocities) {
  test::TempDir dir;
  Config c = test::small_serial_config(0.2);
  c.capsules.mesh_level = 2;
  c.capsules.velocity_projection = false;  // the node velocities are then u_inf + S[f] exactly
  const FrameStart f = last_frame(dir, c);
  Simulation sim(f.source, f.state, "");
  sim.evaluate();
  FlowTargets nodes;
  const std::vector<double>& p = f.state.positions;
  for (std::size_t i = 0; 3 * i < p.size(); ++i) {
    nodes.x.push_back(p[3 * i]);
    nodes.y.push_back(p[3 * i + 1]);
    nodes.z.push_back(p[3 * i + 2]);
  }
  nodes.nu = nodes.x.size();
  const FlowField u = frame_flow(f, f.source, nodes);
  EXPECT_EQ(u.nodes_matched, nodes.size());
  const double range = max_abs(sim.ux());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    ASSERT_NEAR(u.ux[i], sim.ux()[i], 1e-13 * range) << i;
    ASSERT_NEAR(u.uy[i], sim.uy()[i], 1e-13 * range) << i;
    ASSERT_NEAR(u.uz[i], sim.uz()[i], 1e-13 * range) << i;
    ASSERT_EQ(u.capsule[i], static_cast<int>(i / 162)) << i;
  }

  FlowTargets on;
  std::vector<double> normal;
  triangle_centroids(f, 0, on, normal);
  const FlowField w = frame_flow(f, f.source, on);
  const TriMesh& m = icosphere(2);
  double worst = 0.0;
  for (std::size_t e = 0; e < on.size(); ++e) {
    double mean[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < 3; ++k) {
      const std::size_t i = static_cast<std::size_t>(m.tri[3 * e + k]);
      mean[0] += sim.ux()[i] / 3.0;
      mean[1] += sim.uy()[i] / 3.0;
      mean[2] += sim.uz()[i] / 3.0;
    }
    worst = std::max({worst, std::abs(w.ux[e] - mean[0]), std::abs(w.uy[e] - mean[1]), std::abs(w.uz[e] - mean[2])});
  }
  EXPECT_LT(worst, 0.02 * range);
}

// The largest difference between the velocity extrapolated to capsule 1's membrane from outside and from inside: from
// 0.05 a and 0.1 a along the normal of each triangle centroid, linearly (the gradient jumps across the membrane), with
// the floppy capsule's viscosity ratio `lambda` and mesh level `level`.
double jump_across(double lambda, int level) {
  test::TempDir dir;
  Config c = test::small_serial_config(0.1);
  c.capsules.mesh_level = level;
  c.species[1].viscosity_ratio = lambda;
  const FrameStart f = last_frame(dir, c);
  FlowTargets on, all;
  std::vector<double> normal;
  triangle_centroids(f, 1, on, normal);
  const std::size_t n = on.size();
  for (double eps : {0.05, 0.1, -0.05, -0.1}) {  // one evaluation (one interface solve) for the four sets
    const FlowTargets m = moved(on, normal, eps);
    all.x.insert(all.x.end(), m.x.begin(), m.x.end());
    all.y.insert(all.y.end(), m.y.begin(), m.y.end());
    all.z.insert(all.z.end(), m.z.begin(), m.z.end());
  }
  all.nu = all.x.size();
  const FlowField u = frame_flow(f, f.source, all);
  double jump = 0.0, range = 0.0;
  for (std::size_t p = 0; p < n; ++p) {
    EXPECT_EQ(u.capsule[p], -1) << p;
    EXPECT_EQ(u.capsule[2 * n + p], 1) << p;
    for (const std::vector<double>* v : {&u.ux, &u.uy, &u.uz}) {
      const std::vector<double>& w = *v;
      jump = std::max(jump, std::abs((2 * w[p] - w[n + p]) - (2 * w[2 * n + p] - w[3 * n + p])));
    }
    range = std::max(range, std::abs(u.ux[p]));
  }
  return jump / range;
}

// The velocity is continuous across the membrane. Without a viscosity contrast the single layer gives it to 0.3 % of
// the velocity's range (1 % allowed). At a viscosity ratio of 5 the double layer of (1 - lambda) u_s and the 1 / lambda
// inside carry it, less accurately near the membrane (the double layer's near-singular quadrature and the interface
// solve's discretisation): measured 25 % at level 1 and 8 % at level 2 (3 times smaller for h halved). Asserted:
// under 15 % at level 2 and at least 2.5 times smaller than at level 1; a wrong sign or factor in the representation
// (or the inside's lambda forgotten) stays O(1) at every level.
TEST(FlowField, ContinuousAcrossTheMembraneAlsoAtAViscosityRatio) {
  EXPECT_LT(jump_across(1.0, 1), 0.01);
  const double coarse = jump_across(5.0, 1), fine = jump_across(5.0, 2);
  EXPECT_LT(fine, 0.15);
  EXPECT_LT(fine, coarse / 2.5) << coarse;  // 4 for second order, 2 for first
}

// The command: FLOW.h5 (the fields, points and capsules), FLOW.xdmf naming it, FLOW.png for a plane; --points gives
// the same velocities at the same points as the plane. Bad input: one line naming what is wrong, exit 2, no file.
TEST(FlowField, TheCommandWritesItsFilesAndRefusesBadInput) {
  test::TempDir dir;
  {
    std::ofstream(dir.path / "small.toml") << test::small_run_text();
    std::ofstream(dir.path / "pts.csv") << "x,y,z\n0,0,3.1\n3.1,3.0,3.1\n";
    std::ofstream(dir.path / "wall.csv") << "x,y,z\n1,7,1\n";
  }
  ASSERT_EQ(test::run_capsflow(dir.path, "run small.toml --output a.h5 -q --backend serial --set time.end=0.1").status,
            0);
  const test::CliResult r = test::run_capsflow(dir.path, "flow a.h5 --plane z=3.1 --spacing 0.1 --out f.h5");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("63 x 61"), std::string::npos) << r.err;
  const H5File h = H5File::open(dir.path / "f.h5");
  EXPECT_EQ(h.attribute<std::string>("/", "format"), "capsflow-flow");
  EXPECT_EQ(h.attribute<std::string>("/", "plane"), "z=3.1");
  EXPECT_EQ(h.dims("/velocity"), (std::vector<std::size_t>{63 * 61, 3}));
  const std::string xdmf = test::slurp_file(dir.path / "f.xdmf");
  for (const char* s : {"3DSMesh", "Dimensions=\"1 61 63\"", "f.h5:/points", "f.h5:/velocity", "f.h5:/disturbance"})
    EXPECT_NE(xdmf.find(s), std::string::npos) << s;
  EXPECT_GT(fs::file_size(dir.path / "f.png"), 20000u);  // two filled panels, not an empty canvas

  // The same points through --points: the same numbers (the grid's (0, 0) corner and the point (3.1, 3)).
  ASSERT_EQ(test::run_capsflow(dir.path, "flow a.h5 --points pts.csv --out p.h5 -q").status, 0);
  const auto grid = h.read<double>("/velocity").data, pts = H5File::open(dir.path / "p.h5").read<double>("/velocity").data;
  const std::size_t mid = 30 * 63 + 31;  // y = 30 * 0.1, x = 31 * 0.1
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(pts[static_cast<std::size_t>(c)], grid[static_cast<std::size_t>(c)]);
    EXPECT_EQ(pts[3 + static_cast<std::size_t>(c)], grid[3 * mid + static_cast<std::size_t>(c)]);
  }
  EXPECT_FALSE(fs::exists(dir.path / "p.png"));  // a picture for planes only
  EXPECT_NE(test::slurp_file(dir.path / "p.xdmf").find("Polyvertex"), std::string::npos);

  const auto before = test::snapshot_files(dir.path);
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --plane z=3.1 --out f.h5"), {"f.h5", "exists"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --plane w=1 --out g.h5"), {"--plane", "w=1"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --plane y=7 --out g.h5"), {"--plane", "y=7"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --points wall.csv --out g.h5"), {"wall.csv"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --plane z=1 --points pts.csv --out g.h5"), {});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --out g.h5"), {});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --plane z=1 --out g.txt"), {"--out g.txt", ".h5"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --frame 9 --plane z=1 --out g.h5"),
                           {"--frame 9", "a.h5 has 1 frame (0, or -1 from the end)"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow small.toml --plane z=1 --out g.h5"), {"small.toml"});
  test::expect_input_error(test::run_capsflow(dir.path, "flow a.h5 --plane z=1 --out a.h5 --force"), {"a.h5"});
  EXPECT_EQ(test::snapshot_files(dir.path), before);
}

}  // namespace
