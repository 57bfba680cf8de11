// capsflow sweep (docs/sweeps.md) and the run marker OUT.lock (run_marker.hpp): the sweep file's points and
// directory names; a two-run sweep with --local --jobs 2 that is interrupted, resumed without repeating finished
// work and continued bit for bit; --status; failed runs left failed; a changed point refused; capsflow analyze on a
// sweep's root; a killed start's leftovers replaced, a live run's output refused.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/run/checkpoint.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/errors.hpp"
#include "host/run/run_layout.hpp"
#include "host/run/run_marker.hpp"
#include "host/cli/sweep.hpp"
#include "host/base/build_info.hpp"
#include "kernels/backend.hpp"
#include "support/small_run.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace capsflow;

#ifndef CAPSFLOW_TEST_DEFAULT_BINARY
#define CAPSFLOW_TEST_DEFAULT_BINARY nullptr
#endif
#ifndef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
#define CAPSFLOW_TEST_DEFAULT_SOURCE_DIR ""
#endif
std::string capsflow_binary() {
  const char* v = std::getenv("CAPSFLOW_BINARY");
  if (v && *v) return v;
  return CAPSFLOW_TEST_DEFAULT_BINARY ? CAPSFLOW_TEST_DEFAULT_BINARY : "";
}


void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Result {
  int status = -1;
  std::string out, err;
};

