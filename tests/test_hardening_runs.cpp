// Hardening, third round (issue 24): the run's files. Each test is one finding of a hostile user's session against
// `capsflow run` that lost data, corrupted a file, crashed, hung or failed late, with the behaviour now promised:
// a continuation that ends bit for bit where the uninterrupted run ends, or a refusal (exit 2, one line naming the key,
// option or file) that changed nothing (checksums of every file before and after).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/thread_limits.hpp"
#include "host/physics/config.hpp"
#include "host/run/run_estimate.hpp"
#include "host/run/run_layout.hpp"
#include "support/cli_runner.hpp"
#include "support/small_tmpfs.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace capsflow;
using capsflow::test::CliResult;
using capsflow::test::expect_input_error;
using capsflow::test::run_capsflow;
using capsflow::test::SmallTmpfs;
using capsflow::test::shell_quote;
using capsflow::test::snapshot_files;
using capsflow::test::TempDir;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

// One pinned level-1 capsule in shear, records and frames every 0.1: a few hundred steps a second.
std::string pinned(const std::string& file, const std::string& extra_time = "", const std::string& name = "a",
                   const std::string& extra_output = "") {
  return "[domain]\nH = 6.0\nLx = 8.0\nLz = 8.0\n[ggem]\nalpha = 4.0\n[flow]\ntype = \"shear\"\n[capsules]\n"
         "mesh_level = 1\n[[species]]\nname = \"" + name + "\"\nca = 0.2\n[[capsule]]\nspecies = \"" + name + "\"\n"
         "center = [4.0, 3.0, 4.0]\npinned = true\n[time]\nend = 0.5\n" + extra_time +
         "[output]\nfile = \"" + file + "\"\nevery = 0.1\nframes_every = 0.1\n" + extra_output;
}

// Every growing dataset of a run's output (series, frames, events), as read back: two runs that continue bit for bit
// have equal maps.
std::map<std::string, std::vector<double>> series_of(const fs::path& h5) {
  const H5File f = H5File::open(h5);
  std::map<std::string, std::vector<double>> m;
  const std::int64_t version = f.attribute<std::int64_t>("/", layout::kAttrFormat);
  for (auto g : {layout::Growth::PerRecord, layout::Growth::PerFrame, layout::Growth::PerEvent})
    for (const layout::DatasetInfo* d : layout::extendable(g, version)) {
      if (!f.exists(d->path)) continue;
      if (std::string(d->type) == "double" || std::string(d->type) == "float32") {
        m[d->path] = f.read<double>(d->path).data;
      } else {
        for (std::int64_t v : f.read<std::int64_t>(d->path).data) m[d->path].push_back(static_cast<double>(v));
      }
    }
  return m;
}

// Bitwise equality (NaN equal to NaN: the AB2 proxy is NaN before two steps).
bool same_bits(const std::map<std::string, std::vector<double>>& a,
               const std::map<std::string, std::vector<double>>& b, std::string* first_difference) {
  for (const auto& [k, v] : a) {
    auto it = b.find(k);
    if (it == b.end() || it->second.size() != v.size()) {
      *first_difference = k + " (missing or another length)";
      return false;
    }
    // (memcmp of an empty dataset's null pointers is undefined: compare only what is there)
    if (!v.empty() && std::memcmp(v.data(), it->second.data(), v.size() * sizeof(double)) != 0) {
      *first_difference = k;
      return false;
    }
  }
  if (a.size() != b.size()) *first_difference = "another set of datasets";
  return a.size() == b.size();
}

class RunFiles : public testing::Test {
 protected:
  void SetUp() override {
    if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
    work_ = tmp_.path / "work";
    fs::create_directories(work_);
  }
  CliResult run(const std::string& args, int timeout_s = 120) const { return run_capsflow(work_, args, timeout_s); }
  // The uninterrupted run to `end` in its own directory: the reference every continuation must equal.
  fs::path reference(double end) {
    const fs::path dir = work_ / "reference";
    fs::create_directories(dir);
    write_text(dir / "c.toml", pinned("out.h5"));
    EXPECT_EQ(run_capsflow(dir, "run c.toml -q --end " + std::to_string(end)).status, 0);
    return dir / "out.h5";
  }
  TempDir tmp_;
  fs::path work_;
};

