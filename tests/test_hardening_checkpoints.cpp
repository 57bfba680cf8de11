// Hardening, fourth round (issue 37, findings 3 and 4): what a restart continues from.
//   3. A checkpoint is checked against the layout its writer uses and against the configuration stored in it before
//      any file is touched: every dataset the continuation needs present where that configuration needs it
//      (/state/initial_orientations for turned capsules, /state/interface_velocity at a viscosity ratio != 1), of its
//      shape (Np capsules, Nn nodes; a transposed array is refused, not read in another order), finite, with counts
//      in range (the GMRES and contact tallies). One table: each damage is refused with one line naming the file and
//      the dataset (exit 2), and no file changes.
//   4. A run stopped by [gmres] max_iterations writes no record of the rejected solve: continued with a larger cap it
//      ends bit for bit where the uninterrupted run ends, and the stop names the key.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "host/base/digest.hpp"
#include "host/base/h5_file.hpp"
#include "host/physics/config.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "support/cli_runner.hpp"
#include "support/run_files.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace capsflow;
using capsflow::test::expect_input_error;
using capsflow::test::run_capsflow;
using capsflow::test::snapshot_files;

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

// A turned spheroid at viscosity ratio 5, pinned in shear, mesh level 1: its checkpoint holds every optional dataset
// (the orientations, the interface velocity and the two answers before it) at strain 0.2.
std::string turned_drop_of_lambda5(const std::string& file) {
  return "[domain]\nH = 5.0\nLx = 7.0\nLz = 7.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"serial\"\n[flow]\ntype = \"shear\"\n[capsules]\n"
         "mesh_level = 1\n[[species]]\nname = \"a\"\nca = 0.2\nviscosity_ratio = 5.0\nshape = \"spheroid\"\n"
         "aspect = 0.6\n[[capsule]]\nspecies = \"a\"\ncenter = [3.5, 2.5, 3.5]\norientation = [1.0, 1.0, 0.0]\n"
         "pinned = true\n[time]\nend = 0.2\n[output]\nfile = \"" + file + "\"\nevery = 0.05\nframes_every = 0.05\n";
}

// A dataset rewritten with `dims` and `data` (the edit of a hand-made checkpoint).
void rewrite(H5File& f, const std::string& path, const std::vector<std::size_t>& dims, const std::vector<double>& v) {
  f.remove(path);
  f.write(path, dims, v);
}

std::vector<double> transposed(const H5Array<double>& a) {
  const std::size_t r = a.dims[0], c = a.dims[1];
  std::vector<double> t(a.data.size());
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < c; ++j) t[j * r + i] = a.data[i * c + j];
  return t;
}

void set_gmres_tallies(H5File& f, std::int64_t steps, std::int64_t iterations, std::int64_t max_iterations,
                       double residual) {
  f.set_attribute("/state", "gmres_steps_since_record", steps);
  f.set_attribute("/state", "gmres_iterations_since_record", iterations);
  f.set_attribute("/state", "gmres_max_iterations_since_record", max_iterations);
  f.set_attribute("/state", "gmres_max_residual_since_record", residual);
}

