// `capsflow probe CONFIG [--out FILE]` (issue 37, finding 7: the stability probe had no command a user can run): the
// measured limit of the explicit membrane step at the configuration's initial state against the step its [time] cfl
// chooses. The capsule of docs/figures/stability_probe.md's first row (level 2, inflation 0.1, Ca 0.2, at rest in the
// box 6a, alpha 4): lambda -17.69 per strain unit, cfl_crit 1.024 (tests/validation_stability.cpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/cli_runner.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using capsflow::test::expect_input_error;
using capsflow::test::run_capsflow;
using capsflow::test::slurp_file;
using capsflow::test::snapshot_files;

const char* kAtRest =
    "[domain]\nH = 6.0\nLx = 6.0\nLz = 6.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"serial\"\n[flow]\n"
    "type = \"none\"\n[capsules]\nmesh_level = 2\ninflation = 0.1\n[[species]]\nname = \"a\"\nca = 0.2\n"
    "[[capsule]]\nspecies = \"a\"\ncenter = [3.0, 3.0, 3.0]\n";

TEST(ProbeCommand, MeasuresTheLimitAndComparesTheChosenStep) {
  if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  capsflow::test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work);
  std::ofstream(work / "c.toml") << kAtRest;  // no [time] end: the probe takes no step of a run

  const capsflow::test::CliResult r = run_capsflow(work, "probe c.toml --out p.json", 120);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("measured limit"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(slurp_file(work / "p.json"));
  // The validation's measurement, the same state and probe.
  EXPECT_NEAR(j["lambda_re"].get<double>(), -17.69, 0.01);
  EXPECT_NEAR(j["cfl_limit"].get<double>(), 1.024, 0.001);
  // The chosen step is the rule's (one capsule, no contact, no bending): cfl 0.5 over the limit.
  EXPECT_NEAR(j["chosen_over_limit"].get<double>(), 0.5 / j["cfl_limit"].get<double>(), 1e-9);
  EXPECT_NEAR(j["dt_chosen"].get<double>() / j["dt_limit"].get<double>(), j["chosen_over_limit"].get<double>(),
              1e-12);

  // A cfl above the limit is said, with the cfl to use.
  const capsflow::test::CliResult over = run_capsflow(work, "probe c.toml --set time.cfl=2", 120);
  ASSERT_EQ(over.status, 0) << over.err;
  EXPECT_NE(over.out.find("warning: the chosen step is above the measured limit"), std::string::npos) << over.out;
  EXPECT_NE(over.out.find("lower [time] cfl to at most 1.02"), std::string::npos) << over.out;

  // Refusals: one line naming what is wrong, exit 2, nothing written.
  const auto before = snapshot_files(work);
  expect_input_error(run_capsflow(work, "probe c.toml --out p.json", 60), {"p.json", "already exists"});
  expect_input_error(run_capsflow(work, "probe c.toml --set time.cfl=-1 --out q.json", 60), {"--set time.cfl"});
  expect_input_error(run_capsflow(work, "probe missing.toml", 60), {"missing.toml"});
  expect_input_error(run_capsflow(work, "probe c.toml --out c.toml --force", 60), {"c.toml", "configuration"});
  // What `capsflow run` refuses at its first step (tests/test_hardening_runs.cpp, 9), the probe refuses alike.
  for (const char* set : {"capsules.inflation=1e300", "time.cfl=1e300"}) {
    SCOPED_TRACE(set);
    expect_input_error(run_capsflow(work, std::string("probe c.toml --out r.json --set ") + set, 60),
                       {"c.toml", "expected"});
  }
  EXPECT_EQ(snapshot_files(work), before);
}

// Issue 52, item 11: at H = 5 with alpha 4 (Chebyshev degree 63: odd, so y = H/2 is half-way between two planes,
// where the interpolation's nearest plane switches) a mid-channel capsule has nodes exactly on the switch, and the
// default finite-difference step (1e-7) read the jump of the velocity there as a growing mode (+29.46 per strain
// unit, limit cfl 6e-13). The probe measures again with a 100 times larger step and finds the membrane's own mode:
// the capsule's fastest relaxation, the same in the other boxes (-17.69 at H = 6 above; -17.69 at H = 4.6, 5.4, 6.2).
TEST(ProbeCommand, AJumpOfTheInterpolationIsNotAGrowingMode) {
  if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  capsflow::test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work);
  std::string text = kAtRest;
  text.replace(text.find("H = 6.0"), 7, "H = 5.0");
  text.replace(text.find("[3.0, 3.0, 3.0]"), 15, "[3.0, 2.5, 3.0]");
  std::ofstream(work / "c.toml") << text;
  const capsflow::test::CliResult r = run_capsflow(work, "probe c.toml --out p.json", 120);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(slurp_file(work / "p.json"));
  EXPECT_FALSE(j["growing_mode"].get<bool>()) << r.out;
  EXPECT_GT(j["discarded_growth"].get<double>(), 1.0) << r.out;  // the default step's artefact, set aside
  EXPECT_DOUBLE_EQ(j["rms_displacement"].get<double>(), 1e-5);
  EXPECT_NEAR(j["lambda_re"].get<double>(), -17.69, 0.05);
  EXPECT_NEAR(j["cfl_limit"].get<double>(), 1.024, 0.005);
  EXPECT_NE(r.out.find("switch of the interpolation stencil"), std::string::npos) << r.out;
}

}  // namespace