// ---------------------------------------------------------------------------------------------------------------
// 1. A copy of a run directory continues the copy; the original is not touched (it used to be extended through the
//    absolute path stored in the checkpoint). A restart with nothing to do changes nothing.

TEST_F(RunFiles, ACopiedRunContinuesTheCopyAndLeavesTheOriginal) {
  fs::create_directories(work_ / "orig");
  write_text(work_ / "orig" / "c.toml", pinned("out.h5"));
  ASSERT_EQ(run_capsflow(work_ / "orig", "run c.toml -q --end 0.5").status, 0);
  fs::copy(work_ / "orig", work_ / "copy", fs::copy_options::recursive);
  const auto original = snapshot_files(work_ / "orig");

  const CliResult r = run("run --restart copy/out.checkpoint.h5 --end 1 -q");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(snapshot_files(work_ / "orig"), original);
  std::string diff;
  EXPECT_TRUE(same_bits(series_of(work_ / "copy" / "out.h5"), series_of(reference(1.0)), &diff)) << diff;

  // Nothing to do: the end is reached already.
  const auto copy = snapshot_files(work_ / "copy");
  const CliResult again = run("run --restart copy/out.checkpoint.h5 -q");
  EXPECT_EQ(again.status, 0) << again.err;
  EXPECT_EQ(snapshot_files(work_ / "copy").at("out.checkpoint.h5"), copy.at("out.checkpoint.h5"));
  EXPECT_EQ(snapshot_files(work_ / "orig"), original);
}

// 2. The checkpoint given as the output (it used to receive the series and frames, then exit 2).
TEST_F(RunFiles, TheCheckpointAsTheOutputIsRefused) {
  write_text(work_ / "c.toml", pinned("r/out.h5"));
  fs::create_directories(work_ / "r");
  ASSERT_EQ(run("run c.toml -q").status, 0);
  const auto before = snapshot_files(work_);
  expect_input_error(run("run --restart r/out.checkpoint.h5 --output r/out.checkpoint.h5 --end 1"),
                     {"r/out.checkpoint.h5", "checkpoint", "choose another output"});
  EXPECT_EQ(snapshot_files(work_), before);
}

// 3. Started with stderr closed: the HDF5 file used to be opened as descriptor 2 and receive the progress lines.
TEST_F(RunFiles, AClosedStderrDoesNotReachTheOutput) {
  write_text(work_ / "c.toml", pinned("out.h5"));
  const CliResult r = run_capsflow(work_, "run c.toml --end 1 --progress 0.001", 120, "OMP_NUM_THREADS=2", "2>&-");
  ASSERT_EQ(r.status, 0);
  std::string diff;
  EXPECT_TRUE(same_bits(series_of(work_ / "out.h5"), series_of(reference(1.0)), &diff)) << diff;
}

// ---------------------------------------------------------------------------------------------------------------
// 4. A disk that fills late: the checkpoint is whole, the output's index may point past the end of the file. The
//    restart (after room is made) repairs the output and ends bit for bit at the uninterrupted result; no OUT.lock
//    is left by the failed run.

// Whether a full disk tears the output's index depends on where HDF5's last flush stopped, i.e. on the byte layout,
// down to the length of the paths stored in the file: the run is made inside the small disk with relative names, so
// that the layout is the same wherever the test runs. With Debian 12's HDF5 1.10, disks of 1650-1700 kB tear it
// (at strain ~6.5); the others fill cleanly. Each disk that fills is continued after room is made.
//
// Torn: the restart must rebuild the output, because it is longer than its allocated end (a flush that did not finish
// left blocks past it: RunOutput) or because it cannot be truncated in place.
bool restart_must_rebuild(const fs::path& h5) {
  try {
    {
      const H5File f = H5File::open(h5);
      if (f.allocated_end() != fs::file_size(h5)) return true;
    }
    H5File f = H5File::open(h5, H5Access::ReadWrite);
    for (const std::string& name : f.children("/xdmf/positions")) f.remove("/xdmf/positions/" + name);
    f.close();
    return false;
  } catch (const std::exception&) {
    return true;
  }
}

