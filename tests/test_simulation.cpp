// Time integration and `capsflow run` driver (src/host/physics/simulation.*, src/host/run/run_driver.*): restart continuity bit for
// bit, backend equivalence of one full step, pinned mode, stop conditions with a final checkpoint, no silent
// overwrite, signals, and the output layout.
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/run/checkpoint.hpp"
#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "host/solver/sample_problems.hpp"
#include "host/physics/simulation.hpp"
#include "host/run/steady_state.hpp"
#include "support/backends.hpp"
#include "support/small_run.hpp"
#include "support/step_compare.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

// Two level-1 capsules in simple shear in the smallest box the cutoff allows: a few ms per step.
std::string small_config(const std::string& extra = "") { return test::small_run_text(extra); }

Config config_from(const std::string& text) { return parse_config(text, "<test>"); }

RunSettings quiet_settings(const fs::path& out) {
  RunSettings s;
  s.output = out.string();
  s.quiet = true;
  return s;
}

std::ostringstream sink;

void expect_same_dataset(const H5File& a, const H5File& b, const std::string& path) {
  SCOPED_TRACE(path);
  ASSERT_TRUE(a.exists(path));
  ASSERT_TRUE(b.exists(path));
  const auto x = a.read<double>(path), y = b.read<double>(path);
  ASSERT_EQ(x.dims, y.dims);
  for (std::size_t i = 0; i < x.data.size(); ++i)
    ASSERT_EQ(std::memcmp(&x.data[i], &y.data[i], sizeof(double)), 0) << "element " << i << ": " << x.data[i]
                                                                        << " vs " << y.data[i];
}

const char* kSeries[] = {"/series/time",     "/series/step",     "/series/dt",          "/series/centroid",
                         "/series/velocity", "/series/taylor_D", "/series/inclination", "/series/volume",
                         "/series/area",     "/series/contact_corrections"};

TEST(RunRestart, ContinuedRunReproducesTheUninterruptedSeriesBitForBit) {
  test::TempDir dir;
  const Config cfg = config_from(small_config());

  const RunResult full = run_simulation(cfg, quiet_settings(dir.path / "full.h5"), sink);
  ASSERT_EQ(full.exit_code, 0);
  ASSERT_GE(full.steps, 15);

  // Interrupted after a number of steps past the first checkpoint (at strain 0.4): the checkpoint written on
  // interruption is the one continued from; the output holds records past an older checkpoint too.
  RunSettings first = quiet_settings(dir.path / "part.h5");
  first.stop_after_steps = full.steps / 2 + 3;
  const RunResult part = run_simulation(cfg, first, sink);
  EXPECT_EQ(part.exit_code, 128 + SIGINT);
  EXPECT_LT(part.time, 1.0);

  RunSettings cont;
  cont.restart = part.checkpoint;
  cont.quiet = true;
  const RunResult rest = run_simulation(cfg, cont, sink);
  ASSERT_EQ(rest.exit_code, 0) << rest.stop_message;
  EXPECT_EQ(part.steps + rest.steps, full.steps);

  const H5File a = H5File::open(dir.path / "full.h5"), b = H5File::open(dir.path / "part.h5");
  for (const char* p : kSeries) expect_same_dataset(a, b, p);
  expect_same_dataset(a, b, "/frames/time");
  expect_same_dataset(a, b, "/frames/positions");
  const H5File ca = H5File::open(full.checkpoint), cb = H5File::open(rest.checkpoint);
  expect_same_dataset(ca, cb, "/state/positions");
  expect_same_dataset(ca, cb, "/state/u_previous");
}

TEST(RunRestart, RestartFromAnOlderCheckpointTruncatesTheLaterRecords) {
  test::TempDir dir;
  const Config cfg = config_from(small_config());
  const RunResult full = run_simulation(cfg, quiet_settings(dir.path / "run.h5"), sink);
  ASSERT_EQ(full.exit_code, 0);
  const std::size_t n_full = H5File::open(dir.path / "run.h5").extent("/series/time");

  // Keep a copy of the output as it was at the end, then continue the same run from its final checkpoint to a
  // later end: the first n_full records must be unchanged and more must follow.
  RunSettings more;
  more.restart = full.checkpoint;
  more.end = 1.3;
  more.quiet = true;
  fs::copy_file(dir.path / "run.h5", dir.path / "copy.h5");
  const RunResult r = run_simulation(cfg, more, sink);
  ASSERT_EQ(r.exit_code, 0);
  const H5File a = H5File::open(dir.path / "copy.h5"), b = H5File::open(dir.path / "run.h5");
  const auto ta = a.read<double>("/series/time"), tb = b.read<double>("/series/time");
  ASSERT_GT(tb.data.size(), n_full);
  for (std::size_t i = 0; i < n_full; ++i) EXPECT_EQ(ta.data[i], tb.data[i]);
  EXPECT_GE(tb.data.back(), 1.3 - 1e-9);
}