class Sweeps : public testing::Test {
 protected:
  void SetUp() override {
    bin_ = capsflow_binary();
    if (bin_.empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
    write(dir() / "base.toml", test::sweep_base_text());
  }
  const fs::path& dir() const { return tmp_.path; }

  Result run(const std::string& args) const {
    const std::string cmd = "cd '" + dir().string() + "' && '" + bin_ + "' " + args + " >'" +
                            (dir() / "stdout.txt").string() + "' 2>'" + (dir() / "stderr.txt").string() + "'";
    const int raw = std::system(cmd.c_str());
    Result r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(dir() / "stdout.txt");
    r.err = slurp(dir() / "stderr.txt");
    return r;
  }
  // Starts `capsflow args...` in dir() (stdout and stderr to `log`); returns its pid.
  pid_t spawn(const std::vector<std::string>& args, const std::string& log) const {
    std::vector<std::string> a = {bin_};
    a.insert(a.end(), args.begin(), args.end());
    const pid_t pid = ::fork();
    if (pid == 0) {
      if (::chdir(dir().c_str()) != 0) ::_exit(99);
      const int fd = ::open((dir() / log).c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      std::vector<char*> argv;
      for (std::string& s : a) argv.push_back(s.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(98);
    }
    return pid;
  }
  static int wait_exit(pid_t pid) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  // Polls `ready` every 50 ms for up to `seconds`.
  template <class F>
  static bool wait_for(F ready, double seconds = 120.0) {
    const auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
      if (ready()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }

  std::string bin_;
  test::TempDir tmp_;
};

// ---- the sweep file --------------------------------------------------------------------------------------------

TEST_F(Sweeps, FileGivesProductsAndPointsWithReadableUniqueNames) {
  write(dir() / "s.toml", R"(base = "base.toml"
root = "out"
[set]
time.end = 0.5
[[product]]
suspension.fractions = [[1.0, 0.0], [0.25, 0.75]]
suspension.seed = [1, 2, 3]
[[point]]
species.b.ca = 0.45
[[point]]
species.2.ca = 0.45
capsules.inflation = 0.05
)");
  const Sweep s = load_sweep((dir() / "s.toml").string());
  ASSERT_EQ(s.points.size(), 8u);
  EXPECT_EQ(s.root, dir() / "out");
  EXPECT_EQ(s.name, "s");
  // Keys in alphabetical order, the last varying fastest.
  EXPECT_EQ(s.points[0].name, "fractions-1_0__seed-1");
  EXPECT_EQ(s.points[1].name, "fractions-1_0__seed-2");
  EXPECT_EQ(s.points[3].name, "fractions-0.25_0.75__seed-1");
  // "ca" is the last part of two different keys: both are written in full.
  EXPECT_EQ(s.points[6].name, "species.b.ca-0.45");
  EXPECT_EQ(s.points[7].name, "inflation-0.05__species.2.ca-0.45");
  // The overrides: [set] first, then the point's own.
  ASSERT_EQ(s.points[3].overrides.size(), 3u);
  EXPECT_EQ(s.points[3].overrides[0].key, "time.end");
  EXPECT_EQ(s.points[3].overrides[1].key, "suspension.fractions");
  EXPECT_EQ(s.points[3].overrides[1].value, "[0.25, 0.75]");
  EXPECT_EQ(s.points[3].overrides[2].value, "1");
  // Each point resolves to the base with its values.
  const Config c = point_config(s, s.points[3]);
  EXPECT_EQ(c.suspension->fractions, (std::vector<double>{0.25, 0.75}));
  EXPECT_EQ(c.suspension->seed, 1u);
  EXPECT_EQ(*c.time.end, 0.5);
  EXPECT_EQ(point_config(s, s.points[6]).species[1].ca, 0.45);
  EXPECT_EQ(point_config(s, s.points[7]).capsules.membrane.inflation, 0.05);
}

TEST_F(Sweeps, BadFilesAreRefusedNamingTheKey) {
  auto error_of = [&](const std::string& text) {
    write(dir() / "bad.toml", text);
    try {
      (void)load_sweep((dir() / "bad.toml").string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("root = \"o\"\n[[product]]\nsuspension.seed = [1]\n").find("base: required"), std::string::npos);
  EXPECT_NE(error_of("base = \"base.toml\"\n[[product]]\nsuspension.seed = [1]\n").find("root: required"),
            std::string::npos);
  EXPECT_NE(error_of("base = \"base.toml\"\nroot = \"o\"\n").find("no points"), std::string::npos);
  EXPECT_NE(error_of("base = \"base.toml\"\nroot = \"o\"\nbogus = 1\n[[point]]\na.b = 1\n").find("unknown key 'bogus'"),
            std::string::npos);
  EXPECT_NE(error_of("base = \"base.toml\"\nroot = \"o\"\n[[product]]\nsuspension.seed = []\n")
                .find("[[product]] 1 suspension.seed: expected a non-empty array"),
            std::string::npos);
  EXPECT_NE(error_of("base = \"base.toml\"\nroot = \"o\"\n[[product]]\nsuspension.seed = [1, 2]\n[[point]]\n"
                     "suspension.seed = 2\n")
                .find("[[point]] 1 repeats point 1"),
            std::string::npos);
  // A bad override gets the configuration's own message, naming the sweep file's key.
  write(dir() / "o.toml", "base = \"base.toml\"\nroot = \"o\"\n[[product]]\nsuspension.seed = [-1]\n");
  const Result r = run("sweep o.toml --plan");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("suspension.seed"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("o.toml"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir() / "o"));
}

TEST_F(Sweeps, ExampleSetASweepPlansEighteenRunsOfThePreset) {
  const char* src = std::getenv("CAPSFLOW_SOURCE_DIR");
  const std::string root = src && *src ? src : CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
  const fs::path file = fs::path(root) / "examples" / "sweeps" / "set_a.toml";
  const Sweep s = load_sweep(file.string());
  ASSERT_EQ(s.points.size(), 18u);
  EXPECT_EQ(s.root, (fs::path(root) / "runs" / "set_a").lexically_normal());
  EXPECT_EQ(s.points[4].name, "fractions-0.8_0.2__seed-2");
  for (const SweepPoint& p : s.points) {
    const Config c = point_config(s, p);
    EXPECT_EQ(*c.time.end, 2500.0);
    EXPECT_EQ(c.suspension->count, 50);
    EXPECT_EQ(c.species.size(), 2u);
    EXPECT_DOUBLE_EQ(c.suspension->fractions[0] + c.suspension->fractions[1], 1.0);
  }
  EXPECT_EQ(point_config(s, s.points[17]).suspension->fractions, (std::vector<double>{0.0, 1.0}));
  EXPECT_EQ(point_config(s, s.points[17]).suspension->seed, 3u);
  const Result plan = run("sweep '" + file.string() + "' --plan");
  ASSERT_EQ(plan.status, 0) << plan.err;
  EXPECT_NE(plan.out.find("18 run(s)"), std::string::npos) << plan.out;
  EXPECT_FALSE(fs::exists(s.root)) << "--plan writes nothing";
}

TEST_F(Sweeps, ExampleSeriesSweepHoldsTheIsolatedAndPairSeries) {
  const char* src = std::getenv("CAPSFLOW_SOURCE_DIR");
  const std::string root = src && *src ? src : CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
  const Sweep s = load_sweep((fs::path(root) / "examples" / "sweeps" / "series.toml").string());
  ASSERT_EQ(s.points.size(), 12u);
  EXPECT_EQ(s.points[3].name, "center-5.0775_2.53875_5.0775__species.1.ca-0.5");
  EXPECT_EQ(s.points[9].name, "pair__species.bottom.ca-0.2__species.top.ca-0.5");
  const Config iso = point_config(s, s.points[3]);
  ASSERT_EQ(iso.capsule_list.size(), 1u);
  EXPECT_TRUE(iso.capsule_list[0].pinned);
  EXPECT_EQ(iso.capsule_list[0].center[1], 2.53875);
  EXPECT_EQ(iso.species[0].ca, 0.5);
  const Config pair = point_config(s, s.points[9]);
  EXPECT_EQ(pair.species[pair.species_index("top")].ca, 0.5);
  EXPECT_EQ(pair.species[pair.species_index("bottom")].ca, 0.2);
  EXPECT_EQ(pair.capsule_list.size(), 2u);
}

// ---- a local sweep ---------------------------------------------------------------------------------------------

TEST_F(Sweeps, LocalSweepResumesWithoutRepeatingFinishedWork) {
  // Point 0 (seed 1) is short; point 1 (seed 2) runs to strain 40 and is interrupted on the way; point 2 fails: its
  // first step (0.082) passes dt_floor = 0.08, the deforming capsules' next steps (0.0795, ...) do not.
  // Strain 40: the run marker's strain is refreshed once a second, and this 2-capsule point covers about 7 strain
  // units a second on the 2-core VM, so a shorter point could end before the marker shows it past 0.3.
  write(dir() / "s.toml", R"(base = "base.toml"
root = "out"
[[point]]
suspension.seed = 1
[[point]]
suspension.seed = 2
time.end = 40.0
[[point]]
suspension.seed = 3
time.dt_floor = 0.08
)");
  // A point's directory is named from every key of its block.
  const fs::path a = dir() / "out" / "seed-1", b = dir() / "out" / "seed-2__end-40",
                 f = dir() / "out" / "seed-3__dt_floor-0.08";
  const Result plan = run("sweep s.toml --plan");
  ASSERT_EQ(plan.status, 0) << plan.err;
  EXPECT_NE(plan.out.find("out/seed-2__end-40"), std::string::npos) << plan.out;
  EXPECT_NE(plan.out.find("suggested Slurm time limit"), std::string::npos) << plan.out;
  EXPECT_FALSE(fs::exists(dir() / "out")) << "--plan writes nothing";

  const pid_t sweep = spawn({"sweep", "s.toml", "--local", "--jobs", "2"}, "local1.txt");
  // Interrupt the sweep once point 0 is done and point 1 has passed a checkpoint.
  ASSERT_TRUE(wait_for([&] {
    const std::optional<RunMarker> m = read_run_marker(b / "output.lock");
    return fs::exists(a / "result") && m && m->strain > 0.3;  // past its checkpoint at 0.25
  })) << slurp(dir() / "local1.txt");
  ::kill(sweep, SIGTERM);
  EXPECT_EQ(wait_exit(sweep), 128 + SIGTERM) << slurp(dir() / "local1.txt");
  EXPECT_FALSE(fs::exists(b / "output.lock")) << "the interrupted run ends cleanly";

  Result st = run("sweep s.toml --status");
  ASSERT_EQ(st.status, 0) << st.err;
  EXPECT_NE(st.out.find("0    done"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("1    interrupted"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("SIGTERM"), std::string::npos) << st.out;
  const std::string a_bytes = slurp(a / "output.h5");
  const auto a_time = fs::last_write_time(a / "output.h5");
  const double b_stopped = inspect_point(b, 40.0).strain.value();
  EXPECT_GT(b_stopped, 0.3);
  EXPECT_LT(b_stopped, 39.0);
  {
    // A point carried to another machine without its result file (tools/reproduction_runs.sh restore): the
    // checkpoint's strain, which the interrupt wrote at the strain the run stopped at.
    fs::rename(b / "result", b / "result.away");
    const PointStatus carried = inspect_point(b, 40.0);
    EXPECT_EQ(carried.state, PointState::Interrupted);
    ASSERT_TRUE(carried.strain.has_value());
    EXPECT_EQ(*carried.strain, b_stopped);
    EXPECT_NE(carried.message.find("checkpoint at strain"), std::string::npos) << carried.message;
    char six[32];
    std::snprintf(six, sizeof six, "%.6g", b_stopped);  // as --status prints it
    const Result shown = run("sweep s.toml --status");
    EXPECT_NE(shown.out.find(std::string("1    interrupted  strain ") + six), std::string::npos) << shown.out;
    fs::rename(b / "result.away", b / "result");
  }
  // A finished point carried without its result file: its checkpoint, taken at the end, is past [time] end, so it is
  // done (continuing it would be refused: an end below the checkpoint's strain), and the rerun below skips it.
  fs::rename(a / "result", a / "result.away");
  EXPECT_EQ(inspect_point(a, 0.3).state, PointState::Done);

  // Rerun: point 0 is skipped, point 1 continues from its checkpoint, point 2 stays failed or, if the signal came
  // before its first step was taken, continues and fails now. (Before the signal waited for the next step's plan,
  // a signal during its first step left an interrupted checkpoint that the first-step check refused: exit 2, seen
  // under ASan in CI.)
  Result again = run("sweep s.toml --local --jobs 2");
  EXPECT_EQ(again.status, 3) << again.out << again.err;  // point 2 failed (dt below its floor): exit 3
  EXPECT_NE(again.out.find("seed-1: done, skipped"), std::string::npos) << again.out;
  fs::rename(a / "result.away", a / "result");
  EXPECT_EQ(slurp(a / "output.h5"), a_bytes);
  EXPECT_EQ(fs::last_write_time(a / "output.h5"), a_time);
  const std::string b_log = slurp(b / "run.log");
  EXPECT_NE(b_log.find("continue from checkpoint"), std::string::npos) << b_log;
  // Which build ran each part of a continued run: every start and continuation names it.
  EXPECT_NE(b_log.find(std::string("(commit ") + build_commit() + "))"), std::string::npos) << b_log;
  EXPECT_NE(b_log.find("continuing from strain"), std::string::npos) << b_log;

  // The continued run equals an uninterrupted run of the same point, bit for bit.
  fs::create_directories(dir() / "ref");
  const Result ref = run("run out/seed-2__end-40/config.toml --output ref/ref.h5 --progress 0 -q");
  ASSERT_EQ(ref.status, 0) << ref.err;
  const RunFile got = read_run_file(b / "output.h5"), want = read_run_file(dir() / "ref" / "ref.h5");
  ASSERT_EQ(got.records, want.records);
  EXPECT_GT(got.records, 50u);
  EXPECT_EQ(got.time, want.time);
  EXPECT_EQ(got.step, want.step);
  EXPECT_EQ(got.centroid, want.centroid);
  EXPECT_EQ(got.velocity, want.velocity);
  EXPECT_EQ(got.taylor_D, want.taylor_D);
  EXPECT_EQ(got.volume, want.volume);
  EXPECT_EQ(got.profile, want.profile);

  // The failed point stays failed (with its message) unless --retry-failed.
  st = run("sweep s.toml --status");
  EXPECT_NE(st.out.find("1    done"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("2    failed"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("dt-below-floor"), std::string::npos) << st.out;
  const auto f_time = fs::last_write_time(f / "result");
  const Result third = run("sweep s.toml --local --jobs 2");
  EXPECT_EQ(third.status, 3) << third.out;
  EXPECT_NE(third.out.find("seed-3__dt_floor-0.08: failed, skipped (--retry-failed)"), std::string::npos) << third.out;
  EXPECT_NE(third.out.find("0 run(s) to do"), std::string::npos) << third.out;
  EXPECT_EQ(fs::last_write_time(f / "result"), f_time);
  // Retried unchanged, it would stop again at once: its checkpoint's next step is below the floor. Refused before
  // anything is written (issue 24: the first step is checked before any file), naming the key.
  const Result retry = run("sweep s.toml --local --retry-failed");
  EXPECT_EQ(retry.status, 2) << retry.out << retry.err;
  EXPECT_NE(retry.err.find("dt_floor"), std::string::npos) << retry.err;
  EXPECT_EQ(fs::last_write_time(f / "result"), f_time);

  // --task on a finished point does nothing.
  const Result task = run("sweep s.toml --task 0");
  EXPECT_EQ(task.status, 0) << task.err;
  EXPECT_NE(task.out.find("nothing to do"), std::string::npos) << task.out;
  EXPECT_EQ(fs::last_write_time(a / "output.h5"), a_time);

  // capsflow analyze takes the sweep's root and groups its runs (seeds 1 and 2 of one composition: one group).
  const Result an = run("analyze out --out analysis -q");
  ASSERT_EQ(an.status, 0) << an.err;
  const std::string summary = slurp(dir() / "analysis" / "summary.json");
  EXPECT_NE(summary.find("seed-1/output.h5"), std::string::npos) << summary;
  EXPECT_NE(summary.find("seed-2__end-40/output.h5"), std::string::npos) << summary;
  EXPECT_EQ(summary.find("ref.h5"), std::string::npos);
}

TEST_F(Sweeps, StatusTellsARunningRunFromAKilledOne) {
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[set]\ntime.end = 50.0\n[[point]]\nsuspension.seed = 4\n");
  const fs::path d = dir() / "out" / "seed-4";
  const pid_t task = spawn({"sweep", "s.toml", "--task", "0"}, "task.txt");
  ASSERT_TRUE(wait_for([&] {
    const std::optional<RunMarker> m = read_run_marker(d / "output.lock");
    return m && m->strain > 0.3;
  })) << slurp(dir() / "task.txt");
  Result st = run("sweep s.toml --status");
  EXPECT_NE(st.out.find("0    running"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("pid " + std::to_string(task)), std::string::npos) << st.out;
  // A second task for the same point refuses to run over the live one.
  const Result twice = run("sweep s.toml --task 0");
  EXPECT_EQ(twice.status, 2);
  EXPECT_NE(twice.err.find("already running"), std::string::npos) << twice.err;
  ::kill(task, SIGKILL);
  EXPECT_EQ(wait_exit(task), 128 + SIGKILL);
  st = run("sweep s.toml --status");
  EXPECT_NE(st.out.find("0    killed"), std::string::npos) << st.out;
  // The killed run continues from its last checkpoint (a shorter end, a little past the checkpoint, which a fast
  // machine may have taken beyond strain 5: run control may change, an end below the checkpoint may not).
  char end[32];
  std::snprintf(end, sizeof end, "%.6f", read_checkpoint(d / "output.checkpoint.h5").state.time + 0.5);
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[set]\ntime.end = " + std::string(end) +
                              "\n[[point]]\nsuspension.seed = 4\n");
  const Result cont = run("sweep s.toml --task 0");
  EXPECT_EQ(cont.status, 0) << cont.err;
  EXPECT_NE(slurp(d / "run.log").find("continue from checkpoint"), std::string::npos);
  st = run("sweep s.toml --status");
  EXPECT_NE(st.out.find("0    done"), std::string::npos) << st.out;
}

TEST_F(Sweeps, ChangedPointConfigurationIsRefused) {
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\nsuspension.seed = [1, 2]\n");
  const Result ok = run("sweep s.toml --local --jobs 2");
  ASSERT_EQ(ok.status, 0) << ok.out << ok.err;
  // A run-control key may change: a longer end continues the finished runs.
  write(dir() / "s.toml",
        "base = \"base.toml\"\nroot = \"out\"\n[set]\ntime.end = 0.4\n[[product]]\nsuspension.seed = [1, 2]\n");
  Result st = run("sweep s.toml --status");
  ASSERT_EQ(st.status, 0) << st.err;
  // Neither interrupted nor done: extendable, saying how far it went and how far it goes.
  EXPECT_NE(st.out.find("0    extendable"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("reached its earlier [time] end, strain 0.3; continues to 0.4"), std::string::npos) << st.out;
  EXPECT_EQ(st.out.find("interrupted"), std::string::npos) << st.out;
  const Result longer = run("sweep s.toml --local --jobs 2");
  ASSERT_EQ(longer.status, 0) << longer.out << longer.err;
  EXPECT_NE(longer.out.find("2 run(s) to do"), std::string::npos) << longer.out;
  st = run("sweep s.toml --status");
  EXPECT_NE(st.out.find("0    done"), std::string::npos) << st.out;
  EXPECT_NE(st.out.find("1    done"), std::string::npos) << st.out;
  // A physics key may not: the directory holds another point.
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[set]\ncapsules.inflation = 0.05\n[[product]]\n"
                          "suspension.seed = [1, 2]\n");
  const auto before = fs::last_write_time(dir() / "out" / "seed-1" / "output.h5");
  for (const char* verb : {"--status", "--plan", "--local", "--task 1", "--slurm"}) {
    const Result r = run(std::string("sweep s.toml ") + verb);
    EXPECT_EQ(r.status, 2) << verb;
    EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("out/seed-1/config.toml: holds another configuration than point 0"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("inflation"), std::string::npos) << r.err;
  }
  EXPECT_EQ(fs::last_write_time(dir() / "out" / "seed-1" / "output.h5"), before);
  EXPECT_FALSE(fs::exists(dir() / "out" / "slurm"));
}

// Strips the [quadrature] table from a stored configuration text: what a build before issue 34 wrote at the
// default element rules.
std::string without_quadrature_table(std::string text) {
  const std::size_t at = text.find("[quadrature]");
  if (at == std::string::npos) return text;
  const std::size_t end = text.find("\n[", at + 1);
  text.erase(at, end == std::string::npos ? std::string::npos : end + 1 - at);
  return text;
}

TEST_F(Sweeps, PointOfAnEarlierBuildKeepsItsElementRules) {
  // A point run by a build before issue 34 (its config.toml and its checkpoint without a [quadrature] table: the
  // kernels' finer rules were the defaults) continues with those rules when the sweep asks for the defaults: not
  // refused, its config.toml then names them, and the continued run uses them; asking for other rules is refused.
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\nsuspension.seed = [1]\n");
  const Result ok = run("sweep s.toml --local");
  ASSERT_EQ(ok.status, 0) << ok.out << ok.err;
  const fs::path point = dir() / "out" / "seed-1";
  write(point / "config.toml", without_quadrature_table(slurp(point / "config.toml")));
  // The earlier build wrote its configuration so into the output and the checkpoint alike (and no digests: a
  // checkpoint without them is compared with its output's physics).
  for (const char* file : {"output.checkpoint.h5", "output.h5"}) {
    capsflow::H5File f = capsflow::H5File::open(point / file, capsflow::H5Access::ReadWrite);
    const std::string text = without_quadrature_table(f.read_string(capsflow::layout::kConfig));
    f.remove(capsflow::layout::kConfig);
    f.write_string(capsflow::layout::kConfig, text);
    if (f.exists("/state")) f.remove_attribute("/state", "digest");
  }
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[set]\ntime.end = 0.4\n[[product]]\n"
                          "suspension.seed = [1]\n");
  const Result st = run("sweep s.toml --status");
  ASSERT_EQ(st.status, 0) << st.err;
  const Result longer = run("sweep s.toml --local");
  ASSERT_EQ(longer.status, 0) << longer.out << longer.err;
  const std::string stored = slurp(point / "config.toml");
  EXPECT_NE(stored.find("[quadrature]"), std::string::npos) << stored;
  EXPECT_NE(stored.find("far_ratio = 2.5"), std::string::npos) << stored;
  EXPECT_NE(stored.find("kernel_degree = 17"), std::string::npos) << stored;
  const capsflow::Checkpoint ck = capsflow::read_checkpoint(point / "output.checkpoint.h5");
  EXPECT_TRUE(capsflow::checkpoint_config(ck, "ck").quadrature == capsflow::fine_quadrature());
  // Other rules for this point: refused, naming the table, before anything is written.
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[set]\ntime.end = 0.4\nquadrature.singular = 8\n"
                          "[[product]]\nsuspension.seed = [1]\n");
  const Result other = run("sweep s.toml --status");
  EXPECT_EQ(other.status, 2) << other.out;
  EXPECT_NE(other.err.find("holds another configuration than point 0"), std::string::npos) << other.err;
  EXPECT_NE(other.err.find("[quadrature]"), std::string::npos) << other.err;
}

TEST_F(Sweeps, OneStepRulePerSweep) {
  // Two rules in one sweep mix two numerical protocols in one study: refused before anything is written.
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\n"
                          "time.step_rule = [\"membrane\", \"paper\"]\n");
  for (const char* verb : {"--plan", "--local"}) {
    const Result r = run(std::string("sweep s.toml ") + verb);
    EXPECT_EQ(r.status, 2) << verb;
    EXPECT_NE(r.err.find("one rule per sweep"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir() / "out"));
  // One rule for all: the plan names it.
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[set]\ntime.step_rule = \"paper\"\n"
                          "[[product]]\nsuspension.seed = [1, 2]\n");
  const Result plan = run("sweep s.toml --plan");
  ASSERT_EQ(plan.status, 0) << plan.err;
  EXPECT_NE(plan.out.find("(step rule paper)"), std::string::npos) << plan.out;
}

TEST_F(Sweeps, SlurmScriptRunsOneTaskPerPointAndCheckpointsBeforeTheLimit) {
  write(dir() / "s.toml", "base = \"base.toml\"\nroot = \"out\"\nname = \"study\"\n[[product]]\n"
                          "suspension.seed = [1, 2, 3]\n");
  // GPUs per task only where the build has the device backend: elsewhere every task would be refused at its start.
  const std::string gpu_args = "sweep s.toml --slurm --partition gpu --gpus-per-task 1 --cpus-per-task 4 --time 1-00:00:00";
  if (!capsflow::device_backend_built()) {
    const Result no_gpu = run(gpu_args);
    EXPECT_EQ(no_gpu.status, 2) << no_gpu.err;
    EXPECT_NE(no_gpu.err.find("--gpus-per-task 1: expected 0"), std::string::npos) << no_gpu.err;
    EXPECT_FALSE(fs::exists(dir() / "out" / "slurm" / "study.sbatch"));
  }
  const Result r = run(capsflow::device_backend_built() ? gpu_args
                                                       : "sweep s.toml --slurm --partition gpu --cpus-per-task 4 "
                                                         "--time 1-00:00:00");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string sh = slurp(dir() / "out" / "slurm" / "study.sbatch");
  std::vector<std::string> lines = {"#SBATCH --array=0-2\n", "#SBATCH --partition=gpu\n",
                                    "#SBATCH --cpus-per-task=4\n", "#SBATCH --time=1-00:00:00\n",
                                    "#SBATCH --requeue\n", "#SBATCH --open-mode=append\n", "#SBATCH --signal=B:USR1@",
                                    "--task \"$SLURM_ARRAY_TASK_ID\"", "exec '"};
  if (capsflow::device_backend_built()) {
    lines.push_back("#SBATCH --gpus-per-task=1\n");
    lines.push_back("--backend device");
  }
  for (const std::string& line : lines) EXPECT_NE(sh.find(line), std::string::npos) << line << " not in:\n" << sh;
  const Result bad = run("sweep s.toml --slurm --time soon");
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("--time"), std::string::npos) << bad.err;
  // sbatch's forms are accepted (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS); others are not.
  for (const char* t : {"90", "30:00", "12:00:00", "2-12", "2-12:30", "2-12:30:00"})
    EXPECT_EQ(run(std::string("sweep s.toml --slurm --time ") + t).status, 0) << t;
  for (const char* t : {"1:2:3:4", "-5", "2-", "2-1:2:3:4", "12::00", "1h"})
    EXPECT_EQ(run(std::string("sweep s.toml --slurm --time ") + t).status, 2) << t;
  const Result task = run("sweep s.toml --task 3");
  EXPECT_EQ(task.status, 2);
  EXPECT_NE(task.err.find("from 0 to 2"), std::string::npos) << task.err;
}

// ---- the run marker --------------------------------------------------------------------------------------------

TEST_F(Sweeps, MarkerTellsLiveFromDead) {
  const fs::path p = dir() / "x.lock";
  {
    RunMarkerFile m(p, "id-1", 0.0, 5.0);
    const std::optional<RunMarker> r = read_run_marker(p);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->run_id, "id-1");
    EXPECT_EQ(r->pid, static_cast<long>(::getpid()));
    EXPECT_EQ(r->host, this_host());
    EXPECT_EQ(marker_owner(*r), MarkerOwner::Live);
    m.beat(1.5, true);
    EXPECT_EQ(read_run_marker(p)->strain, 1.5);
  }
  // The destructor removes the marker (an error or a refusal ends the process cleanly, issue 24) ...
  EXPECT_FALSE(fs::exists(p));
  // ... which only a process that is killed leaves behind: here one that ends with _exit (no destructors, no atexit).
  // A finished process (reaped), a zombie and a pid reused by another process all count as dead.
  const pid_t child = ::fork();
  if (child == 0) {
    RunMarkerFile left(p, "id-1", 0.0, 5.0);
    ::_exit(0);
  }
  ::usleep(200000);
  ASSERT_TRUE(read_run_marker(p)) << "the killed process's marker";
  RunMarker m = *read_run_marker(p);
  EXPECT_EQ(m.pid, static_cast<long>(child));
  m.start_ticks = 0;
  EXPECT_EQ(marker_owner(m), MarkerOwner::Dead) << "zombie";
  ::waitpid(child, nullptr, 0);
  EXPECT_EQ(marker_owner(m), MarkerOwner::Dead) << "reaped";
  m.pid = ::getpid();
  m.start_ticks = read_run_marker(p)->start_ticks + 1;
  EXPECT_EQ(marker_owner(m), MarkerOwner::Dead) << "reused pid";
  // On another host only the heartbeat tells.
  m.host = "elsewhere";
  m.heartbeat = epoch_seconds() - 10;
  EXPECT_EQ(marker_owner(m), MarkerOwner::Live);
  m.heartbeat = epoch_seconds() - 2 * kStaleSeconds;
  EXPECT_EQ(marker_owner(m), MarkerOwner::Dead);
  // A recent marker of this process's own Slurm job is that of the job's run before a requeue: dead.
  m.heartbeat = epoch_seconds() - 10;
  m.slurm_job = "4242";
  ::setenv("SLURM_JOB_ID", "4242", 1);
  EXPECT_EQ(marker_owner(m), MarkerOwner::Dead);
  ::setenv("SLURM_JOB_ID", "4243", 1);
  EXPECT_EQ(marker_owner(m), MarkerOwner::Live);
  ::unsetenv("SLURM_JOB_ID");
}

TEST_F(Sweeps, RunReplacesTheLeftoversOfAKilledStartAndRefusesALiveRunsOutput) {
  const std::string cfg = "base.toml --set output.file=r/run.h5 --progress 0 -q";
  fs::create_directories(dir() / "r");
  // A start killed before its first flush: an unreadable OUT.h5 and its dead marker.
  write(dir() / "r" / "run.h5", "not hdf5");
  write(dir() / "r" / "run.lock", "run_id = gone\nhost = " + this_host() + "\npid = 999999999\n");
  Result r = run("run " + cfg);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir() / "r" / "run.lock")) << "removed at the clean end";
  EXPECT_GE(read_run_file(dir() / "r" / "run.h5").records, 4u);

  // A dead marker beside another run's output: that output is not its leftover and is kept.
  write(dir() / "r" / "run.lock", "run_id = gone\nhost = " + this_host() + "\npid = 999999999\n");
  fs::rename(dir() / "r" / "run.checkpoint.h5", dir() / "r" / "kept.checkpoint.h5");
  r = run("run " + cfg);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("already exists"), std::string::npos) << r.err;
  // A dead marker with a checkpoint: the run is resumable, the message says how.
  fs::rename(dir() / "r" / "kept.checkpoint.h5", dir() / "r" / "run.checkpoint.h5");
  r = run("run " + cfg);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--restart"), std::string::npos) << r.err;

  // A live run's marker: refused, --force or not, and for a restart too.
  RunMarkerFile live(dir() / "r" / "run.lock", "live-id", 0.0, 1.0);
  for (const std::string& args : {"run " + cfg, "run " + cfg + " --force",
                                  std::string("run --restart r/run.checkpoint.h5 --progress 0 -q")}) {
    r = run(args);
    EXPECT_EQ(r.status, 2) << args;
    EXPECT_NE(r.err.find("in use by a live run, pid " + std::to_string(::getpid())), std::string::npos) << r.err;
  }
  live.release();
}

TEST_F(Sweeps, KilledRunLeavesItsMarkerAndTheRestartClearsIt) {
  fs::create_directories(dir() / "k");
  const pid_t pid = spawn({"run", "base.toml", "--set", "output.file=k/run.h5", "--set", "time.end=50",
                           "--progress", "0"},
                          "k.txt");
  ASSERT_TRUE(wait_for([&] {
    const std::optional<RunMarker> m = read_run_marker(dir() / "k" / "run.lock");
    return m && m->strain > 0.5;
  })) << slurp(dir() / "k.txt");
  ::kill(pid, SIGKILL);
  EXPECT_EQ(wait_exit(pid), 128 + SIGKILL);
  ASSERT_TRUE(fs::exists(dir() / "k" / "run.lock"));
  EXPECT_EQ(marker_owner(*read_run_marker(dir() / "k" / "run.lock")), MarkerOwner::Dead);
  // The run may have checkpointed well past 0.5 before the kill: continue a little beyond its checkpoint (an --end
  // below the checkpoint's strain is refused).
  char end[32];
  std::snprintf(end, sizeof end, "%.6f", read_checkpoint(dir() / "k" / "run.checkpoint.h5").state.time + 0.2);
  const Result r = run("run --restart k/run.checkpoint.h5 --end " + std::string(end) + " --progress 0 -q");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir() / "k" / "run.lock"));
}