TEST_F(RunFiles, ALateFullDiskIsRepairedByTheRestart) {
  const fs::path ref = reference(10.0);
  int filled = 0, torn = 0;
  for (int kb : {1675, 1500}) {
    SCOPED_TRACE(std::to_string(kb) + " kB");
    SmallTmpfs fsys(tmp_.path / ("small" + std::to_string(kb)), std::to_string(kb) + "k");
    if (!fsys.mounted) GTEST_SKIP() << fsys.why;
    write_text(fsys.dir / "c.toml", pinned("out.h5"));
    const CliResult r = run_capsflow(fsys.dir, "run c.toml -q --end 10");
    if (r.status == 0) continue;  // the disk was large enough
    ++filled;
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(fsys.dir / "out.lock"));
    ASSERT_TRUE(fs::exists(fsys.dir / "out.checkpoint.h5"));
    EXPECT_NO_THROW(H5File::open(fsys.dir / "out.checkpoint.h5"));
    // Torn? (a copy is probed: the output itself goes to the restart as the failed run left it)
    fs::copy_file(fsys.dir / "out.h5", work_ / "probe.h5", fs::copy_options::overwrite_existing);
    const bool tear = restart_must_rebuild(work_ / "probe.h5");
    torn += tear ? 1 : 0;
    ASSERT_TRUE(fsys.grow("64m"));
    const CliResult c = run_capsflow(fsys.dir, "run --restart out.checkpoint.h5 --end 10 --progress 0");
    ASSERT_EQ(c.status, 0) << c.err;
    EXPECT_EQ(c.err.find("rebuilt from the") != std::string::npos, tear) << c.err;
    std::string diff;
    EXPECT_TRUE(same_bits(series_of(fsys.dir / "out.h5"), series_of(ref), &diff)) << diff;
    EXPECT_FALSE(fs::exists(fsys.dir / "out.lock"));
  }
  EXPECT_GT(filled, 0) << "no disk filled: the test tests nothing";
  if (torn == 0) std::cerr << "no disk tore the output's index with this HDF5: the rebuild was not exercised\n";
}

// ---------------------------------------------------------------------------------------------------------------
// 5. Thread counts from the environment (OMP_NUM_THREADS=100000 used to crash in GOMP_parallel; 5000 under an
//    address-space limit ended in "libgomp: Thread creation failed" with OUT.lock left).

TEST_F(RunFiles, ThreadCountsFromTheEnvironmentAreChecked) {
  write_text(work_ / "c.toml", pinned("out.h5"));
  write_text(work_ / "g.toml", "[domain]\nH = 4.0\nLx = 8.0\nLz = 8.0\n[ggem]\nalpha = 4.0\n");
  write_text(work_ / "s.csv", "x,y,z,fx,fy,fz\n4.0,2.0,4.0,1.0,0.0,0.0\n");
  write_text(work_ / "t.csv", "x,y,z\n4.5,2.0,4.0\n");
  const auto before = snapshot_files(work_);
  // More than any pid_max allows (2^22); the 100000 where this machine cannot create it either.
  std::vector<std::string> envs = {"OMP_NUM_THREADS=100000000", "OMP_NUM_THREADS=100000000,4",
                                   "OMP_NUM_THREADS=2,100000000"};
  const ThreadLimits lim = thread_limits();
  if (lim.hard > 0 && lim.hard < 100000) envs.push_back("OMP_NUM_THREADS=100000");
  for (const std::string& env : envs)
    for (const char* args : {"run c.toml", "demo --out d", "green g.toml --sources s.csv --targets t.csv --out u.csv"}) {
      SCOPED_TRACE(env + " " + args);
      expect_input_error(run_capsflow(work_, args, 60, env), {"OMP_NUM_THREADS", "(environment)", "expected at most"});
    }
  // libgomp warns about the value itself first ("Invalid value for environment variable"): ours is the last line.
  const CliResult two = run_capsflow(work_, "run c.toml", 60, "OMP_NUM_THREADS=two");
  EXPECT_EQ(two.status, 2) << two.err;
  EXPECT_NE(two.err.find("capsflow: error: OMP_NUM_THREADS=two (environment): expected positive integers"),
            std::string::npos)
      << two.err;
  // Under a 6 GB address space, 5000 stacks of 8 MiB cannot be mapped. (Not under AddressSanitizer, whose shadow
  // memory alone reserves terabytes of address space: such a binary cannot start under the limit at all.)
  if (!kAddressSanitizer)
    expect_input_error(
        run_capsflow(work_, "run c.toml", 60, "ulimit -s 8192; ulimit -v 6000000; OMP_NUM_THREADS=5000"),
        {"OMP_NUM_THREADS=5000", "address-space limit"});
  EXPECT_EQ(snapshot_files(work_), before);
}