TEST(CheckpointSchema, EveryDamageADatasetCanHaveIsRefusedByName) {
  if (test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work / "r");
  write_text(work / "c.toml", turned_drop_of_lambda5("r/out.h5"));
  ASSERT_EQ(run_capsflow(work, "run c.toml -q", 120).status, 0);
  {
    const H5File f = H5File::open(work / "r" / "out.checkpoint.h5");
    ASSERT_TRUE(f.exists("/state/initial_orientations"));
    ASSERT_TRUE(f.exists("/state/interface_velocity"));
    ASSERT_EQ(f.dims("/state/interface_velocity"), (std::vector<std::size_t>{3, 42}));
    ASSERT_TRUE(f.exists("/state/interface_velocity_previous2"));
  }
  // The checkpoint as written continues (the dry run reads it and takes the first solve).
  EXPECT_EQ(run_capsflow(work, "run --restart r/out.checkpoint.h5 --end 1 --dry-run", 120).status, 0);

  struct Case {
    const char* dataset;  // what the message must name
    std::function<void(H5File&)> edit;
  };
  const std::string o = "/state/initial_orientations", iv = "/state/interface_velocity";
  const Case cases[] = {
      // The orientations this configuration turns its capsule by: gone, short, transposed, not a rotation, NaN.
      {"/state/initial_orientations (missing)", [&](H5File& f) { f.remove(o); }},
      {"/state/initial_orientations", [&](H5File& f) { rewrite(f, o, {1, 8}, std::vector<double>(8, 0.0)); }},
      {"/state/initial_orientations", [&](H5File& f) { rewrite(f, o, {9, 1}, f.read<double>(o).data); }},
      {"/state/initial_orientations", [&](H5File& f) {
         const std::vector<double> r = f.read<double>(o).data;  // R^T: the inverse turn, a rotation, not this one
         rewrite(f, o, {1, 9}, {r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]});
       }},
      {"/state/initial_orientations", [&](H5File& f) {
         rewrite(f, o, {1, 9}, {1, 0, 0, 0, 1, 0, 0, 0, 1});  // the identity: the unturned spheroid
       }},
      {"/state/initial_orientations", [&](H5File& f) {
         std::vector<double> r = f.read<double>(o).data;
         r[4] = std::nan("");
         rewrite(f, o, {1, 9}, r);
       }},
      // The interface velocity the next solve starts from: gone, short, transposed, NaN.
      {"/state/interface_velocity (missing)", [&](H5File& f) { f.remove(iv); }},
      {"/state/interface_velocity", [&](H5File& f) {
         std::vector<double> v = f.read<double>(iv).data;
         v.resize(3 * 41);
         rewrite(f, iv, {3, 41}, v);
       }},
      {"/state/interface_velocity", [&](H5File& f) { rewrite(f, iv, {42, 3}, transposed(f.read<double>(iv))); }},
      {"/state/interface_velocity", [&](H5File& f) {
         std::vector<double> v = f.read<double>(iv).data;
         v[17] = std::numeric_limits<double>::infinity();
         rewrite(f, iv, {3, 42}, v);
       }},
      // The answer two solves back (the quadratic guess): at a strain that is not finite or not below the newer
      // answer's, or without the newer answer beside it.
      {"/state attribute interface_velocity_previous2_time",
       [](H5File& f) { f.set_attribute("/state", "interface_velocity_previous2_time", std::nan("")); }},
      {"/state attribute interface_velocity_previous2_time", [](H5File& f) {
         f.set_attribute("/state", "interface_velocity_previous2_time",
                         f.attribute<double>("/state", "interface_velocity_previous_time"));
       }},
      {"/state/interface_velocity_previous2", [](H5File& f) { f.remove("/state/interface_velocity_previous"); }},
      // The GMRES tallies since the last record: NaN, negative, inconsistent, incomplete.
      {"gmres_max_residual_since_record", [](H5File& f) { set_gmres_tallies(f, 1, 12, 12, std::nan("")); }},
      {"gmres_max_residual_since_record", [](H5File& f) { set_gmres_tallies(f, 1, 12, 12, -1e-9); }},
      {"gmres_steps_since_record", [](H5File& f) { set_gmres_tallies(f, -1, 12, 12, 1e-9); }},
      {"gmres_iterations_since_record", [](H5File& f) { set_gmres_tallies(f, 1, -12, 0, 1e-9); }},
      {"gmres_max_iterations_since_record", [](H5File& f) { set_gmres_tallies(f, 1, 12, -3, 1e-9); }},
      {"gmres_*_since_record", [](H5File& f) { set_gmres_tallies(f, 1, 12, 13, 1e-9); }},
      {"gmres_*_since_record", [](H5File& f) { f.set_attribute("/state", "gmres_steps_since_record", 2); }},
      // The other datasets of the state: shapes, finiteness, ranges.
      {"/state/u_previous", [](H5File& f) {
         rewrite(f, "/state/u_previous", {3, 42}, transposed(f.read<double>("/state/u_previous")));
       }},
      {"/state/u_previous2", [](H5File& f) { f.remove("/state/u_previous2"); }},
      {"/state/step_limits_since_record", [](H5File& f) { f.remove("/state/step_limits_since_record"); }},
      {"/state/step_limits_since_record", [](H5File& f) {
         f.remove("/state/step_limits_since_record");
         f.write<std::int64_t>("/state/step_limits_since_record", {5}, std::vector<std::int64_t>{1, 0, -4, 0, 0});
       }},
      {"/state/pinned", [](H5File& f) {
         f.remove("/state/pinned");
         f.write<std::int64_t>("/state/pinned", {1}, std::vector<std::int64_t>{7});
       }},
      {"/state/species", [](H5File& f) {
         f.remove("/state/species");
         f.write<std::int64_t>("/state/species", {1}, std::vector<std::int64_t>{3});
       }},
      {"/state/initial_centres", [](H5File& f) { rewrite(f, "/state/initial_centres", {1, 2}, {3.5, 2.5}); }},
      {"/state/pin_centres", [](H5File& f) {
         rewrite(f, "/state/pin_centres", {1, 3}, {3.5, std::nan(""), 3.5});
       }},
      {"/state attribute contact_corrections",
       [](H5File& f) { f.set_attribute("/state", "contact_corrections", std::int64_t{-1}); }},
      {"/state attribute max_step_ratio_since_record",
       [](H5File& f) { f.set_attribute("/state", "max_step_ratio_since_record", std::nan("")); }},
      {"/state attribute dt_previous", [](H5File& f) { f.set_attribute("/state", "dt_previous", 0.0); }},
      {"/state attribute have_history", [](H5File& f) { f.set_attribute("/state", "have_history", std::int64_t{2}); }},
      {"format_version", [](H5File& f) { f.set_attribute("/", "format_version", std::int64_t{0}); }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.dataset);
    fs::copy_file(work / "r" / "out.checkpoint.h5", work / "bad.checkpoint.h5", fs::copy_options::overwrite_existing);
    {
      H5File f = H5File::open(work / "bad.checkpoint.h5", H5Access::ReadWrite);
      c.edit(f);
    }
    const auto before = snapshot_files(work);
    expect_input_error(run_capsflow(work, "run --restart bad.checkpoint.h5 --output r/out.h5 --end 1", 60),
                       {"bad.checkpoint.h5", c.dataset, "expected"});
    EXPECT_EQ(snapshot_files(work), before);
  }
}