// ---- the state files as JSON (run marker, sweep result) ---------------------------------------------------------

TEST_F(Sweeps, MarkerIsJsonWithTheDigitsItsNumbersCarry) {
  const fs::path p = dir() / "j.lock";
  RunMarkerFile m(p, "id-j", 0.0, 5.0);
  m.beat(0.1, true);
  const nlohmann::json j = nlohmann::json::parse(slurp(p));  // throws (fails the test) if not JSON
  for (const char* k : {"run_id", "host", "pid", "start_ticks", "started", "heartbeat", "strain", "end", "slurm_job"})
    EXPECT_TRUE(j.contains(k)) << k << " not in " << j.dump();
  EXPECT_EQ(j["run_id"], "id-j");
  EXPECT_EQ(j["pid"], static_cast<long>(::getpid()));
  // 0.1 is written as 0.1 (the shortest text of the double), not 0.10000000000000001, and reads back exactly.
  EXPECT_NE(slurp(p).find("\"strain\": 0.1,"), std::string::npos) << slurp(p);
  EXPECT_EQ(read_run_marker(p)->strain, 0.1);
  EXPECT_EQ(read_run_marker(p)->end, 5.0);
}

TEST_F(Sweeps, MarkerOfTheOlderTextFormatStillReads) {
  const fs::path p = dir() / "old.lock";
  write(p, "run_id = old-1\nhost = node7\npid = 4242\nstart_ticks = 99\nstarted = 1796000000.5\n"
           "heartbeat = 1796000100.25\nstrain = 12.5\nend = 100\nslurm_job = 77\n");
  const std::optional<RunMarker> m = read_run_marker(p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->run_id, "old-1");
  EXPECT_EQ(m->host, "node7");
  EXPECT_EQ(m->pid, 4242);
  EXPECT_EQ(m->start_ticks, 99u);
  EXPECT_EQ(m->heartbeat, 1796000100.25);
  EXPECT_EQ(m->strain, 12.5);
  EXPECT_EQ(m->slurm_job, "77");
  // A torn JSON marker reads as a dead one (no pid), as a torn text marker did.
  write(p, "{\"run_id\": \"x\", \"pid\": 12");
  ASSERT_TRUE(read_run_marker(p));
  EXPECT_EQ(read_run_marker(p)->pid, 0);
  EXPECT_EQ(marker_owner(*read_run_marker(p)), MarkerOwner::Dead);
}