// --restart with --set: run-control keys change the continued run; a physics key is refused before any file changes.
TEST(RunRestart, RestartTakesRunControlOverridesAndRefusesPhysicsKeys) {
  test::TempDir dir;
  const Config cfg = config_from(small_config());
  const RunResult full = run_simulation(cfg, quiet_settings(dir.path / "run.h5"), sink);
  ASSERT_EQ(full.exit_code, 0);
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string h5 = bytes(dir.path / "run.h5"), ck = bytes(full.checkpoint);

  RunSettings physics;
  physics.restart = full.checkpoint;
  physics.quiet = true;
  physics.overrides = parse_overrides({"time.end=1.2", "capsules.inflation=0.2"});
  try {
    run_simulation(cfg, physics, sink);
    FAIL() << "a physics key was accepted on --restart";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--set capsules.inflation: cannot change when continuing a run", 0), 0u)
        << e.what();
  }
  EXPECT_EQ(bytes(dir.path / "run.h5"), h5);
  EXPECT_EQ(bytes(full.checkpoint), ck);

  RunSettings control;
  control.restart = full.checkpoint;
  control.quiet = true;
  control.overrides = parse_overrides({"time.end=1.2", "output.every=0.1", "run.backend=serial"});
  const RunResult r = run_simulation(cfg, control, sink);
  ASSERT_EQ(r.exit_code, 0) << r.stop_message;
  EXPECT_GE(r.time, 1.2 - 1e-9);
  const Config stored = checkpoint_config(read_checkpoint(r.checkpoint), r.checkpoint);
  EXPECT_EQ(*stored.time.end, 1.2);
  EXPECT_EQ(stored.output.every, 0.1);
  EXPECT_EQ(stored.run.backend, Backend::Serial);
}

// [time] stop_pair_dx ends a pair collision at the first record where x_top - x_bottom reaches the value.
TEST(RunStop, PairSeparationStopsAtTheFirstRecordPastIt) {
  test::TempDir dir;
  // small_config's pair: the floppy capsule on top (y 3.5, x 4.3), the stiff one below (y 2.6, x 2.0): in shear
  // x_top - x_bottom = 2.3 grows by ~0.9 per strain unit, so 2.6 is crossed near strain 0.33 of the 1.0 allowed.
  std::string text = small_config();
  text.replace(text.find("end = 1.0"), 9, "end = 1.0\nstop_pair_dx = 2.6");
  const RunResult r = run_simulation(config_from(text), quiet_settings(dir.path / "pair.h5"), sink);
  ASSERT_EQ(r.exit_code, 0) << r.stop_message;
  EXPECT_NE(r.stop_message.find("pair separation reached"), std::string::npos) << r.stop_message;
  EXPECT_LT(r.time, 0.6);
  const RunFile f = read_run_file(dir.path / "pair.h5");
  ASSERT_GE(f.records, 3u);
  auto dx = [&](std::size_t rec) {
    const double* c = &f.centroid[rec * f.np * 3];
    return c[1] >= c[4] ? c[0] - c[3] : c[3] - c[0];
  };
  EXPECT_NEAR(dx(0), 2.3, 1e-12);
  EXPECT_GE(dx(f.records - 1), 2.6);  // the stop record is past the separation
  EXPECT_LT(dx(f.records - 2), 2.6);  // and the one before it is not
  EXPECT_EQ(f.time.back(), r.time);

  // The key needs a pair: a third capsule is an input error naming it.
  std::string three = text;
  three.replace(three.find("[time]"), 6, "[[capsule]]\nspecies = \"stiff\"\ncenter = [3.1, 1.2, 0.5]\n[time]");
  try {
    config_from(three);
    FAIL() << "three capsules accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "<test>: [time] stop_pair_dx: expected exactly two [[capsule]] entries (a pair) for a stop on their "
              "separation, got 3 [[capsule]]");
  }
}

