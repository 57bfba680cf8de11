// The run file's layout has one home (src/host/run/run_layout.*): the file a run writes holds exactly its datasets with
// their shapes and types, read_run_file reads them back, docs/output_format.md lists the same table, and a
// checkpoint of the older format restarts with the older behaviour.
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>

#include "host/run/checkpoint.hpp"
#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow;
namespace fs = std::filesystem;

std::string source_dir() {
  const char* e = std::getenv("CAPSFLOW_SOURCE_DIR");
  return e ? e : CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
}

// Two level-1 capsules close enough to touch in shear (contact events), a few ms per step.
std::string two_capsules(const std::string& flow) {
  return R"(
[domain]
H = 6.0
Lx = 6.2
Lz = 6.2
[run]
backend = "serial"
[flow]
type = ")" + flow + R"("
[capsules]
mesh_level = 1
inflation = 0.05
[[species]]
name = "stiff"
ca = 0.2
[[species]]
name = "floppy"
ca = 0.6
[[capsule]]
species = "stiff"
center = [2.0, 2.4, 3.1]
[[capsule]]
species = "floppy"
center = [4.1, 3.6, 3.1]
[time]
end = 0.3
[output]
every = 0.05
frames_every = 0.1
profile_bins = 12
)";
}

std::vector<std::size_t> dims_of(std::string shape, const std::map<std::string, std::size_t>& sym) {
  std::vector<std::size_t> d;
  if (shape == "scalar") return d;
  shape = shape.substr(1, shape.size() - 2);
  std::stringstream ss(shape);
  std::string part;
  while (std::getline(ss, part, ',')) {
    std::stringstream ps(part);
    std::string tok;
    std::size_t v = 1;
    while (ps >> tok) v *= std::isdigit(static_cast<unsigned char>(tok[0])) ? std::stoul(tok) : sym.at(tok);
    d.push_back(v);
  }
  return d;
}

TEST(RunLayout, TheWrittenFileHoldsExactlyTheLayoutsDatasets) {
  test::TempDir dir;
  Config c = parse_config(two_capsules("shear"), "<test>");
  RunSettings s;
  s.output = (dir.path / "run.h5").string();
  s.quiet = true;
  const RunResult r = run_simulation(c, s, std::cerr);
  ASSERT_EQ(r.exit_code, 0) << r.stop_message;

  const RunFile run = read_run_file(dir.path / "run.h5");
  const std::map<std::string, std::size_t> sym = {
      {"T", run.records}, {"F", run.frames}, {"E", run.events}, {"Np", 2}, {"Ns", 2}, {"B", 12},
      {"Nt", 80},         {"Nn", 2 * 42}};
  EXPECT_EQ(run.format_version, layout::kFormatVersion);
  EXPECT_EQ(run.records, 7u);  // strain 0, 0.05, ..., 0.3
  EXPECT_EQ(run.frames, 4u);
  EXPECT_EQ(run.profile_bins, 12u);
  EXPECT_EQ(run.species_names, (std::vector<std::string>{"stiff", "floppy"}));
  const H5File f = H5File::open(dir.path / "run.h5");
  for (const layout::DatasetInfo& d : layout::output_datasets()) {
    SCOPED_TRACE(d.path);
    ASSERT_TRUE(f.exists(d.path));
    if (std::string(d.type) == "string") continue;
    EXPECT_EQ(f.dims(d.path), dims_of(d.shape, sym));
  }
  // Nothing outside the layout in the data groups.
  for (const std::string g : {"/series", "/frames", "/events", "/mesh", "/capsules"})
    for (const std::string& name : f.children(g)) {
      bool listed = false;
      for (const layout::DatasetInfo& d : layout::output_datasets()) listed = listed || g + "/" + name == d.path;
      EXPECT_TRUE(listed) << g + "/" + name << " is written but not in the layout";
    }

  // What read_run_file gives is what was written.
  EXPECT_EQ(run.time, f.read<double>(layout::kTime).data);
  EXPECT_EQ(run.centroid, f.read<double>(layout::kCentroid).data);
  // The profile holds the capsule volumes: per record, the sum over slabs and species equals the sum of
  // /series/volume to round-off (exact slab volumes of the polyhedra).
  for (std::size_t t = 0; t < run.records; ++t) {
    double slabs = 0.0, vol = 0.0;
    for (std::size_t i = 0; i < 2 * 12; ++i) slabs += run.profile[t * 24 + i];
    for (std::size_t k = 0; k < 2; ++k) vol += run.volume[t * 2 + k];
    EXPECT_NEAR(slabs, vol, 1e-12 * vol);
  }
  // Shear: the relative viscosity is defined (and the flow rate ratio is not).
  for (std::size_t t = 0; t < run.records; ++t) {
    EXPECT_TRUE(std::isfinite(run.relative_viscosity[t]));
    EXPECT_TRUE(std::isnan(run.flow_rate_ratio[t]));
  }
}