// A checkpoint at step 0 has no interface velocity (the first solve starts from the imposed flow); one that has it
// would start that solve elsewhere. And a lambda = 1 run has no GMRES tallies.
TEST(CheckpointSchema, DatasetsTheConfigurationCannotHaveAreRefused) {
  if (test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work / "r");
  write_text(work / "c.toml", turned_drop_of_lambda5("r/out.h5"));
  // A finished run's checkpoint made into one of step 0 by hand (a run checkpoints step 0 before any solve's answer
  // is kept).
  ASSERT_EQ(run_capsflow(work, "run c.toml -q", 120).status, 0);
  fs::copy_file(work / "r" / "out.checkpoint.h5", work / "zero.checkpoint.h5", fs::copy_options::overwrite_existing);
  {
    H5File f = H5File::open(work / "zero.checkpoint.h5", H5Access::ReadWrite);
    f.set_attribute("/state", "step", std::int64_t{0});
  }
  expect_input_error(run_capsflow(work, "run --restart zero.checkpoint.h5 --output r/out.h5 --end 1", 60),
                     {"zero.checkpoint.h5", "/state/interface_velocity", "step 0"});
}

// ---------------------------------------------------------------------------------------------------------------
// Issue 52, item 3: a checkpoint that contradicts its own run (edited after capsflow wrote it: a moved time, another
// configuration, float32 positions, swapped or grafted datasets, a moved node, a dropped history) is refused before
// anything is written, by the digests written with it (since 2026-12-08); one without digests (an older build's) is
// checked against the output it continues. Item 4: the dry run refuses what the restart refuses.