class StepBackends : public test::OnEachBackend {};

TEST_P(StepBackends, OneFullStepMatchesSerial) {
  Config cs = config_from(small_config());
  cs.run.backend = Backend::Serial;
  Config cp = cs;
  cp.run.backend = GetParam();
  Simulation a(cs), b(cp);
  // Two steps: the Euler start and one AB2 step (with history).
  for (int k = 0; k < 2; ++k) {
    const StepInfo ia = a.advance(), ib = b.advance();
    ASSERT_EQ(ia.stop, StopReason::None);
    ASSERT_EQ(ib.stop, StopReason::None);
    // Step 2's dt follows the node distances after step 1, which carry the device's round-off.
    if (GetParam() == Backend::Device)
      EXPECT_NEAR(ia.dt, ib.dt, 1e-11 * ia.dt);
    else
      EXPECT_EQ(ia.dt, ib.dt);
  }
  const double tol = GetParam() == Backend::Device ? 1e-11 : 0.0;  // threads: same summation order, same bits
  double worst = 0.0;
  for (std::size_t i = 0; i < a.state().x.size(); ++i) {
    worst = std::max(worst, std::abs(a.state().x[i] - b.state().x[i]));
    worst = std::max(worst, std::abs(a.state().y[i] - b.state().y[i]));
    worst = std::max(worst, std::abs(a.state().z[i] - b.state().z[i]));
  }
  EXPECT_LE(worst, tol);
}

// The paper's set A (50 level-2 capsules, bench/bench_step.cpp) for two steps (Euler, then AB2): each step's
// displacement against the serial one, relative to the largest serial displacement. 1e-10 is the target for
// the device (atomics reorder the spreading sums); the host backends give the same bits. The threads instance runs in
// the default suite (about 5 s on 2 cores); the device instance where CAPSFLOW_TEST_SET_A=1 (tools/device-check.sh on
// a GPU, the offload-host preset): on the OpenMP runtime's host fallback it is a serial run of set A twice over.
TEST_P(StepBackends, SetAStepsMatchSerial) {
  if (const char* v = std::getenv("CAPSFLOW_TEST_SET_A");
      backend() == Backend::Device && (v == nullptr || std::string(v) != "1"))
    GTEST_SKIP() << "set A compare on the device: set CAPSFLOW_TEST_SET_A=1 (tools/device-check.sh does, on a GPU); "
                    "the small configuration of OneFullStepMatchesSerial covers the device in this run";
  Config cs = config_from(set_a_step_problem_toml());
  cs.run.backend = Backend::Serial;
  Config cp = cs;
  cp.run.backend = backend();
  Simulation a(cs), b(cp);
  for (int k = 0; k < 2; ++k) {
    const test::Positions before(a);
    const StepInfo ia = a.advance(), ib = b.advance();
    ASSERT_EQ(ia.stop, StopReason::None);
    ASSERT_EQ(ib.stop, StopReason::None);
    // dt carries the positions' round-off on the device (1e-10 relative); a capped step or a different h pair would
    // move it by far more.
    if (backend() == Backend::Device)
      ASSERT_NEAR(ia.dt, ib.dt, 1e-10 * ia.dt)
          << "a discrete decision flipped (dt): the compare needs a configuration far from one";
    else
      ASSERT_EQ(ia.dt, ib.dt) << "a discrete decision flipped (dt): the compare needs a configuration far from one";
    ASSERT_EQ(ia.contact.pair_corrections + ia.contact.wall_corrections, 0L) << "contact in set A's first steps";
    const test::StepDifference d = test::step_difference(before, a, b);
    std::printf("  set A step %d, %s vs serial: max displacement difference / max displacement = %.3e\n", k + 1,
                backend_name(backend()), d.worst / d.scale);
    EXPECT_LE(d.worst / d.scale, oracle_tol(1e-10)) << "step " << k + 1;
  }
}

CAPSFLOW_ON_PARALLEL_BACKENDS(StepBackends);

