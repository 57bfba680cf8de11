// Hardening, fourth round (issue 37, finding 7): a refusal names the key whose value made the problem, where that
// value came from. Non-finite forces from a [[species]] inflation or radius, a step made tiny by a [[species]]
// skalak_c, and an interface-velocity solve whose residual is not finite (a huge viscosity ratio overflows the
// operator: no [gmres] max_iterations mends it) each name the [[species]] key, not the [capsules] default or the cap.
// Fifth round (issue 52, item 9): a shear rate or viscosity far from 1 names itself, not the step's keys; a cutoff
// that [ggem] tolerance chose names the tolerance.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/cli_runner.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using capsflow::test::expect_input_error;
using capsflow::test::run_capsflow;
using capsflow::test::snapshot_files;

// One capsule at viscosity ratio 1 (the cases set what they need), serial, a small box.
const char* kConfig =
    "[domain]\nH = 5.0\nLx = 6.0\nLz = 6.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"serial\"\n[flow]\n"
    "type = \"poiseuille\"\n[capsules]\nmesh_level = 1\n[[species]]\nname = \"a\"\nca = 0.1\n[[capsule]]\n"
    "species = \"a\"\ncenter = [3.0, 2.0, 3.0]\n[time]\nend = 0.1\n[output]\nfile = \"out/run.h5\"\n";

TEST(KeyBlame, TheKeyThatMadeTheValueIsNamed) {
  if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  capsflow::test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work / "out");
  std::ofstream(work / "c.toml") << kConfig;
  const auto before = snapshot_files(work);
  struct Case {
    const char* sets;
    const char* key;      // must be named
    const char* not_key;  // must not be blamed
  };
  const Case cases[] = {
      {"--set species.1.inflation=1e300", "[[species]] 1 inflation = 1e+300", "[capsules] inflation = 1e+300"},
      {"--set capsules.inflation=1e300", "[capsules] inflation = 1e+300", "[[species]] 1 inflation"},
      {"--set species.1.radius=1e-300", "[[species]] 1 radius", "[capsules] radius = 1e-300"},
      {"--set species.1.law='\"skalak\"' --set species.1.skalak_c=1e300", "[[species]] 1 skalak_c = 1e+300",
       "the smallest [[species]] ca"},
      {"--set species.1.viscosity_ratio=1e300", "[[species]] 1 viscosity_ratio = 1e+300", "[gmres] max_iterations"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.sets);
    const capsflow::test::CliResult r = run_capsflow(work, std::string("run c.toml ") + c.sets, 60);
    expect_input_error(r, {"c.toml", c.key, "expected"});
    EXPECT_EQ(r.err.find(c.not_key), std::string::npos) << r.err;
  }
  EXPECT_EQ(snapshot_files(work), before);
}

// Fifth round (issue 52, item 9), keys in the file: the scale of the units overflowed the solve and was blamed on
// [time] cfl, Ca and inflation; a cutoff that [ggem] tolerance chose was blamed on Lx and the cutoff.
TEST(KeyBlame, TheUnitsAndTheToleranceNameThemselves) {
  if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  capsflow::test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work / "out");
  struct Case {
    const char* from;
    const char* to;       // the edit of kConfig
    const char* key;      // must be named, with the file
    const char* not_key;  // must not be blamed
  };
  const Case cases[] = {
      {"type = \"poiseuille\"\n", "type = \"poiseuille\"\nshear_rate = 1e300\n", "[flow] shear_rate", "[time] cfl"},
      {"type = \"poiseuille\"\n", "type = \"poiseuille\"\nshear_rate = 1e-300\n", "[flow] shear_rate", "[time] cfl"},
      {"Lz = 6.0\n", "Lz = 6.0\nviscosity = 1e300\n", "[domain] viscosity", "[time] cfl"},
      // alpha 1: the tolerance's cutoff 4.3 needs Lx >= 8.6 (alpha's own default, 3.5, would be blamed on alpha).
      {"alpha = 4.0\n", "alpha = 1.0\ntolerance = 1e-4\n", "[ggem] tolerance", "is too small for the cutoff"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.to);
    std::string text = kConfig;
    text.replace(text.find(c.from), std::string(c.from).size(), c.to);
    std::ofstream(work / "c.toml") << text;
    const auto before = snapshot_files(work);
    const capsflow::test::CliResult r = run_capsflow(work, "run c.toml", 60);
    expect_input_error(r, {"c.toml", c.key, "expected"});
    EXPECT_EQ(r.err.find(c.not_key), std::string::npos) << r.err;
    EXPECT_EQ(snapshot_files(work), before);
  }
}

}  // namespace