// The digest tells a one-bit change and an order change (what the checkpoint's /state digest stands on).
TEST(CheckpointDigest, TellsOneBitAndTheOrderOfValues) {
  auto digest_of = [](const std::vector<double>& v, const std::string& text) {
    Digest64 d;
    d.add(v);
    d.add(std::string_view(text));
    return d.hex();
  };
  const std::vector<double> v = {0.1, 2.5, -3.0, 1e-300};
  const std::string base = digest_of(v, "ca = 0.2");
  EXPECT_EQ(base.size(), 4u + 16u);
  EXPECT_EQ(base.rfind("h64:", 0), 0u);
  EXPECT_EQ(digest_of(v, "ca = 0.2"), base);  // a function of the values alone
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int bit : {0, 31, 52, 63}) {
      std::vector<double> w = v;
      std::uint64_t u;
      std::memcpy(&u, &w[i], 8);
      u ^= std::uint64_t{1} << bit;
      std::memcpy(&w[i], &u, 8);
      EXPECT_NE(digest_of(w, "ca = 0.2"), base) << "value " << i << " bit " << bit;
    }
  EXPECT_NE(digest_of({2.5, 0.1, -3.0, 1e-300}, "ca = 0.2"), base);
  EXPECT_NE(digest_of(v, "ca = 0.5"), base);
  EXPECT_NE(digest_of(v, "ca = 0.2 "), base);  // a byte past the last full word
  EXPECT_NE(text_digest(""), text_digest(std::string(1, '\0')));  // the length is part of it
}

namespace {

// The small run (two capsules in shear, level 1) writing r/out.h5 (or `file`), checkpointed at its end.
std::string small_checkpointed_run(const std::string& file) {
  return test::small_run_text("file = \"" + file + "\"\n");
}

// Edits the copy work/bad.checkpoint.h5 of work/r/out.checkpoint.h5 by `edit`; then the restart and its dry run
// are both refused in one line naming `words`, and no file changes.
void expect_refused_after(const fs::path& work, const std::function<void(H5File&)>& edit,
                          const std::vector<std::string>& words, const std::string& output = "r/out.h5") {
  fs::copy_file(work / "r" / "out.checkpoint.h5", work / "bad.checkpoint.h5", fs::copy_options::overwrite_existing);
  {
    H5File f = H5File::open(work / "bad.checkpoint.h5", H5Access::ReadWrite);
    edit(f);
  }
  const auto before = snapshot_files(work);
  for (const char* dry : {"", " --dry-run"}) {
    SCOPED_TRACE(dry);
    const test::CliResult r =
        run_capsflow(work, "run --restart bad.checkpoint.h5 --output " + output + " --end 1" + std::string(dry), 60);
    expect_input_error(r, {});
    for (const std::string& w : words) EXPECT_NE(r.err.find(w), std::string::npos) << "'" << w << "' not in: " << r.err;
    EXPECT_EQ(r.out.find("valid"), std::string::npos) << r.out;
    EXPECT_EQ(snapshot_files(work), before);
  }
}

void drop_digests(H5File& f) {
  // An older build's checkpoint: the same file without the attributes written since 2026-12-08.
  const std::string text = f.read_string("/parameters/config");
  f.remove("/parameters/config");
  f.write_string("/parameters/config", text);
  f.remove_attribute("/state", "digest");
}

void replace_config_text(H5File& f, const std::string& from, const std::string& to) {
  std::string text = f.read_string("/parameters/config");
  const std::size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  const bool had_digest = f.has_attribute("/parameters/config", "digest");
  const std::string digest = had_digest ? f.attribute<std::string>("/parameters/config", "digest") : "";
  f.remove("/parameters/config");
  f.write_string("/parameters/config", text);
  if (had_digest) f.set_attribute("/parameters/config", "digest", digest);  // the edit leaves the old digest
}

// The run r/out.h5 to strain 0.4 and another, other/out.h5, to 0.3 (another state of the same shapes), in `work`.
void two_small_runs(const fs::path& work) {
  fs::create_directories(work / "r");
  fs::create_directories(work / "other");
  write_text(work / "c.toml", small_checkpointed_run("r/out.h5"));
  write_text(work / "o.toml", small_checkpointed_run("other/out.h5"));
  ASSERT_EQ(run_capsflow(work, "run c.toml -q --end 0.4", 120).status, 0);
  ASSERT_EQ(run_capsflow(work, "run o.toml -q --end 0.3", 120).status, 0);
}

}  // namespace