TEST(Simulation, TimeStepFollowsD8AndTheFirstStepIsEuler) {
  Config c = config_from(small_config());
  c.capsules.volume_correction = false;  // the update alone (the position projection moves nodes after it)
  Simulation s(c);
  s.evaluate();
  const std::vector<double> x0 = s.state().x, u0 = s.ux();
  bool between = true;
  const double h = s.min_node_distance(&between);
  EXPECT_FALSE(between);  // the capsules start far apart
  const StepInfo st = s.advance();
  EXPECT_DOUBLE_EQ(st.dt, 0.5 * 0.2 * h);
  for (std::size_t i = 0; i < x0.size(); ++i) ASSERT_NEAR(s.state().x[i], x0[i] + st.dt * u0[i], 1e-14);
  // Second step: AB2 with r = dt1/dt0 from the saved history.
  s.evaluate();
  const std::vector<double> x1 = s.state().x, u1 = s.ux();
  const StepInfo st2 = s.advance();
  const double r = st2.dt / st.dt;
  for (std::size_t i = 0; i < x1.size(); ++i)
    ASSERT_NEAR(s.state().x[i], x1[i] + st2.dt * ((1 + r / 2) * u1[i] - (r / 2) * u0[i]), 1e-13);
}

// Issue 36: a stop rule added as a hook refuses a step like the built-in ones: the state stays at x^n with its
// step count and time, the reason and the hook's message come back, and a later step without the rule's objection
// is taken as usual.
TEST(Simulation, AnAddedStopRuleRefusesTheStepAndKeepsTheState) {
  Simulation s(config_from(small_config()));
  bool object = false;
  int calls = 0;
  s.add_step_check([&](StepCheckContext& c, const StepInfo&, std::string& why) {
    ++calls;
    EXPECT_EQ(c.s.x.size(), s.state().x.size());  // the new positions, judged before they are kept
    if (!object) return StopReason::None;
    why = "the test's rule objects";
    return StopReason::LeftSlit;
  });
  ASSERT_EQ(s.advance().stop, StopReason::None);
  EXPECT_EQ(calls, 1);
  const std::vector<double> x1 = s.positions();
  const double t1 = s.time();
  object = true;
  const StepInfo refused = s.advance();
  EXPECT_EQ(refused.stop, StopReason::LeftSlit);
  EXPECT_NE(refused.message.find("the test's rule objects"), std::string::npos) << refused.message;
  EXPECT_EQ(s.positions(), x1);
  EXPECT_EQ(s.time(), t1);
  EXPECT_EQ(s.step(), 1);
  object = false;
  EXPECT_EQ(s.advance().stop, StopReason::None);
  EXPECT_EQ(s.step(), 2);
}

TEST(Simulation, NodeDistanceBetweenCapsulesSetsTheStep) {
  // Two capsules 0.1 apart (surface to surface): the inter-capsule node distance is below the edge length.
  Config c = config_from(small_config());
  c.capsule_list[0].center = {2.0, 3.0, 3.1};
  c.capsule_list[1].center = {4.1, 3.0, 3.1};
  Simulation s(c);
  bool between = false;
  const double h = s.min_node_distance(&between);
  EXPECT_TRUE(between);
  EXPECT_NEAR(h, 0.1, 1e-12);  // icosphere nodes at the poles +-x face each other
}

TEST(Simulation, PinnedCapsuleKeepsItsCentreAndReportsAMigrationVelocity) {
  Config c = config_from(small_config());
  c.flow.type = FlowType::Poiseuille;
  c.capsule_list.resize(1);
  c.capsule_list[0].center = {3.1, 1.9, 3.1};
  c.capsule_list[0].pinned = true;
  Simulation s(c);
  const std::vector<double> c0 = s.geometry().centroid;
  for (int k = 0; k < 15; ++k) ASSERT_EQ(s.advance().stop, StopReason::None);
  const std::vector<double> c1 = s.geometry().centroid;
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(c1[d], c0[d], 1e-12);
  s.evaluate();
  // Below the centreline the deformed capsule drifts toward it: U_y > 0 before the pinning removes it.
  EXPECT_GT(s.capsule_velocity()[1], 1e-4);
}

TEST(RunStops, DtBelowFloorStopsWithExitThreeAndACheckpointOfTheLastGoodState) {
  test::TempDir dir;
  Config c = config_from(small_config());
  // Just below the first step (0.0546533 = cfl Ca h of the undeformed mesh): the first step is taken (a floor above
  // it is refused before any file, issue 24), the next ones shrink with h as the capsules deform and fall below it.
  c.time.dt_floor = 0.0546;
  c.output.every = 0.01;
  const RunResult r = run_simulation(c, quiet_settings(dir.path / "run.h5"), sink);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.stop_message.find("dt_floor"), std::string::npos) << r.stop_message;
  // The checkpoint holds the last good state: the strain reached, with every record up to it in the output.
  const H5File ck = H5File::open(r.checkpoint);
  EXPECT_GT(ck.attribute<double>("/state", "time"), 0.0);
  EXPECT_EQ(ck.attribute<double>("/state", "time"), r.time);
  const H5File out = H5File::open(dir.path / "run.h5");
  EXPECT_GE(out.extent("/series/time"), 2u);
  EXPECT_LE(out.read<double>("/series/time").data.back(), r.time);
}