// Format 5: every dataset of a written run file, the frame views included, says its units; the scales are those of
// docs/usage.md (a, 1/gammadot, gammadot a, mu gammadot, ...), "1" for numbers, counts and ids.
TEST(RunLayout, EveryDatasetOfTheFileCarriesItsUnits) {
  test::TempDir dir;
  RunSettings s;
  s.output = (dir.path / "run.h5").string();
  s.quiet = true;
  ASSERT_EQ(run_simulation(parse_config(two_capsules("shear"), "<test>"), s, std::cerr).exit_code, 0);
  const H5File f = H5File::open(dir.path / "run.h5");
  const std::vector<std::string> all = f.datasets();
  ASSERT_GT(all.size(), layout::output_datasets().size());  // the layout's datasets and the frame views
  std::size_t views = 0;
  for (const std::string& path : all) {
    SCOPED_TRACE(path);
    ASSERT_TRUE(f.has_attribute(path, "units"));
    EXPECT_FALSE(f.attribute<std::string>(path, "units").empty());
    if (path.rfind("/xdmf/", 0) == 0) {  // /xdmf/<name>/<f> shows /frames/<name>: same units
      const std::string name = path.substr(6, path.rfind('/') - 6);
      EXPECT_EQ(f.attribute<std::string>(path, "units"), f.attribute<std::string>("/frames/" + name, "units"));
      ++views;
    }
  }
  EXPECT_EQ(views, 4u * layout::frame_view_sources(layout::kFormatVersion).size());  // 4 frames
  EXPECT_EQ(f.attribute<std::string>(layout::kCentroid, "units"), "a");
  EXPECT_EQ(f.attribute<std::string>(layout::kTime, "units"), "1/gammadot");
  EXPECT_EQ(f.attribute<std::string>(layout::kVelocity, "units"), "gammadot a");
  EXPECT_EQ(f.attribute<std::string>(layout::kFramePositions, "units"), "a");
  EXPECT_EQ(f.attribute<std::string>(layout::kFrameTractionJump, "units"), "mu gammadot");
  EXPECT_EQ(f.attribute<std::string>(layout::kFrameTensionMax, "units"), "mu gammadot a");
  EXPECT_EQ(f.attribute<std::string>(layout::kStep, "units"), "1");
  EXPECT_EQ(f.attribute<std::string>(layout::kInclination, "units"), "rad");
}

// [output] compression: the frames' node arrays are shuffled and deflated by default, one frame per chunk, and plain
// with 0; the series, events and frame times are plain while the run writes them (their chunks are rewritten in
// place) and compressed when it ends (tests/test_series_compression.cpp); either way every dataset holds the same
// numbers bit for bit (lossless), and the fixed ones stay contiguous.
TEST(RunLayout, FramesAreCompressedLosslesslyUnlessSwitchedOff) {
  test::TempDir dir;
  RunSettings s;
  s.quiet = true;
  s.output = (dir.path / "deflated.h5").string();
  ASSERT_EQ(run_simulation(parse_config(two_capsules("shear"), "<test>"), s, std::cerr).exit_code, 0);
  s.output = (dir.path / "plain.h5").string();
  ASSERT_EQ(run_simulation(parse_config(two_capsules("shear") + "compression = 0\n", "<test>"), s, std::cerr).exit_code,
            0);
  const H5File a = H5File::open(dir.path / "deflated.h5"), b = H5File::open(dir.path / "plain.h5");
  for (const layout::DatasetInfo& d : layout::output_datasets()) {
    SCOPED_TRACE(d.path);
    const bool growing = d.growth != layout::Growth::Fixed;
    EXPECT_EQ(a.filters(d.path),
              growing ? (std::vector<std::string>{"shuffle", "deflate"}) : std::vector<std::string>{});
    EXPECT_TRUE(b.filters(d.path).empty());
    if (std::string(d.type) == "string") continue;
    const H5Array<double> x = a.read<double>(d.path), y = b.read<double>(d.path);
    ASSERT_EQ(x.dims, y.dims);
    if (!x.data.empty()) {
      EXPECT_EQ(std::memcmp(x.data.data(), y.data.data(), 8 * x.data.size()), 0);
    }
  }
}