// ---------------------------------------------------------------------------------------------------------------
// 9. Values that pass each key's range but give no first step: refused before any file (they used to write four
//    files and stop at step 0 with exit 3).

TEST_F(RunFiles, ValuesThatGiveNoFirstStepAreRefusedBeforeAnyFile) {
  fs::create_directories(work_ / "out");
  write_text(work_ / "c.toml", pinned("out/run.h5"));
  const auto before = snapshot_files(work_);
  const std::pair<const char*, const char*> cases[] = {
      {"time.cfl=1e300", "[time] cfl"},        {"time.cfl=1e-300", "[time] cfl"},
      {"species.1.ca=1e300", "[[species]] ca"}, {"species.1.ca=1e-300", "[[species]] 1 ca"},
      {"time.dt_floor=1e300", "[time] dt_floor"}, {"time.reference_ca=1e-300", "[time] reference_ca"},
      {"capsules.inflation=1e300", "[capsules] inflation"}, {"capsules.radius=1e-300", "[capsules] radius"}};
  for (const auto& [set, key] : cases) {
    SCOPED_TRACE(set);
    expect_input_error(run(std::string("run c.toml --set ") + set), {"c.toml", key, "expected"});
  }
  EXPECT_EQ(snapshot_files(work_), before);
}

// 9, 12. A checkpoint is an input: a NaN time (used to loop forever), a negative time or step, a NaN position.
TEST_F(RunFiles, ImpossibleCheckpointValuesAreRefused) {
  write_text(work_ / "c.toml", pinned("r/out.h5"));
  fs::create_directories(work_ / "r");
  ASSERT_EQ(run("run c.toml -q").status, 0);
  struct Case {
    const char* what;
    void (*edit)(H5File&);
  };
  const Case cases[] = {
      {"/state attribute time", [](H5File& f) { f.set_attribute("/state", "time", std::nan("")); }},
      {"/state attribute time", [](H5File& f) { f.set_attribute("/state", "time", -1.0); }},
      {"/state attribute step", [](H5File& f) { f.set_attribute("/state", "step", std::int64_t{-5}); }},
      {"/state/positions", [](H5File& f) {
         std::vector<double> x = f.read<double>("/state/positions").data;
         x[7] = std::nan("");
         f.remove("/state/positions");
         f.write("/state/positions", {x.size() / 3, 3}, x);
       }}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    fs::copy_file(work_ / "r" / "out.checkpoint.h5", work_ / "bad.checkpoint.h5", fs::copy_options::overwrite_existing);
    {
      H5File f = H5File::open(work_ / "bad.checkpoint.h5", H5Access::ReadWrite);
      c.edit(f);
    }
    const auto before = snapshot_files(work_);
    expect_input_error(run("run --restart bad.checkpoint.h5 --output r/out.h5 --end 1", 30),
                       {"bad.checkpoint.h5", c.what, "expected"});
    EXPECT_EQ(snapshot_files(work_), before);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// 10. Refusals and failures leave no OUT.lock; temporaries of a writer killed during a checkpoint are removed.

TEST_F(RunFiles, RefusedRestartsLeaveNoLock) {
  fs::create_directories(work_ / "a");
  fs::create_directories(work_ / "b");
  write_text(work_ / "a" / "c.toml", pinned("out.h5"));
  write_text(work_ / "b" / "c.toml", pinned("out.h5"));
  ASSERT_EQ(run_capsflow(work_ / "a", "run c.toml -q").status, 0);
  ASSERT_EQ(run_capsflow(work_ / "b", "run c.toml -q --end 0.2").status, 0);
  // The output of another run.
  expect_input_error(run("run --restart a/out.checkpoint.h5 --output b/out.h5 --end 2"), {"b/out.h5", "another run"});
  EXPECT_FALSE(fs::exists(work_ / "b" / "out.lock"));
  // An output older than the checkpoint (b's copy has fewer records than a's checkpoint needs).
  fs::copy(work_ / "a", work_ / "old", fs::copy_options::recursive);
  ASSERT_EQ(run_capsflow(work_ / "a", "run --restart out.checkpoint.h5 -q --end 1").status, 0);
  fs::copy_file(work_ / "a" / "out.checkpoint.h5", work_ / "old" / "out.checkpoint.h5",
                fs::copy_options::overwrite_existing);
  const auto old = snapshot_files(work_ / "old");
  expect_input_error(run("run --restart old/out.checkpoint.h5 --end 2"), {"old/out.h5", "older than the checkpoint"});
  EXPECT_FALSE(fs::exists(work_ / "old" / "out.lock"));
  EXPECT_EQ(snapshot_files(work_ / "old"), old);
  // An output that is a directory.
  fs::create_directories(work_ / "dir.h5");
  expect_input_error(run("run --restart a/out.checkpoint.h5 --output dir.h5 --end 2"), {"dir.h5"});
  EXPECT_FALSE(fs::exists(work_ / "dir.lock"));
}

TEST_F(RunFiles, TemporariesOfAKilledWriterAreRemovedOthersKept) {
  write_text(work_ / "c.toml", pinned("out.h5"));
  ASSERT_EQ(run("run c.toml -q").status, 0);
  // A pid that is gone: a child that has exited and been reaped.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  const std::string dead = ".out.checkpoint.h5.tmp." + std::to_string(child) + ".0";
  const std::string live = ".out.checkpoint.h5.tmp." + std::to_string(::getpid()) + ".3";  // this test: alive
  const std::string other = ".other.h5.tmp." + std::to_string(child) + ".0";              // not this run's file
  for (const std::string& n : {dead, live, other}) write_text(work_ / n, "half a checkpoint");
  ASSERT_EQ(run("run --restart out.checkpoint.h5 --end 1 -q").status, 0);
  EXPECT_FALSE(fs::exists(work_ / dead));
  EXPECT_TRUE(fs::exists(work_ / live));
  EXPECT_TRUE(fs::exists(work_ / other));
  EXPECT_FALSE(fs::exists(work_ / "out.lock"));
}

// 12. OUT.lock that is a FIFO used to block the run for good.
TEST_F(RunFiles, ALockThatIsNotAFileIsRefused) {
  write_text(work_ / "c.toml", pinned("out.h5"));
  ASSERT_EQ(::mkfifo((work_ / "out.lock").c_str(), 0600), 0);
  const auto before = snapshot_files(work_);
  expect_input_error(run("run c.toml", 20), {"out.lock", "not a regular file"});
  EXPECT_EQ(snapshot_files(work_), before);
}

// ---------------------------------------------------------------------------------------------------------------
// 13. Smaller findings.

// SIGUSR1 used to kill a plain run (exit 138, no checkpoint); docs/sweeps.md lists it with SIGINT and SIGTERM.
TEST_F(RunFiles, SigusrOneCheckpointsAPlainRun) {
  write_text(work_ / "c.toml", pinned("out.h5"));
  const std::string cmd = "cd " + shell_quote(work_.string()) + " && (OMP_NUM_THREADS=2 " +
                          shell_quote(capsflow::test::capsflow_binary_path()) +
                          " run c.toml --progress 0 --end 1000 2>err.txt & p=$!; sleep 3; kill -USR1 $p; wait $p; echo $? > st.txt)";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  EXPECT_EQ(test::slurp_file(work_ / "st.txt"), "138\n") << test::slurp_file(work_ / "err.txt");
  const std::string err = test::slurp_file(work_ / "err.txt");
  EXPECT_NE(err.find("interrupted (SIGUSR1)"), std::string::npos) << err;
  // The summary names the command that draws the run's diagnostics, for an interrupted run too (issue 25).
  EXPECT_NE(err.find("capsflow figures out.h5 --out DIR"), std::string::npos) << err;
  EXPECT_TRUE(fs::exists(work_ / "out.checkpoint.h5"));
  EXPECT_FALSE(fs::exists(work_ / "out.lock"));
}

TEST_F(RunFiles, CommandLineFindings) {
  const auto before = snapshot_files(work_);
  expect_input_error(run("--bogus"), {"unknown option '--bogus'", "run", "--help"});
  // A 120 000-character value is not echoed whole.
  const CliResult r = run("run --dry-run --set time.end=" + std::string(120000, '9') + "x");
  expect_input_error(r, {"--set time.end", "characters left out"});
  EXPECT_LT(r.err.size(), 1200u);
  // Standard output on a full device: the promised output did not arrive.
  for (const char* args : {"info", "run --dry-run", "run --print-demo-config"}) {
    const CliResult full = run_capsflow(work_, args, 60, "OMP_NUM_THREADS=2", "2>" + shell_quote((work_.parent_path() /
                                                                                              "full.err").string()) +
                                                                                  " >/dev/full");
    EXPECT_EQ(full.status, 1) << args;
    EXPECT_NE(test::slurp_file(work_.parent_path() / "full.err").find("cannot write to standard output"),
              std::string::npos)
        << args;
  }
  EXPECT_EQ(snapshot_files(work_), before);
}

TEST_F(RunFiles, GreenOnAFullDiskExitsOne) {
  SmallTmpfs fsys(tmp_.path / "tiny", "64k");
  if (!fsys.mounted) GTEST_SKIP() << fsys.why;
  write_text(fsys.dir / "filler", std::string(60000, 'x'));
  write_text(work_ / "g.toml", "[domain]\nH = 4.0\nLx = 8.0\nLz = 8.0\n[ggem]\nalpha = 4.0\n");
  write_text(work_ / "s.csv", "x,y,z,fx,fy,fz\n4.0,2.0,4.0,1.0,0.0,0.0\n");
  std::string targets = "x,y,z\n";
  for (int i = 0; i < 400; ++i) targets += "4.5," + std::to_string(0.5 + 0.005 * i) + ",4.0\n";
  write_text(work_ / "t.csv", targets);
  const CliResult r =
      run("green g.toml --sources s.csv --targets t.csv -q --out " + shell_quote((fsys.dir / "u.csv").string()));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(fsys.dir / "u.csv"));
}

TEST(RunFilesUnit, ConfigurationFindings) {
  // A species name with a control character (it made the SVG malformed) is refused, shown escaped.
  const std::string bell = pinned("o.h5", "", "a\\u0007b");
  try {
    parse_config(bell, "bell.toml");
    ADD_FAILURE() << "accepted a control character in a species name";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("[[species]] 1 name"), std::string::npos) << m;
    EXPECT_NE(m.find("\\x07"), std::string::npos) << m;
  }
  // Two capsules exactly 2a + min_gap apart (2.02 used to be refused as 2.019999999999999 < 2.02).
  const std::string two =
      "[domain]\nH = 6.0\nLx = 12.0\nLz = 8.0\n[flow]\ntype = \"shear\"\n[[species]]\nname = \"a\"\nca = 0.2\n"
      "[[capsule]]\nspecies = \"a\"\ncenter = [3.3, 3.0, 4.0]\n[[capsule]]\nspecies = \"a\"\n"
      "center = [5.32, 3.0, 4.0]\n[time]\nend = 1.0\n[output]\nfile = \"o.h5\"\n";
  EXPECT_NO_THROW(validate_run_config(parse_config(two, "two.toml")));
  // A memory request names the key that made it: an explicit grid size, or the capsules.
  Config c = parse_config(pinned("o.h5"), "m.toml");
  c.ggem.nx = 4096;
  const RunSize s = run_size(c);
  const MemoryLimit tiny{1 << 20, "a test limit"};
  try {
    check_memory_fits(c, s, estimate_memory(s), tiny);
    ADD_FAILURE() << "no memory error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("[ggem] nx"), std::string::npos) << e.what();
  }
}

}  // namespace