TEST(RunStops, AnUnstableStepStopsBeforeGarbageIsKept) {
  // cfl 30 is far beyond the explicit membrane limit (its first step still moves nodes less than H, so it is taken;
  // cfl 60 is refused before any file): node oscillations grow until a capsule leaves the slit or a value
  // overflows. The run must stop with exit 3 and a checkpoint of finite positions inside the slit.
  test::TempDir dir;
  Config c = config_from(small_config());
  c.time.cfl = 30.0;
  c.time.end = 200.0;
  const RunResult r = run_simulation(c, quiet_settings(dir.path / "run.h5"), sink);
  ASSERT_EQ(r.exit_code, 3) << "ran to strain " << r.time;
  const H5File ck = H5File::open(r.checkpoint);
  const auto p = ck.read<double>("/state/positions");
  for (std::size_t i = 0; i < p.data.size(); ++i) {
    ASSERT_TRUE(std::isfinite(p.data[i]));
    if (i % 3 == 1) {
      ASSERT_TRUE(p.data[i] >= 0.0 && p.data[i] <= 6.0);
    }
  }
}

TEST(RunOutput, ExistingOutputIsRefusedAndLeftUntouched) {
  test::TempDir dir;
  const fs::path out = dir.path / "run.h5";
  { std::ofstream(out) << "precious"; }
  Config c = config_from(small_config());
  EXPECT_THROW(run_simulation(c, quiet_settings(out), sink), InputError);
  EXPECT_EQ(test::slurp(out), "precious");
  EXPECT_FALSE(fs::exists(dir.path / "run.checkpoint.h5"));
}

TEST(RunOutput, SignalWritesACheckpointAndStops) {
  test::TempDir dir;
  Config c = config_from(small_config());
  request_stop(SIGTERM);
  const RunResult r = run_simulation(c, quiet_settings(dir.path / "run.h5"), sink);
  clear_stop_request();
  EXPECT_EQ(r.exit_code, 128 + SIGTERM);
  EXPECT_TRUE(fs::exists(r.checkpoint));
  EXPECT_NE(r.stop_message.find("--restart"), std::string::npos);
}

TEST(RunOutput, LayoutHasTheDocumentedDatasets) {
  test::TempDir dir;
  Config c = config_from(small_config());
  c.time.end = 0.2;
  const RunResult r = run_simulation(c, quiet_settings(dir.path / "run.h5"), sink);
  ASSERT_EQ(r.exit_code, 0);
  const H5File f = H5File::open(dir.path / "run.h5");
  const std::size_t T = f.extent("/series/time");
  EXPECT_EQ(T, 5u);  // strain 0, 0.05, ..., 0.2
  EXPECT_EQ(f.dims("/series/centroid"), (std::vector<std::size_t>{T, 2, 3}));
  EXPECT_EQ(f.dims("/series/velocity"), (std::vector<std::size_t>{T, 2, 3}));
  for (const char* p : {"/series/taylor_D", "/series/inclination", "/series/volume", "/series/area"})
    EXPECT_EQ(f.dims(p), (std::vector<std::size_t>{T, 2})) << p;
  EXPECT_EQ(f.dims("/mesh/triangles"), (std::vector<std::size_t>{80, 3}));
  EXPECT_EQ(f.read<double>("/capsules/ca").data, (std::vector<double>{0.2, 0.6}));
  EXPECT_EQ(f.dims("/frames/positions"), (std::vector<std::size_t>{2, 84, 3}));
  // The stored configuration parses back to the one that ran.
  const Config back = parse_config(f.read_string("/parameters/config"), "stored");
  c.output.file = (dir.path / "run.h5").string();
  EXPECT_EQ(to_toml(back).substr(to_toml(back).find('\n')), to_toml(c).substr(to_toml(c).find('\n')));
  EXPECT_TRUE(fs::exists(dir.path / "run.xdmf"));
  // One plotting stack (issue 25): the run draws nothing itself; `capsflow figures run.h5` draws its diagnostics.
  EXPECT_FALSE(fs::exists(dir.path / "run.trajectories.svg"));
}

}  // namespace