TEST(RunLayout, OutputFormatDocListsTheLayout) {
  std::ifstream in(source_dir() + "/docs/output_format.md");
  ASSERT_TRUE(in) << "docs/output_format.md";
  // Rows "| `/path` | shape | type | since | units | meaning |" (split by hand: std::regex trips GCC 12's
  // maybe-uninitialized warning under the sanitizers).
  std::map<std::string, std::tuple<std::string, std::string, int, std::string>> doc;
  std::string line;
  auto trim = [](std::string v) {
    while (!v.empty() && v.front() == ' ') v.erase(v.begin());
    while (!v.empty() && v.back() == ' ') v.pop_back();
    return v;
  };
  while (std::getline(in, line)) {
    if (line.rfind("| `/", 0) != 0) continue;
    std::vector<std::string> cells;
    std::size_t start = 1;
    for (std::size_t bar = line.find('|', start); bar != std::string::npos; bar = line.find('|', start)) {
      cells.push_back(trim(line.substr(start, bar - start)));
      start = bar + 1;
    }
    if (cells.size() < 6 || cells[0].size() < 3 || cells[3].empty() ||
        cells[3].find_first_not_of("0123456789") != std::string::npos)
      continue;
    std::string units = cells[4];  // written as code: `a`
    if (units.size() >= 2 && units.front() == '`' && units.back() == '`') units = units.substr(1, units.size() - 2);
    doc[cells[0].substr(1, cells[0].size() - 2)] = {cells[1], cells[2], std::stoi(cells[3]), units};
  }
  std::set<std::string> in_layout;
  for (const layout::DatasetInfo& d : layout::output_datasets()) {
    SCOPED_TRACE(d.path);
    in_layout.insert(d.path);
    const auto it = doc.find(d.path);
    ASSERT_NE(it, doc.end()) << "missing from docs/output_format.md";
    EXPECT_EQ(std::get<0>(it->second), d.shape);
    EXPECT_EQ(std::get<1>(it->second), d.type);
    EXPECT_EQ(std::get<2>(it->second), d.since);
    EXPECT_EQ(std::get<3>(it->second), d.units);
  }
  for (const auto& [path, v] : doc) EXPECT_TRUE(in_layout.count(path)) << path << " is documented but not written";
}

TEST(RunLayout, FormatOneCheckpointKeepsFormatOnesBehaviour) {
  // A checkpoint from before the velocity projection and the step-ratio cap: its configuration has neither key.
  Checkpoint ck;
  ck.format_version = 1;
  ck.config_text = two_capsules("shear");
  const Config old = checkpoint_config(ck, "old.checkpoint.h5");
  EXPECT_FALSE(old.capsules.velocity_projection);
  EXPECT_EQ(old.time.max_step_ratio, kUncappedStepRatio);
  EXPECT_TRUE(old.capsules.volume_correction == parse_config(ck.config_text, "x").capsules.volume_correction);
  // The same text in the current format takes today's defaults; explicit keys win in both.
  ck.format_version = 2;
  const Config now = checkpoint_config(ck, "new.checkpoint.h5");
  EXPECT_TRUE(now.capsules.velocity_projection);
  EXPECT_EQ(now.time.max_step_ratio, 2.0);
  ck.format_version = 1;
  ck.config_text += "";
  Config round = checkpoint_config(ck, "x");
  round.output.file = "a.h5";
  // Written back (to_toml, as the next checkpoint does) the old behaviour is explicit and survives another restart.
  ck.config_text = to_toml(round);
  const Config again = checkpoint_config(ck, "x");
  EXPECT_FALSE(again.capsules.velocity_projection);
  EXPECT_EQ(again.time.max_step_ratio, kUncappedStepRatio);
}

