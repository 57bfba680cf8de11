// The resident device step (docs/device.md "Resident data"): a Simulation on the device backend keeps its arrays on
// the device (StepWorkspace) and moves only a documented set per step. Checked on every backend: the serial and
// threads backends must move nothing (the workspace is inactive there); the device must equal the serial run, move
// exactly the documented arrays per step, pull for an output record or a checkpoint exactly the arrays it writes, and
// continue a run from a checkpoint. On the host fallback (no GPU) the counts are the bookkeeping's, exactly as on a
// GPU; that the data really stays on the device is checked only on a GPU (tools/device-check.sh full).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/base/h5_file.hpp"
#include "host/run/run_driver.hpp"
#include "host/physics/simulation.hpp"
#include "support/backends.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {
using namespace capsflow;
namespace fs = std::filesystem;

// The tests' small run (support/small_run.hpp) on backend b, to strain 0.6 with records every 0.1 and checkpoints
// every 0.2.
Config small_config(Backend b) {
  Config c = parse_config(test::small_run_text(), "<test>");
  c.run.backend = b;
  c.time.end = 0.6;
  c.output.every = 0.1;
  c.output.checkpoint_every = 0.2;
  return c;
}

std::multiset<std::string> pulled(const StepWorkspace& ws) {
  std::multiset<std::string> names;
  for (const TransferRecord& r : ws.log())
    if (!r.to_device) names.insert(r.name);
  return names;
}

class ResidentStep : public test::OnEachBackend {
 protected:
  bool active() const { return backend() == Backend::Device; }
  // Positions after the device backend's steps differ from serial by round-off: on a GPU atomics reorder the
  // spreading sums and the device's libm rounds differently; on the host fallback the device global solve
  // (SlitStokesPlanDevice: its FFTs, the DCT as a matrix product) rounds differently from the CPU reference (~1e-15).
  double device_tol() const {
    if (backend() != Backend::Device) return 0.0;
    return device_count() > 0 ? 1e-10 : 1e-12;
  }
};

TEST_P(ResidentStep, SeveralStepsEqualTheSerialRun) {
  if (backend() == Backend::Serial)
    GTEST_SKIP() << "serial is this compare's reference (serial against serial proves nothing)";
  Simulation a(small_config(Backend::Serial)), b(small_config(backend()));
  double worst = 0.0;
  for (int k = 0; k < 5; ++k) {
    const StepInfo ia = a.advance(), ib = b.advance();
    ASSERT_EQ(ia.stop, StopReason::None);
    ASSERT_EQ(ib.stop, StopReason::None) << ib.message;
    // dt follows the smallest node distance, which carries the positions' round-off (on the host fallback the device
    // spreading's atomics add in an order that changes from run to run).
    if (backend() == Backend::Device)
      ASSERT_NEAR(ia.dt, ib.dt, device_tol() * ia.dt) << "step " << k;
    else
      ASSERT_EQ(ia.dt, ib.dt) << "step " << k;
  }
  const CapsuleState &sa = a.state(), &sb = b.state();
  for (std::size_t i = 0; i < sa.x.size(); ++i)
    worst = std::max({worst, std::abs(sa.x[i] - sb.x[i]), std::abs(sa.y[i] - sb.y[i]), std::abs(sa.z[i] - sb.z[i])});
  std::printf("  five steps, %s vs serial: max position difference %.3e\n", backend_name(backend()), worst);
  EXPECT_LE(worst, device_tol());
}

// The documented per-step set (docs/device.md): no array moves at all (the cell lists are binned and the step-size
// rule's node pairs searched on the device; the forces and wall data reach the global stages' kernels (GgemGlobalPart)
// present), six scalars come back (two finiteness checks, the left-slit check, the element radius of the mesh check,
// the largest element radius that sizes the element cell grid, the closest node pair of different capsules).
TEST_P(ResidentStep, AStepWithoutOutputMovesExactlyTheDocumentedArrays) {
  Simulation s(small_config(backend()));
  ASSERT_EQ(s.advance().stop, StopReason::None);  // the first step starts with both copies valid
  const StepWorkspace& ws = s.workspace();
  for (int k = 0; k < 3; ++k) {
    const TransferCounts before = ws.transfers();
    ws.clear_log();
    ASSERT_EQ(s.advance().stop, StopReason::None);
    const TransferCounts d = ws.transfers() - before;
    if (!active()) {
      EXPECT_EQ(d.calls(), 0);
      EXPECT_EQ(d.scalar_results, 0);
      EXPECT_EQ(ws.registered(), 0u);
      continue;
    }
    EXPECT_EQ(d.push_calls, 0) << "step " << k;
    EXPECT_EQ(d.pull_calls, 0) << "step " << k;
    EXPECT_EQ(d.pull_bytes, 0u) << "step " << k;
    EXPECT_EQ(d.scalar_results, 6) << "step " << k;
    EXPECT_EQ(ws.log().size(), 0u) << "step " << k;
  }
}