namespace {

TEST(Simulation, VolumeCorrectionHoldsTheVolumeThatOtherwiseDrifts) {
  // A stiff pre-inflated level-1 capsule in shear loses volume quickly (discretisation error of the rest state,
  // docs/method.md 3); with [capsules] volume_correction the volume stays at its initial value.
  Config c = config_from(small_config());
  c.capsule_list.resize(1);
  c.capsule_list[0].center = {3.1, 3.0, 3.1};
  double drift[2] = {0.0, 0.0};
  c.capsules.velocity_projection = false;  // the position projection on its own
  for (int on = 0; on < 2; ++on) {
    c.capsules.volume_correction = on == 1;
    Simulation s(c);
    const double v0 = s.geometry().volume[0];
    for (int k = 0; k < 10; ++k) ASSERT_EQ(s.advance().stop, StopReason::None);
    drift[on] = std::abs(s.geometry().volume[0] / v0 - 1.0);
  }
  EXPECT_GT(drift[0], 1e-2);   // measured 3-4 %: the effect is real without the correction
  EXPECT_LT(drift[1], 1e-7);   // Newton with the exact derivative, twice per step
}

}  // namespace

namespace {

TEST(EmbeddedDemo, ConfigurationIsAValidRunOfTwoSpeciesInPoiseuilleFlow) {
  const Config c = parse_config(embedded_demo_config(), "<embedded demo>");
  validate_run_config(c);
  EXPECT_EQ(c.flow.type, FlowType::Poiseuille);
  ASSERT_EQ(c.species.size(), 2u);
  EXPECT_LT(c.species[0].ca, c.species[1].ca);
  const std::vector<CapsulePlacement> p = place_capsules(c);
  EXPECT_EQ(p.size(), 8u);
}

}  // namespace

