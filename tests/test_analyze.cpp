// `capsflow analyze` end to end (src/host/cli/analyze_command.*): a run of pinned capsules at known heights gives the
// d-bar computed here by hand from those heights; outputs are refused or kept as documented; directories are
// searched for run outputs and checkpoints are skipped; the files of a run store are refused as runs.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "host/cli/analyze_command.hpp"
#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/run/run_driver.hpp"
#include "support/cli_runner.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

// Four pinned level-1 capsules, two per species, at known heights in a slit of H = 8 (Poiseuille).
constexpr double kH = 8.0;
const double kStiffY[2] = {2.0, 5.0}, kFloppyY[2] = {3.1, 4.4};

std::string pinned_run(double end) {
  std::ostringstream o;
  o << "[domain]\nH = 8.0\nLx = 6.2\nLz = 6.2\n[run]\nbackend = \"serial\"\n[flow]\ntype = \"poiseuille\"\n"
    << "[capsules]\nmesh_level = 1\ninflation = 0.05\n[[species]]\nname = \"stiff\"\nca = 0.2\n"
    << "[[species]]\nname = \"floppy\"\nca = 0.6\n";
  const double x[4] = {1.0, 4.1, 1.0, 4.1}, z[4] = {1.5, 1.5, 4.6, 4.6};
  for (int i = 0; i < 2; ++i)
    o << "[[capsule]]\nspecies = \"stiff\"\ncenter = [" << x[i] << ", " << kStiffY[i] << ", " << z[i]
      << "]\npinned = true\n";
  for (int i = 0; i < 2; ++i)
    o << "[[capsule]]\nspecies = \"floppy\"\ncenter = [" << x[2 + i] << ", " << kFloppyY[i] << ", " << z[2 + i]
      << "]\npinned = true\n";
  o << "[time]\nend = " << end << "\n[output]\nevery = 0.02\nframes_every = 0.1\nprofile_bins = 50\n";
  return o.str();
}

// groups[0].species[sp][key].value of summary.json, read with a JSON parser; NaN where it is null.
double summary_value(const std::string& json, const std::string& sp, const std::string& key) {
  const nlohmann::json v = nlohmann::json::parse(json).at("groups").at(0).at("species").at(sp).at(key).at("value");
  return v.is_null() ? NAN : v.get<double>();
}

struct Fixture {
  test::TempDir dir;
  fs::path run;
  Fixture() {
    run = dir.path / "runs" / "pinned.h5";
    fs::create_directories(run.parent_path());
    Config c = parse_config(pinned_run(0.2), "<test>");
    RunSettings s;
    s.output = run.string();
    s.quiet = true;
    EXPECT_EQ(run_simulation(c, s, std::cerr).exit_code, 0);
  }
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Analyze, PinnedRunGivesTheDBarOfItsHeights) {
  Fixture fx;
  AnalyzeOptions o;
  o.inputs = {(fx.dir.path / "runs").string()};  // a directory: the checkpoint beside the run is skipped
  o.out = (fx.dir.path / "an").string();
  o.quiet = true;
  ASSERT_EQ(run_analyze(o, std::cerr), 0);
  const std::string json = slurp(fx.dir.path / "an" / "summary.json");
  ASSERT_EQ(nlohmann::json::parse(json).at("groups").at(0).at("kind"), "pinned") << json;
  EXPECT_EQ(json.find("checkpoint"), std::string::npos) << "the checkpoint is not a run";
  auto dbar = [](const double* y, int n) {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += std::abs(y[i] - kH / 2);
    return s / n / (kH / 2);
  };
  const double all[4] = {kStiffY[0], kStiffY[1], kFloppyY[0], kFloppyY[1]};
  EXPECT_NEAR(summary_value(json, "stiff", "dbar"), dbar(kStiffY, 2), 1e-9);
  EXPECT_NEAR(summary_value(json, "floppy", "dbar"), dbar(kFloppyY, 2), 1e-9);
  EXPECT_NEAR(summary_value(json, "all", "dbar"), dbar(all, 4), 1e-9);
  // f_AB needs a window of 100 strain: null, with the reason.
  EXPECT_TRUE(std::isnan(summary_value(json, "stiff", "f_AB")));
  EXPECT_NE(json.find("shorter than the horizon"), std::string::npos);
  // The HDF5 result holds the profiles; n-hat of the stiff capsules integrates to 1 ((2/H) sum n dy = 1).
  const H5File f = H5File::open(fx.dir.path / "an" / "analysis.h5");
  EXPECT_EQ(f.attribute<std::string>("/", "format"), "capsflow-analysis");
  const auto n = f.read<double>("/groups/g000/profiles/n_hat_stiff").data;
  double integral = 0.0;
  for (double v : n) integral += (std::isfinite(v) ? v : 0.0) * (0.5 / static_cast<double>(n.size())) * 2.0;
  EXPECT_NEAR(integral, 1.0, 1e-12);
  // summary.json carries the exact doubles (issue 25: it had 10 digits): its window is analysis.h5's, bit for bit.
  const nlohmann::json g0 = nlohmann::json::parse(json).at("groups").at(0);
  EXPECT_EQ(g0.at("window").at(0).get<double>(), f.attribute<double>("/groups/g000", "t0"));
  EXPECT_EQ(g0.at("window").at(1).get<double>(), f.attribute<double>("/groups/g000", "t1"));
  // Every dataset names its units (docs/analysis.md): d-bar and the profiles are normalised, times in strain.
  for (const std::string& d : f.datasets()) {
    SCOPED_TRACE(d);
    ASSERT_TRUE(f.has_attribute(d, "units"));
    EXPECT_FALSE(f.attribute<std::string>(d, "units").empty());
  }
  EXPECT_EQ(f.attribute<std::string>("/groups/g000/dbar_t/time", "units"), "1/gammadot");
  EXPECT_EQ(f.attribute<std::string>("/groups/g000/dbar_t/stiff", "units"), "1");
  EXPECT_EQ(f.attribute<std::string>("/groups/g000/profiles/n_hat_stiff", "units"), "1");
  if (f.exists("/groups/g000/profiles/v_bar_stiff")) {  // written where a bin has enough samples
    EXPECT_EQ(f.attribute<std::string>("/groups/g000/profiles/v_bar_stiff", "units"), "gammadot a");
  }
  EXPECT_EQ(f.attribute<std::string>("/groups/g000/snapshot/positions", "units"), "a");
}