TEST_P(ResidentStep, OutputAndCheckpointPullExactlyTheArraysTheyWrite) {
  Simulation s(small_config(backend()));
  ASSERT_EQ(s.advance().stop, StopReason::None);
  ASSERT_EQ(s.advance().stop, StopReason::None);
  const StepWorkspace& ws = s.workspace();
  auto expect_pulls = [&](const std::multiset<std::string>& names, const char* what) {
    EXPECT_EQ(pulled(ws), active() ? names : std::multiset<std::string>{}) << what;
    ws.clear_log();
  };
  ws.clear_log();
  // A checkpoint after a step: the positions, the AB2 history and u^(n-2) (kept for the AB2 error proxy, so a
  // restarted run reports the same proxy as the uninterrupted one).
  (void)s.snapshot();
  expect_pulls({"x", "y", "z", "u_previous_x", "u_previous_y", "u_previous_z", "u_previous2_x", "u_previous2_y",
                "u_previous2_z"},
               "checkpoint");
  (void)s.snapshot();
  expect_pulls({}, "a second checkpoint moves nothing");
  // The driver records after evaluate(), which moves nothing (its cell lists are binned on the device).
  ASSERT_EQ(s.advance().stop, StopReason::None);
  s.evaluate();
  expect_pulls({}, "a step and an evaluation");
  // A series record: geometry (positions), the capsule velocities, the diagnostics (force density f_x).
  (void)s.geometry();
  (void)s.capsule_velocity();
  (void)s.flow_diagnostics();
  expect_pulls({"x", "y", "z", "capsule_velocity", "f_x"}, "series record");
  // A frame: positions and node velocities.
  (void)s.state();
  (void)s.ux();
  (void)s.uy();
  (void)s.uz();
  expect_pulls({"u_x", "u_y", "u_z"}, "frame");
}

// A device run interrupted and continued from its checkpoint reproduces the uninterrupted device run: bit for bit on
// the host fallback, to round-off on a GPU (atomics), through the real driver (output records, frames, checkpoints).
TEST_P(ResidentStep, RestartContinuesTheRun) {
  test::TempDir dir;
  std::ostringstream sink;
  const Config cfg = small_config(backend());
  RunSettings full_s;
  full_s.output = (dir.path / "full.h5").string();
  full_s.quiet = true;
  const RunResult full = run_simulation(cfg, full_s, sink);
  ASSERT_EQ(full.exit_code, 0) << full.stop_message;
  ASSERT_GE(full.steps, 8);

  RunSettings first = full_s;
  first.output = (dir.path / "part.h5").string();
  first.stop_after_steps = full.steps / 2 + 1;
  const RunResult part = run_simulation(cfg, first, sink);
  ASSERT_EQ(part.exit_code, 128 + SIGINT);
  RunSettings cont;
  cont.restart = part.checkpoint;
  cont.quiet = true;
  const RunResult rest = run_simulation(cfg, cont, sink);
  ASSERT_EQ(rest.exit_code, 0) << rest.stop_message;
  EXPECT_EQ(part.steps + rest.steps, full.steps);

  const H5File a = H5File::open(dir.path / "full.h5"), b = H5File::open(dir.path / "part.h5");
  for (const char* p : {"/series/time", "/series/centroid", "/series/velocity", "/series/volume", "/frames/positions",
                        "/frames/velocity"}) {
    const auto x = a.read<double>(p), y = b.read<double>(p);
    ASSERT_EQ(x.dims, y.dims) << p;
    double worst = 0.0;
    for (std::size_t i = 0; i < x.data.size(); ++i) worst = std::max(worst, std::abs(x.data[i] - y.data[i]));
    EXPECT_LE(worst, device_tol()) << p;
  }
}

CAPSFLOW_ON_EACH_BACKEND(ResidentStep);

}  // namespace