TEST(CheckpointAgainstItsRun, EveryEditAfterTheWriteIsRefused) {
  if (test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  ASSERT_NO_FATAL_FAILURE(two_small_runs(work));
  const std::vector<double> grafted = H5File::open(work / "other" / "out.checkpoint.h5").read<double>(
      "/state/positions").data;
  {
    const H5File f = H5File::open(work / "r" / "out.checkpoint.h5");
    ASSERT_TRUE(f.has_attribute("/state", "digest"));
    ASSERT_TRUE(f.has_attribute("/parameters/config", "digest"));
    ASSERT_EQ(f.attribute<std::string>("/", "capsflow_commit").empty(), false);
  }
  // As written, it continues (the dry run reads and checks everything the restart does).
  ASSERT_EQ(run_capsflow(work, "run --restart r/out.checkpoint.h5 --end 1 --dry-run", 60).status, 0);
  const std::string pos = "/state/positions", up = "/state/u_previous";
  const std::vector<std::string> state_digest = {"bad.checkpoint.h5", "/state (attribute digest", "changed"};
  struct Case {
    const char* what;
    std::function<void(H5File&)> edit;
    std::vector<std::string> words;
  };
  const Case cases[] = {
      {"time moved on by 0.2", [](H5File& f) { f.set_attribute("/state", "time", f.attribute<double>("/state", "time") + 0.2); },
       state_digest},
      {"time moved back by 0.2", [](H5File& f) { f.set_attribute("/state", "time", f.attribute<double>("/state", "time") - 0.2); },
       state_digest},
      {"have_history 0", [](H5File& f) { f.set_attribute("/state", "have_history", std::int64_t{0}); }, state_digest},
      {"positions and u_previous swapped", [&](H5File& f) {
         const std::vector<double> a = f.read<double>(pos).data, b = f.read<double>(up).data;
         const std::vector<std::size_t> dims = f.dims(pos);
         rewrite(f, pos, dims, b);
         rewrite(f, up, dims, a);
       }, state_digest},
      {"one node moved by 1e-9", [&](H5File& f) {
         std::vector<double> a = f.read<double>(pos).data;
         a[40] += 1e-9;
         rewrite(f, pos, f.dims(pos), a);
       }, state_digest},
      {"positions grafted from another run", [&](H5File& f) { rewrite(f, pos, f.dims(pos), grafted); }, state_digest},
      {"positions stored as float32", [&](H5File& f) {
         const H5Array<double> a = f.read<double>(pos);
         f.remove(pos);
         f.write<float>(pos, a.dims, std::vector<float>(a.data.begin(), a.data.end()));
       }, {"bad.checkpoint.h5", "/state/positions", "float64", "float32"}},
      {"ca 0.2 -> 0.5 in the stored configuration", [](H5File& f) { replace_config_text(f, "ca = 0.2", "ca = 0.5"); },
       {"bad.checkpoint.h5", "/parameters/config (attribute digest", "changed"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    expect_refused_after(work, c.edit, c.words);
  }
}

// An older build's checkpoint (no digests) is checked against the output it continues: its strain at or after the
// output's last counted record and, one step back, below /run next_record, its configuration the output's physics; and in every case the
// output must exist and be the run's own. The dry run says "valid" only where the restart would start.
TEST(CheckpointAgainstItsRun, WithoutDigestsTheOutputIsTheReference) {
  if (test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  ASSERT_NO_FATAL_FAILURE(two_small_runs(work));
  // Without its digests the checkpoint as written still continues (the dry run checks what the restart checks).
  fs::copy_file(work / "r" / "out.checkpoint.h5", work / "old.checkpoint.h5");
  {
    H5File f = H5File::open(work / "old.checkpoint.h5", H5Access::ReadWrite);
    drop_digests(f);
  }
  ASSERT_EQ(run_capsflow(work, "run --restart old.checkpoint.h5 --output r/out.h5 --end 1 --dry-run", 60).status, 0);
  struct Case {
    const char* what;
    std::function<void(H5File&)> edit;
    std::vector<std::string> words;
    std::string output = "r/out.h5";
  };
  const Case cases[] = {
      {"time moved on by 0.2", [](H5File& f) {
         drop_digests(f);
         f.set_attribute("/state", "time", f.attribute<double>("/state", "time") + 0.2);
       }, {"bad.checkpoint.h5", "/state attribute time", "next_record"}},
      {"time moved back by 0.2", [](H5File& f) {
         drop_digests(f);
         f.set_attribute("/state", "time", f.attribute<double>("/state", "time") - 0.2);
       }, {"bad.checkpoint.h5", "/state attribute time", "record 9", "/series/time"}},
      {"ca 0.2 -> 0.5 in the stored configuration", [](H5File& f) {
         drop_digests(f);
         replace_config_text(f, "ca = 0.2", "ca = 0.5");
       }, {"bad.checkpoint.h5", "/parameters/config", "ca = 0.2", "ca = 0.5"}},
      // Same shapes, types, strains and physics: only the first step sees it, and blames the checkpoint (issue 52,
      // item 9: it was blamed on [time] c_gap, which a restart cannot change).
      {"positions and u_previous swapped", [](H5File& f) {
         drop_digests(f);
         const std::string pos = "/state/positions", up = "/state/u_previous";
         const std::vector<double> a = f.read<double>(pos).data, b = f.read<double>(up).data;
         const std::vector<std::size_t> dims = f.dims(pos);
         rewrite(f, pos, dims, b);
         rewrite(f, up, dims, a);
       }, {"bad.checkpoint.h5", "the checkpoint's state gives no next step", "damaged or edited"}},
      {"an emptied digest", [](H5File& f) { f.set_attribute("/state", "digest", std::string()); },
       {"bad.checkpoint.h5", "/state attribute digest", "h64:"}},
      // With or without digests: the output must be the run's own, and there.
      {"another run's output", [](H5File&) {}, {"other/out.h5", "belongs to another run"}, "other/out.h5"},
      {"no output", [](H5File&) {}, {"gone/out.h5", "does not exist"}, "gone/out.h5"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    expect_refused_after(work, c.edit, c.words, c.output);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// 4. Stop at a small GMRES cap, continue with a larger one: the uninterrupted run's files, bit for bit.

// A prestressed capsule at lambda 5 in Poiseuille flow (a small box: a few tenths of a second per step). The first
// solve starts from the imposed flow and takes fewer operator applications than the next ones, which start from
// the previous answer of another shape: a cap that lets the first through stops a later one.
std::string lambda5_poiseuille(int max_iterations) {
  return "[domain]\nH = 5.0\nLx = 6.0\nLz = 6.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"serial\"\n"
         "[flow]\ntype = \"poiseuille\"\n[capsules]\nmesh_level = 1\ninflation = 0.05\n[[species]]\nname = \"a\"\n"
         "ca = 0.1\nviscosity_ratio = 5.0\n[[capsule]]\nspecies = \"a\"\ncenter = [3.0, 2.0, 3.0]\n[time]\n"
         "end = 0.1\n[gmres]\ntolerance = 1e-10\nmax_iterations = " + std::to_string(max_iterations) +
         "\n[output]\nevery = 0.001\nframes_every = 0.08\n";
}

std::map<std::string, std::vector<double>> growing_datasets(const fs::path& h5) {
  const H5File f = H5File::open(h5);
  std::map<std::string, std::vector<double>> m;
  const std::int64_t version = f.attribute<std::int64_t>("/", layout::kAttrFormat);
  for (auto g : {layout::Growth::PerRecord, layout::Growth::PerFrame, layout::Growth::PerEvent})
    for (const layout::DatasetInfo* d : layout::extendable(g, version))
      if (f.exists(d->path)) m[d->path] = f.read<double>(d->path).data;
  return m;
}

TEST(GmresStop, ContinuedWithALargerCapEqualsTheUninterruptedRunBitForBit) {
  test::TempDir dir;
  std::ostringstream sink;
  // The uninterrupted run at the default cap (200: every solve converges, as it would at any cap above its need).
  const RunResult full =
      run_simulation(parse_config(lambda5_poiseuille(200), "full.toml"), test::quiet_run(dir.path / "full.h5"), sink);
  ASSERT_EQ(full.exit_code, 0) << full.stop_message;
  // Records every step: record r > 0 tallies the solve of step r - 1. The cap: the applications the solves before
  // the first one that needs more took.
  const std::vector<double> it = H5File::open(dir.path / "full.h5").read<double>("/series/gmres_iterations").data;
  ASSERT_GE(it.size(), 3u);
  int cap = static_cast<int>(it[1]);
  std::size_t stop_record = 0;
  for (std::size_t r = 2; r < it.size() && stop_record == 0; ++r) {
    if (it[r] > cap) stop_record = r;
    else cap = static_cast<int>(it[r]) > cap ? static_cast<int>(it[r]) : cap;
  }
  ASSERT_GT(stop_record, 0u) << "no solve needs more applications than the ones before it";
  std::printf("  GMRES applications per solve:");
  for (std::size_t r = 1; r < it.size(); ++r) std::printf(" %.0f", it[r]);
  std::printf("; cap %d stops the solve of step %zu\n", cap, stop_record - 1);

  const RunResult part =
      run_simulation(parse_config(lambda5_poiseuille(cap), "part.toml"), test::quiet_run(dir.path / "part.h5"), sink);
  ASSERT_EQ(part.exit_code, 3) << part.stop_message;
  EXPECT_NE(part.stop_message.find("[gmres] max_iterations = " + std::to_string(cap)), std::string::npos)
      << part.stop_message;
  // The rejected solve reached no record: the records end before the stopped step.
  EXPECT_EQ(H5File::open(dir.path / "part.h5").extent("/series/time"), stop_record - 1);

  RunSettings cont;
  cont.restart = part.checkpoint;
  cont.quiet = true;
  cont.overrides = parse_overrides({"gmres.max_iterations=200"});
  const RunResult rest = run_simulation(Config{}, cont, sink);
  ASSERT_EQ(rest.exit_code, 0) << rest.stop_message;
  EXPECT_EQ(part.steps + rest.steps, full.steps);
  const auto a = growing_datasets(dir.path / "full.h5"), b = growing_datasets(dir.path / "part.h5");
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [path, v] : a) {
    SCOPED_TRACE(path);
    const std::vector<double>& w = b.at(path);
    ASSERT_EQ(v.size(), w.size());
    if (!v.empty()) {
      EXPECT_EQ(std::memcmp(v.data(), w.data(), v.size() * sizeof(double)), 0);
    }
  }
}

}  // namespace