TEST_F(Sweeps, ResultIsJsonAndRoundTrips) {
  const fs::path p = dir() / "result";
  SweepResult r;
  r.exit_code = 3;
  r.strain = 0.25;
  r.end = 1000.0070529793252;
  r.finished = 1796464020.9249797;
  r.message = "stopped: \"quoted\"\nsecond line";
  write_sweep_result(p, r);
  const nlohmann::json j = nlohmann::json::parse(slurp(p));
  EXPECT_EQ(j["exit_code"], 3);
  EXPECT_NE(slurp(p).find("\"strain\": 0.25,"), std::string::npos) << slurp(p);
  const std::optional<SweepResult> back = read_sweep_result(p);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->exit_code, 3);
  EXPECT_EQ(back->strain, 0.25);
  EXPECT_EQ(back->end, r.end);            // every digit the double carries
  EXPECT_EQ(back->finished, r.finished);
  EXPECT_EQ(back->message, "stopped: \"quoted\" second line");  // one line, as --status prints it
  write(p, "not json, not key = value either");
  EXPECT_EQ(read_sweep_result(p)->exit_code, 1) << "an unreadable result is a failed attempt";
}

// The results committed with the reproduction's runs (docs/reproduction/runs/*/*/result, the older text format) still
// read: each a run that reached its end (exit 0) or was interrupted by SIGINT (130) short of it, its message saying
// which.
TEST_F(Sweeps, CommittedResultsOfTheOlderFormatStillParse) {
  const char* env = std::getenv("CAPSFLOW_SOURCE_DIR");
  const fs::path src = env && *env ? fs::path(env) : fs::path(CAPSFLOW_TEST_DEFAULT_SOURCE_DIR);
  const fs::path runs = src / "docs" / "reproduction" / "runs";
  if (src.empty() || !fs::is_directory(runs)) GTEST_SKIP() << "no source tree with docs/reproduction/runs";
  int n = 0;
  for (const auto& sweep : fs::directory_iterator(runs))
    for (const auto& point : fs::directory_iterator(sweep.path())) {
      const fs::path f = point.path() / "result";
      if (!fs::is_regular_file(f)) continue;
      ++n;
      const std::optional<SweepResult> r = read_sweep_result(f);
      ASSERT_TRUE(r) << f;
      EXPECT_GT(r->strain, 0.0) << f;
      EXPECT_GT(r->end, 0.0) << f;
      EXPECT_GT(r->finished, 1.7e9) << f;  // epoch seconds of 2023 or later
      if (r->exit_code == 0) {
        EXPECT_GE(r->strain, r->end - 1e-6) << f;
        EXPECT_EQ(r->message.rfind("reached strain ", 0), 0u) << f << ": " << r->message;
      } else {
        EXPECT_EQ(r->exit_code, 130) << f;
        EXPECT_LT(r->strain, r->end) << f;
        EXPECT_EQ(r->message.rfind("interrupted (SIGINT) at strain ", 0), 0u) << f << ": " << r->message;
      }
    }
  EXPECT_GE(n, 1) << "no committed result under " << runs;
}

}  // namespace