namespace {

// Issue 8: step control, reference Ca, flow diagnostics, steady-state stop.

std::string separating_pair(double max_ratio) {
  // Two level-1 capsules 0.023 apart, the upper one ahead in shear: they separate and h grows from the gap to the
  // edge length, so an uncapped dt would jump.
  std::string t = small_config();
  t.replace(t.find("center = [2.0, 2.6, 3.1]"), 24, "center = [2.0, 2.75, 3.1]");
  t.replace(t.find("center = [4.3, 3.5, 3.1]"), 24, "center = [3.96, 3.25, 3.1]");
  char buf[96];
  std::snprintf(buf, sizeof buf, "max_step_ratio = %.17g\n", max_ratio);
  t.replace(t.find("end = 1.0"), 9, std::string("end = 0.4\n") + buf);
  return t;
}

TEST(StepControl, StepRatioNeverExceedsTheCapAndTheCapBinds) {
  // A history step far below the rule's dt (as after a close pair separates): the uncapped AB2 step would be
  // thousands of times longer; the cap lets dt grow by at most max_step_ratio per step until it meets the rule.
  Config c = config_from(small_config());
  c.time.max_step_ratio = 1.5;
  SimulationSnapshot snap = Simulation(c).snapshot();
  snap.dt_previous = 1e-5;
  snap.have_history = true;
  Simulation s(c, snap, "<test>: ");
  double dt = 1e-5;
  int capped = 0;
  StepInfo last;
  for (int k = 0; k < 30; ++k) {
    const StepInfo st = s.advance();
    ASSERT_EQ(st.stop, StopReason::None) << st.message;
    ASSERT_LE(st.ratio, 1.5 * (1 + 1e-15));
    ASSERT_LE(st.dt, 1.5 * dt * (1 + 1e-15));
    capped += st.capped;
    dt = st.dt;
    last = st;
  }
  EXPECT_GE(capped, 20);  // 1e-5 * 1.5^20 = 0.033: the ramp to the rule's ~0.05
  EXPECT_FALSE(last.capped);
  EXPECT_DOUBLE_EQ(last.dt, 0.5 * 0.2 * last.h) << "after the ramp the step is the rule's again";
  EXPECT_LE(s.max_step_ratio_since_record(), 1.5 * (1 + 1e-15));
  // Uncapped (the behaviour before the cap), the same history gives one enormous ratio.
  c.time.max_step_ratio = kUncappedStepRatio;
  Simulation u(c, snap, "<test>: ");
  const StepInfo st = u.advance();
  EXPECT_FALSE(st.capped);
  EXPECT_GT(st.ratio, 1000.0);
}

TEST(StepControl, RecordedStepRatioIsTheLargestSinceThePreviousRecord) {
  test::TempDir dir;
  Config c = config_from(separating_pair(1.3));
  c.time.step_rule = StepRule::Paper;  // the gap in h makes the step grow as the pair separates
  const RunResult r = run_simulation(c, quiet_settings(dir.path / "run.h5"), sink);
  ASSERT_EQ(r.exit_code, 0) << r.stop_message;
  const H5File f = H5File::open(dir.path / "run.h5");
  const auto ratio = f.read<double>("/series/max_step_ratio").data;
  ASSERT_GT(ratio.size(), 3u);
  EXPECT_EQ(ratio[0], 0.0);
  double seen = 0.0;
  for (double q : ratio) {
    EXPECT_LE(q, 1.3 * (1 + 1e-15));
    seen = std::max(seen, q);
  }
  EXPECT_GT(seen, 1.0);
}

TEST(StepControl, ReferenceCaSetsTheStepAndALargerOneIsRefused) {
  Config c = config_from(small_config("")), r = c;
  r.time.reference_ca = 0.1;
  Simulation a(c), b(r);
  const double h = a.min_node_distance();
  EXPECT_DOUBLE_EQ(a.advance().dt, 0.5 * 0.2 * h);
  EXPECT_DOUBLE_EQ(b.advance().dt, 0.5 * 0.1 * h);
  EXPECT_EQ(b.ca_step(), 0.1);
  std::string text = small_config();
  text.replace(text.find("end = 1.0"), 9, "end = 1.0\nreference_ca = 0.3");
  try {
    parse_config(text, "<test>");
    FAIL() << "reference_ca above the smallest Ca was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("[time] reference_ca"), std::string::npos) << e.what();
  }
}

// A degree-5 rule on a triangle (Radon's 7 points): exact for the cubic integrands below, independent of the
// closed-form moments flow_diagnostics uses.
double radon7(const double* a, const double* b, const double* c, double area, double (*g)(const double*)) {
  const double w[3] = {0.225, 0.13239415278850619, 0.12593918054482716};
  const double p1 = 0.47014206410511505, p2 = 0.10128650732345634;
  const double bary[7][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3},       {p1, p1, 1 - 2 * p1}, {p1, 1 - 2 * p1, p1},
                             {1 - 2 * p1, p1, p1},                {p2, p2, 1 - 2 * p2}, {p2, 1 - 2 * p2, p2},
                             {1 - 2 * p2, p2, p2}};
  double sum = 0.0;
  for (int q = 0; q < 7; ++q) {
    double x[3];
    for (int d = 0; d < 3; ++d) x[d] = bary[q][0] * a[d] + bary[q][1] * b[d] + bary[q][2] * c[d];
    sum += (q == 0 ? w[0] : q < 4 ? w[1] : w[2]) * g(x);
  }
  return sum * area;
}

constexpr double kYc = 2.3, kH = 6.0;
double g_shear(const double* x) { return (x[1] - kYc) * x[1]; }
double g_pois(const double* x) { return (x[1] - kYc) * x[1] * (kH - x[1]); }