TEST(Analyze, ExistingOutputIsRefusedUnlessForcedAndABadWindowWritesNothing) {
  Fixture fx;
  AnalyzeOptions o;
  o.inputs = {fx.run.string()};
  o.out = (fx.dir.path / "an").string();
  o.quiet = true;
  ASSERT_EQ(run_analyze(o, std::cerr), 0);
  const std::string before = slurp(fx.dir.path / "an" / "summary.json");
  EXPECT_THROW(run_analyze(o, std::cerr), InputError);
  EXPECT_EQ(slurp(fx.dir.path / "an" / "summary.json"), before);
  o.force = true;
  EXPECT_EQ(run_analyze(o, std::cerr), 0);

  AnalyzeOptions w = o;
  w.out = (fx.dir.path / "an2").string();
  parse_window("0.1:5", w);  // the run ends at 0.2
  EXPECT_THROW(run_analyze(w, std::cerr), InputError);
  EXPECT_FALSE(fs::exists(fx.dir.path / "an2"));
  EXPECT_THROW(parse_window("5:1", w), InputError);
  EXPECT_THROW(parse_window("abc", w), InputError);
  AnalyzeOptions none = o;
  none.inputs = {(fx.dir.path / "nothing-here").string()};
  EXPECT_THROW(run_analyze(none, std::cerr), InputError);
}

// A file of a run store (tools/run_store.py: a base and append-only parts) is not a run (issue 52, item 10): a part
// read as one was a short run starting mid-way, the base with parts beside it one that ends at the first save. Each
// is refused, named as such with the restore that makes the run, given alone or found in a directory, and nothing is
// written. The parts here are the fixture's run with the /_store group a save writes (the second without the `part`
// attribute, as saved before it: known by its group and its name).
TEST(Analyze, FilesOfARunStoreAreRefusedNamingTheRestore) {
  Fixture fx;
  const fs::path store = fx.dir.path / "store";
  fs::create_directories(store);
  fs::copy_file(fx.run, store / "output.h5");
  for (int k : {1, 2}) {
    const fs::path part = store / ("output.part-00" + std::to_string(k) + ".h5");
    fs::copy_file(fx.run, part);
    H5File f = H5File::open(part, H5Access::ReadWrite);
    f.create_group("/_store");
    f.set_attribute("/_store", "series/time", std::int64_t{5 * k});
    if (k == 1) f.set_attribute("/_store", "part", std::int64_t{1});
    f.close();
  }
  const std::string restore = "tools/run_store.py restore " + store.string() + " RUN_DIR";
  struct Case {
    fs::path input;
    std::vector<std::string> named;
  };
  const Case cases[] = {
      {store / "output.part-001.h5", {"part 1 of 2", "from record 5 on", "not a run output", restore}},
      {store / "output.part-002.h5", {"part 2 of 2", "from record 10 on", restore}},
      {store / "output.h5", {"the base of a run store with 2 part(s)", "first save only", restore}},
      {store, {"the base of a run store", restore}},           // found in a directory: refused, not skipped
      {fx.dir.path, {"run store", restore}},                    // beside a run: the pool would lack it
  };
  int i = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.input.string());
    AnalyzeOptions o;
    o.inputs = {c.input.string()};
    o.out = (fx.dir.path / ("an" + std::to_string(i++))).string();
    o.quiet = true;
    try {
      run_analyze(o, std::cerr);
      ADD_FAILURE() << "analyzed as a run";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      for (const std::string& w : c.named) EXPECT_NE(msg.find(w), std::string::npos) << "'" << w << "' not in: " << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
    EXPECT_FALSE(fs::exists(o.out)) << "nothing written";
  }
  // The command line: exit 2, one line.
  if (!test::capsflow_binary_path().empty()) {
    const test::CliResult r = test::run_capsflow(
        fx.dir.path, "analyze " + test::shell_quote((store / "output.part-001.h5").string()) + " --out an-cli -q");
    test::expect_input_error(r, {(store / "output.part-001.h5").string(), "part 1 of 2", restore});
    EXPECT_FALSE(fs::exists(fx.dir.path / "an-cli"));
  }
}

}  // namespace