TEST(RunLayout, CheckpointOfAnEarlierBuildKeepsItsElementRules) {
  // Before issue 34 the default element rules were the kernels' finer ones and a stored configuration at the
  // defaults had no [quadrature] table (nor one at a tolerance, before the tolerance picked rules): such a run
  // continues with the rules it ran with, fine_quadrature(), with or without a tolerance; a table stored by this
  // build is read as written.
  for (const char* tol : {"", "[ggem]\ntolerance = 1e-2\n"}) {
    SCOPED_TRACE(*tol ? "at a tolerance" : "at the defaults");
    Checkpoint ck;
    ck.format_version = 3;
    const Config now = parse_config(two_capsules("shear") + tol, "x");
    ASSERT_TRUE(now.quadrature == QuadratureOptions{});
    ASSERT_EQ(now.ggem.tolerance, *tol ? 1e-2 : 0.0);
    std::string text = to_toml(now);
    ck.config_text = text;
    EXPECT_TRUE(checkpoint_config(ck, "new.checkpoint.h5").quadrature == QuadratureOptions{});
    const std::size_t at = text.find("[quadrature]");
    ASSERT_NE(at, std::string::npos);
    const std::size_t end = text.find("\n[", at + 1);
    text.erase(at, end == std::string::npos ? std::string::npos : end + 1 - at);
    ASSERT_EQ(text.find("[quadrature]"), std::string::npos);
    ck.config_text = text;
    Config old = checkpoint_config(ck, "old.checkpoint.h5");
    EXPECT_TRUE(old.quadrature == fine_quadrature());
    EXPECT_EQ(old.ggem.tolerance, now.ggem.tolerance);
    // Written back (the next checkpoint) the finer rules are explicit and survive another restart.
    ck.config_text = to_toml(old);
    EXPECT_TRUE(checkpoint_config(ck, "x").quadrature == fine_quadrature());
  }
}

TEST(RunLayout, ReaderRefusesANewerFormatAndNonRunFiles) {
  test::TempDir dir;
  {
    H5File f = H5File::create(dir.path / "x.h5");
    f.set_attribute("/", "format_version", std::int64_t{99});
    f.write_string(layout::kConfig, "");
    f.write(layout::kCapsuleSpecies, {1}, std::vector<std::int32_t>{0});
  }
  EXPECT_THROW(read_run_file(dir.path / "x.h5"), InputError);
  {
    H5File f = H5File::create(dir.path / "y.h5");
    f.write_string("/other", "");
  }
  EXPECT_THROW(read_run_file(dir.path / "y.h5"), InputError);
}

}  // namespace