TEST(FlowDiagnostics, MomentsOfALinearDensityAreExact) {
  // f_x = y - y_c is linear in position, so its linear interpolant on every flat element is exact and the
  // diagnostics must equal the integrals over the polyhedron computed here with an independent rule.
  Config c = config_from(small_config());
  CapsuleState s(3);
  s.add_species(0.2);
  s.add_capsule({3.0, kYc, 3.0}, 1.0, 0);
  const std::size_t n = s.x.size();
  s.fx.assign(n, 0.0);
  s.fy.assign(n, 0.0);
  s.fz.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) s.fx[i] = s.y[i] - kYc;
  double m1 = 0.0, m3 = 0.0;
  const auto& tri = s.mesh().tri;
  for (std::size_t e = 0; e < tri.size() / 3; ++e) {
    double p[3][3];
    for (int v = 0; v < 3; ++v) {
      const auto i = static_cast<std::size_t>(tri[3 * e + v]);
      p[v][0] = s.x[i];
      p[v][1] = s.y[i];
      p[v][2] = s.z[i];
    }
    const double ax = p[1][0] - p[0][0], ay = p[1][1] - p[0][1], az = p[1][2] - p[0][2];
    const double bx = p[2][0] - p[0][0], by = p[2][1] - p[0][1], bz = p[2][2] - p[0][2];
    const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
    m1 += radon7(p[0], p[1], p[2], area, g_shear);
    m3 += radon7(p[0], p[1], p[2], area, g_pois);
  }
  const double A = c.domain.Lx * c.domain.Lz;
  c.flow.type = FlowType::Shear;
  EXPECT_NEAR(flow_diagnostics(s, c).relative_viscosity, 1.0 - m1 / (A * kH), 1e-14);
  EXPECT_TRUE(std::isnan(flow_diagnostics(s, c).flow_rate_ratio));
  c.flow.type = FlowType::Poiseuille;
  EXPECT_NEAR(flow_diagnostics(s, c).flow_rate_ratio, 1.0 + 3.0 * m3 / (A * kH * kH), 1e-14);
  // The sphere value: int (y - y_c) y dS = 4 pi a^4 / 3 on the continuous sphere; level 3 is within 1 %.
  EXPECT_NEAR(m1, 4.0 * 3.14159265358979 / 3.0, 0.02 * m1);
}

TEST(FlowDiagnostics, DeformedCapsulesThickenShearAndSlowPoiseuille) {
  for (FlowType ft : {FlowType::Shear, FlowType::Poiseuille}) {
    Config c = config_from(small_config());
    c.flow.type = ft;
    Simulation s(c);
    for (int k = 0; k < 40; ++k) ASSERT_EQ(s.advance().stop, StopReason::None);
    s.evaluate();
    const FlowDiagnostics d = s.flow_diagnostics();
    if (ft == FlowType::Shear) {
      EXPECT_GT(d.relative_viscosity, 1.0);
    } else {
      EXPECT_LT(d.flow_rate_ratio, 1.0);
    }
  }
}

TEST(SteadyStop, PinnedCapsuleStopsOnceSteadyAndTheMonitorMeasuresSlopes) {
  SteadyStateMonitor m(1.0, 1e-3, {1e-9});
  for (int i = 0; i <= 20; ++i) m.add(0.1 * i, {1.0 + 5e-4 * 0.1 * i});  // slope 5e-4 < 1e-3 |1|
  EXPECT_TRUE(m.steady());
  SteadyStateMonitor m2(1.0, 1e-3, {1e-9});
  std::string why;
  for (int i = 0; i <= 20; ++i) m2.add(0.1 * i, {1.0 + 2e-3 * 0.1 * i});
  EXPECT_FALSE(m2.steady(&why));
  EXPECT_NE(why.find("slope"), std::string::npos) << why;
  // The floor is per value: a value near zero creeping at 5e-8 per strain is steady under a floor of 1e-7, not 1e-8.
  SteadyStateMonitor m3(1.0, 1e-4, {1e-7, 1e-8});
  for (int i = 0; i <= 20; ++i) m3.add(0.1 * i, {1e-9 + 5e-8 * 0.1 * i, 1e-9});
  EXPECT_TRUE(m3.steady());
  SteadyStateMonitor m4(1.0, 1e-4, {1e-8, 1e-7});
  for (int i = 0; i <= 20; ++i) m4.add(0.1 * i, {1e-9 + 5e-8 * 0.1 * i, 1e-9});
  EXPECT_FALSE(m4.steady());

  test::TempDir dir;
  std::string text = small_config();
  text.replace(text.find("end = 1.0"), 9, "end = 30.0\nsteady_rtol = 1e-2\nsteady_atol = 1e-6");
  Config c = config_from(text);
  c.time.steady_stop = true;
  c.flow.type = FlowType::Poiseuille;
  c.capsule_list.resize(1);
  c.capsule_list[0].center = {3.1, 2.0, 3.1};
  c.capsule_list[0].pinned = true;
  const RunResult r = run_simulation(c, quiet_settings(dir.path / "run.h5"), sink);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_LT(r.time, 30.0);
  EXPECT_NE(r.stop_message.find("steady state"), std::string::npos) << r.stop_message;
  // A free capsule cannot ask for it.
  c.capsule_list[0].pinned = false;
  EXPECT_THROW(validate_run_config(c), InputError);
}

}  // namespace