namespace {

std::string approaching_pair() {
  // The upper capsule behind the lower one in shear: they close in and the contact control acts.
  std::string t = two_capsules("shear");
  t.replace(t.find("center = [2.0, 2.4, 3.1]"), 24, "center = [1.8, 3.3, 3.1]");
  t.replace(t.find("center = [4.1, 3.6, 3.1]"), 24, "center = [4.1, 2.7, 3.1]");
  t.replace(t.find("end = 0.3"), 9, "end = 4.0\nmin_gap = 0.15");  // a wide gap: sure to be violated
  t += "checkpoint_every = 0.5\n";
  return t;
}

TEST(RunLayout, ContactEventsAreRecordedAndSurviveARestartBitForBit) {
  test::TempDir dir;
  const Config c = parse_config(approaching_pair(), "<test>");
  RunSettings s;
  s.output = (dir.path / "full.h5").string();
  s.quiet = true;
  const RunResult full = run_simulation(c, s, std::cerr);
  ASSERT_EQ(full.exit_code, 0) << full.stop_message;
  const RunFile a = read_run_file(dir.path / "full.h5");
  ASSERT_GT(a.events, 0u) << "the pair was meant to touch";
  for (std::size_t e = 0; e < a.events; ++e) {
    EXPECT_LT(a.event_gap[e], c.time.min_gap);
    EXPECT_GT(a.event_time[e], 0.0);
    EXPECT_LE(a.event_time[e], a.time.back());  // the step that made it ended by the last record
    const int p = a.event_capsules[2 * e], q = a.event_capsules[2 * e + 1];
    EXPECT_TRUE((p == 0 && q == 1) || (q < 0 && p >= 0)) << p << " " << q;
  }
  // Interrupted and continued: events (and everything else) as in the uninterrupted run.
  s.output = (dir.path / "part.h5").string();
  s.stop_after_steps = full.steps / 2;
  const RunResult part = run_simulation(c, s, std::cerr);
  ASSERT_EQ(part.exit_code, 128 + SIGINT);
  RunSettings cont;
  cont.restart = part.checkpoint;
  cont.quiet = true;
  ASSERT_EQ(run_simulation(c, cont, std::cerr).exit_code, 0);
  const RunFile b = read_run_file(dir.path / "part.h5");
  EXPECT_EQ(a.event_time, b.event_time);
  EXPECT_EQ(a.event_gap, b.event_gap);
  EXPECT_EQ(a.event_dy, b.event_dy);
  EXPECT_EQ(a.event_capsules, b.event_capsules);
  EXPECT_EQ(a.centroid, b.centroid);
  EXPECT_EQ(a.profile, b.profile);
  EXPECT_EQ(a.max_step_ratio, b.max_step_ratio);
  EXPECT_EQ(a.relative_viscosity, b.relative_viscosity);
  // The frames too, membrane fields included (compressed datasets truncated and appended to).
  const H5File fa = H5File::open(dir.path / "full.h5"), fb = H5File::open(dir.path / "part.h5");
  for (const char* p : layout::frame_view_sources(layout::kFormatVersion)) {
    SCOPED_TRACE(p);
    const H5Array<double> x = fa.read<double>(p), y = fb.read<double>(p);
    ASSERT_EQ(x.dims, y.dims);
    EXPECT_EQ(std::memcmp(x.data.data(), y.data.data(), 8 * x.data.size()), 0);
  }
  EXPECT_EQ(fa.datasets().size(), fb.datasets().size());  // the same frame views, no stale ones
}

}  // namespace

// A stop signal is honoured only after the next step is planned: a run whose next step falls below [time] dt_floor
// has failed even when a signal came first, so an interrupted run's checkpoint can always take its next step (a
// sweep resumed after an interruption never meets a point that the first-step check refuses). Two level-1 capsules
// in shear, seed 3: the first step (0.082) passes dt_floor = 0.08, the deforming capsules' second (0.0795) does not.
TEST(RunLayout, AStopSignalBeforeAFailingStepEndsTheRunAsFailedNotInterrupted) {
  test::TempDir dir;
  const Config c = parse_config(test::sweep_base_text(3, "dt_floor = 0.08\n"), "<test>");
  RunSettings s;
  s.quiet = true;
  s.output = (dir.path / "zero.h5").string();
  s.stop_after_steps = 0;  // the signal before step 1, whose step passes the floor: interrupted
  const RunResult zero = run_simulation(c, s, std::cerr);
  EXPECT_EQ(zero.exit_code, 128 + SIGINT) << zero.stop_message;
  EXPECT_EQ(zero.steps, 0);
  EXPECT_NE(zero.stop_message.find("interrupted"), std::string::npos) << zero.stop_message;

  s.output = (dir.path / "one.h5").string();
  s.stop_after_steps = 1;  // the signal before step 2, which fails: failed, with the failure's reason
  const RunResult one = run_simulation(c, s, std::cerr);
  EXPECT_EQ(one.exit_code, 3) << one.stop_message;
  EXPECT_EQ(one.steps, 1);
  EXPECT_NE(one.stop_message.find("stopped early (dt-below-floor)"), std::string::npos) << one.stop_message;

  // The interrupted run continues from its checkpoint and fails at the same step as the uninterrupted run.
  RunSettings cont;
  cont.quiet = true;
  cont.restart = zero.checkpoint;
  const RunResult rest = run_simulation(c, cont, std::cerr);
  EXPECT_EQ(rest.exit_code, 3) << rest.stop_message;
  EXPECT_EQ(rest.steps, 1);
  EXPECT_EQ(rest.time, one.time);
  EXPECT_NE(rest.stop_message.find("dt-below-floor"), std::string::npos) << rest.stop_message;
}
