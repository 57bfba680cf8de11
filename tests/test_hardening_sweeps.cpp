// Hardening of `capsflow sweep` and `capsflow analyze` (the hardening issue's findings 6, 7, 8, 10, 11 and 13): each
// test feeds the input or fault that used to inject a command into a Slurm script, pool one run twice, report an
// unfinished sweep as done, write files before a refusal, block a rerun after a full disk or exhaust the memory, and
// asserts what docs/sweeps.md and docs/analysis.md promise: exit 2 with one line naming the key, option or file, and
// every input and earlier output unchanged.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "host/base/thread_limits.hpp"
#include "host/cli/sweep.hpp"
#include "host/run/run_marker.hpp"
#include "support/cli_runner.hpp"
#include "support/small_run.hpp"
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
using capsflow::test::slurp_file;
using capsflow::test::snapshot_files;
using capsflow::test::TempDir;

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}


// One pinned level-1 capsule in shear, to strain 0.3, with its output at `file`.
std::string pinned_run(const std::string& file) {
  return "[domain]\nH = 6.0\nLx = 8.0\nLz = 8.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"serial\"\n[flow]\n"
         "type = \"shear\"\n[capsules]\nmesh_level = 1\n[[species]]\nname = \"a\"\nca = 0.2\n[[capsule]]\n"
         "species = \"a\"\ncenter = [4.0, 3.0, 4.0]\npinned = true\n[time]\nend = 0.3\n[output]\nfile = \"" + file +
         "\"\nevery = 0.02\nframes_every = 0.1\nprofile_bins = 50\n";
}

// An input error as the docs promise it: status 2, one line `capsflow: error: ...` naming every one of `parts`.
class HardeningSweeps : public testing::Test {
 protected:
  void SetUp() override {
    if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
    work_ = tmp_.path / "work";
    fs::create_directories(work_);
    write_text(work_ / "base.toml", capsflow::test::sweep_base_text());
  }
  CliResult run(const std::string& args, int timeout_s = 120) const { return run_capsflow(work_, args, timeout_s); }
  // Everything below the test's temporary directory (the work directory and anything a command wrote beside it).
  std::map<std::string, std::string> everything() const {
    auto m = snapshot_files(tmp_.path);
    // run_capsflow's own capture files.
    for (auto it = m.begin(); it != m.end();)
      it = it->first.rfind("work.std", 0) == 0 ? m.erase(it) : std::next(it);
    return m;
  }
  TempDir tmp_;
  fs::path work_;
};

// ---------------------------------------------------------------------------------------------------------------
// 6. The Slurm script is built from checked values only.

TEST_F(HardeningSweeps, SlurmNameMustBeASafeToken) {
  const auto before = everything();
  // A line break in the name would end the #SBATCH directives and run the next line as a command.
  write_text(work_ / "nl.toml", "base = \"base.toml\"\nroot = \"out\"\nname = \"x\\ntouch pwned\"\n"
                                "[[point]]\nsuspension.seed = 2\n");
  for (const char* verb : {"--slurm", "--plan"})
    expect_input_error(run(std::string("sweep nl.toml ") + verb),
                       {"nl.toml: name", "A-Z a-z 0-9 . _ + -", "x\\ntouch pwned"});
  // A name with a path in it would put the script outside ROOT/slurm/.
  write_text(work_ / "up.toml", "base = \"base.toml\"\nroot = \"out\"\nname = \"../../escape\"\n"
                                "[[point]]\nsuspension.seed = 2\n");
  expect_input_error(run("sweep up.toml --slurm"), {"up.toml: name", "../../escape", "starting with a letter"});
  write_text(work_ / "dot.toml", "base = \"base.toml\"\nroot = \"out\"\nname = \".hidden\"\n"
                                 "[[point]]\nsuspension.seed = 2\n");
  expect_input_error(run("sweep dot.toml --slurm"), {"dot.toml: name"});
  write_text(work_ / "num.toml", "base = \"base.toml\"\nroot = \"out\"\nname = 3\n[[point]]\nsuspension.seed = 2\n");
  expect_input_error(run("sweep num.toml --slurm"), {"num.toml: name", "not a string"});
  // Without `name`, the file's stem is the name: one that is not a token is refused by --slurm, with the way out.
  write_text(work_ / "my study.toml", "base = \"base.toml\"\nroot = \"out\"\n[[point]]\nsuspension.seed = 2\n");
  expect_input_error(run("sweep 'my study.toml' --slurm"), {"my study.toml: name", "'my study'", "add name ="});
  for (const char* f : {"nl.toml", "up.toml", "dot.toml", "num.toml", "my study.toml"}) fs::remove(work_ / f);
  EXPECT_EQ(everything(), before);
}

TEST_F(HardeningSweeps, SlurmOptionValuesCannotBreakTheScript) {
  write_text(work_ / "s.toml", "base = \"base.toml\"\nroot = \"out\"\nname = \"study\"\n[[product]]\n"
                               "suspension.seed = [1, 2]\n");
  const auto before = everything();
  const std::string cmd = "sweep s.toml --slurm ";
  expect_input_error(run(cmd + "--sbatch-extra " + shell_quote("--qos=long\ntouch pwned")),
                     {"--sbatch-extra", "one line", "--qos=long\\ntouch pwned"});
  expect_input_error(run(cmd + "--sbatch-extra " + shell_quote("qos=long")), {"--sbatch-extra", "starting with '-'"});
  expect_input_error(run(cmd + "--partition " + shell_quote("cpu\ntouch pwned")),
                     {"--partition", "cpu\\ntouch pwned"});
  expect_input_error(run(cmd + "--partition " + shell_quote("cpu gpu")), {"--partition", "'cpu gpu'"});
  expect_input_error(run(cmd + "--account " + shell_quote("proj\r")), {"--account", "proj\\r"});
  expect_input_error(run(cmd + "--account " + shell_quote("a;b")), {"--account"});
  expect_input_error(run(cmd + "--mem " + shell_quote("4G\nexit")), {"--mem", "4G\\nexit"});
  expect_input_error(run(cmd + "--mem 4GB"), {"--mem", "K M G T"});
  EXPECT_EQ(everything(), before) << "a refused --slurm writes nothing";

  // A root that an #SBATCH line cannot carry (whitespace, quotes, '%', control characters): refused by --slurm only.
  write_text(work_ / "sp.toml", "base = \"base.toml\"\nroot = \"out dir\"\nname = \"study\"\n[[point]]\n"
                                "suspension.seed = 2\n");
  write_text(work_ / "pct.toml", "base = \"base.toml\"\nroot = \"out%x\"\nname = \"study\"\n[[point]]\n"
                                 "suspension.seed = 2\n");
  write_text(work_ / "cr.toml", "base = \"base.toml\"\nroot = \"out\\nx\"\nname = \"study\"\n[[point]]\n"
                                "suspension.seed = 2\n");
  const auto with_roots = everything();
  expect_input_error(run("sweep sp.toml --slurm"), {"sp.toml: root", "#SBATCH --output", "out dir/slurm"});
  expect_input_error(run("sweep pct.toml --slurm"), {"pct.toml: root", "'%'"});
  expect_input_error(run("sweep cr.toml --slurm"), {"cr.toml: root", "out\\nx/slurm"});
  EXPECT_EQ(run("sweep sp.toml --plan").status, 0);
  EXPECT_EQ(everything(), with_roots);
  for (const char* f : {"sp.toml", "pct.toml", "cr.toml"}) fs::remove(work_ / f);

  // Good values: each on its own #SBATCH line, every directive before the first command.
  const CliResult ok = run(cmd + "--partition cpu,gpu --account proj_1 --mem 16G --sbatch-extra " +
                           shell_quote("--qos=long"));
  ASSERT_EQ(ok.status, 0) << ok.err;
  const std::string sh = slurp_file(work_ / "out" / "slurm" / "study.sbatch");
  for (const char* line : {"#SBATCH --job-name=study\n", "#SBATCH --partition=cpu,gpu\n", "#SBATCH --account=proj_1\n",
                           "#SBATCH --mem=16G\n", "#SBATCH --qos=long\n", "#SBATCH --requeue\n"})
    EXPECT_NE(sh.find(line), std::string::npos) << line << " not in:\n" << sh;
  std::istringstream lines(sh);
  std::string l;
  bool command_seen = false;
  int directives_after_command = 0;
  while (std::getline(lines, l)) {
    if (l.rfind("#SBATCH ", 0) == 0) {
      directives_after_command += command_seen;
    } else if (!l.empty() && l[0] != '#') {
      command_seen = true;
      EXPECT_TRUE(l.rfind("export OMP_NUM_THREADS=", 0) == 0 || l.rfind("exec '", 0) == 0) << l;
    }
  }
  EXPECT_EQ(directives_after_command, 0) << sh;
  EXPECT_FALSE(fs::exists(work_ / "pwned"));
}

// ---------------------------------------------------------------------------------------------------------------
// 7. One run, given twice (the same file, a directory and a file in it, a copy), is refused.

TEST_F(HardeningSweeps, AnalyzeRefusesTheSameRunTwice) {
  write_text(work_ / "pin.toml", pinned_run("s/out.h5"));
  fs::create_directories(work_ / "s");
  ASSERT_EQ(run("run pin.toml -q").status, 0);
  fs::create_directories(work_ / "copy");
  fs::copy_file(work_ / "s" / "out.h5", work_ / "copy" / "out.h5");
  const auto before = everything();
  expect_input_error(run("analyze s/out.h5 s/out.h5 --out a -q"), {"s/out.h5: the same run is given twice", "run id"});
  expect_input_error(run("analyze s s/out.h5 --out a -q"), {"s/out.h5: the same run is given twice"});
  expect_input_error(run("analyze s/out.h5 ./s/out.h5 --out a -q"),
                     {"s/out.h5 and ./s/out.h5 are the same run", "run id"});
  expect_input_error(run("analyze s copy --out a -q"), {"s/out.h5 and copy/out.h5 are the same run", "run id"});
  expect_input_error(run("analyze . --out a -q"), {"are the same run"});
  EXPECT_EQ(everything(), before);
  // Each run once: analysed.
  const CliResult ok = run("analyze s --out a -q");
  EXPECT_EQ(ok.status, 0) << ok.err;
  EXPECT_TRUE(fs::exists(work_ / "a" / "summary.json"));
}

// ---------------------------------------------------------------------------------------------------------------
// 8. --local's exit status tells a finished sweep from one with a point still running elsewhere.

// Field 22 of /proc/PID/stat (the process's start time), as run_marker.cpp reads it.
unsigned long long start_ticks_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  const std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream rest(s.substr(s.rfind(')') + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i) rest >> field;
  return std::stoull(field);
}

TEST_F(HardeningSweeps, LocalExitsFourWhileAPointRunsElsewhere) {
  write_text(work_ / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\nsuspension.seed = [1, 2]\n");
  // Point 1 "runs elsewhere": its marker names a live process of this host (a sleep) with its real start time.
  const pid_t other = ::fork();
  if (other == 0) {
    ::execlp("sleep", "sleep", "120", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ASSERT_GT(other, 0);
  struct Reap {
    pid_t pid;
    ~Reap() {
      if (pid <= 0) return;  // never kill(-1, ...)
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
  } reap{other};
  unsigned long long ticks = 0;
  for (int i = 0; i < 100 && ticks == 0; ++i) {  // until the child has exec'd (its stat is readable)
    ::usleep(20000);
    ticks = start_ticks_of(other);
  }
  const fs::path lock = work_ / "out" / "seed-2" / "output.lock";
  char marker[512];
  std::snprintf(marker, sizeof marker,
                "run_id = elsewhere\npid = %d\nhost = %s\nstart_ticks = %llu\nstarted = %.3f\nheartbeat = %.3f\n"
                "strain = 0.1\nend = 0.3\nslurm_job = \n",
                static_cast<int>(other), this_host().c_str(), ticks, epoch_seconds(), epoch_seconds());
  write_text(lock, marker);
  ASSERT_EQ(marker_owner(*read_run_marker(lock)), MarkerOwner::Live);

  const CliResult first = run("sweep s.toml --local");
  EXPECT_EQ(first.status, kSweepExitNotDone) << first.out << first.err;
  EXPECT_NE(first.out.find("seed-2: running elsewhere, skipped"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("1 not done (1 running)"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("exit 4"), std::string::npos) << first.out;
  // The point that runs elsewhere is left alone; the other is done.
  EXPECT_EQ(slurp_file(lock), marker);
  EXPECT_EQ(std::distance(fs::directory_iterator(work_ / "out" / "seed-2"), fs::directory_iterator()), 1);
  EXPECT_NE(run("sweep s.toml --status").out.find("0    done"), std::string::npos);
  // So `sweep --local && analyze` does not analyse the unfinished sweep.
  const CliResult chained = run_capsflow(
      work_, "sweep s.toml --local >/dev/null && " + shell_quote(capsflow::test::capsflow_binary_path()) +
                 " analyze out --out an -q");
  EXPECT_EQ(chained.status, kSweepExitNotDone);
  EXPECT_FALSE(fs::exists(work_ / "an"));

  // The other process dies (its marker stays behind, dead): the rerun continues the point, and only then exit 0.
  ::kill(other, SIGKILL);
  ::waitpid(other, nullptr, 0);
  reap.pid = -1;
  const CliResult second = run("sweep s.toml --local");
  EXPECT_EQ(second.status, 0) << second.out << second.err;
  EXPECT_NE(second.out.find("now 2 of 2 done"), std::string::npos) << second.out;
}

// ---------------------------------------------------------------------------------------------------------------
// 10. --task and --local check everything before they write the point's first file.

TEST_F(HardeningSweeps, TaskAndLocalRefuseBeforeWritingThePoint) {
  write_text(work_ / "s.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\nsuspension.seed = [1, 2]\n");
  const auto before = everything();
  const ThreadLimits lim = thread_limits();
  if (lim.hard > 0 && lim.hard < 100000000) {
    const std::string too_many = std::to_string(lim.hard + 1);
    expect_input_error(run("sweep s.toml --task 0 --threads " + too_many), {"--threads", std::to_string(lim.hard)});
    expect_input_error(run("sweep s.toml --local --threads " + too_many), {"--threads", std::to_string(lim.hard)});
    EXPECT_EQ(everything(), before) << "no config.toml, run.log or result of a refused point";
  }
  // A point whose output is a symbolic link: refused before its config.toml and log, the link's target not made.
  fs::create_directories(work_ / "out" / "seed-1");
  fs::create_symlink(tmp_.path / "elsewhere.h5", work_ / "out" / "seed-1" / "output.h5");
  const auto with_link = everything();
  expect_input_error(run("sweep s.toml --task 0"), {"seed-1/output.h5", "symbolic link"});
  expect_input_error(run("sweep s.toml --local"), {"seed-1/output.h5", "symbolic link"});
  EXPECT_EQ(everything(), with_link);
  EXPECT_FALSE(fs::exists(tmp_.path / "elsewhere.h5"));
  EXPECT_FALSE(fs::exists(work_ / "out" / "seed-2"));
}

// ---------------------------------------------------------------------------------------------------------------
// 11. An analysis that fails on a full disk leaves nothing that blocks its rerun, and never half an analysis.

TEST_F(HardeningSweeps, AnalyzeOnAFullDiskLeavesNothingThatBlocksTheRerun) {
  SmallTmpfs disk(tmp_.path / "small", "4m");
  if (!disk.mounted) GTEST_SKIP() << disk.why;
  write_text(work_ / "pin.toml", pinned_run("s/out.h5"));
  fs::create_directories(work_ / "s");
  ASSERT_EQ(run("run pin.toml -q").status, 0);
  // The sizes of a complete analysis, in pages.
  ASSERT_EQ(run("analyze s --out full -q").status, 0);
  const std::size_t page = 4096;
  auto pages = [&](const fs::path& p) { return (fs::file_size(p) + page - 1) / page; };
  const std::size_t h5_pages = pages(work_ / "full" / "analysis.h5");
  ASSERT_GT(h5_pages, 0u);

  const fs::path out = disk.dir / "m" / "a";
  int failed = 0;
  for (std::size_t free_pages : {std::size_t{0}, h5_pages / 2, h5_pages, h5_pages + 1, h5_pages + 2, h5_pages + 3}) {
    SCOPED_TRACE("free pages " + std::to_string(free_pages));
    disk.leave_free(free_pages * page);
    const CliResult r = run("analyze s --out " + shell_quote(out.string()) + " -q");
    if (r.status == 0) {
      fs::remove_all(disk.dir / "m");
      continue;
    }
    ++failed;
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    // Nothing left: no analysis, no temporary, not even the directories the analysis made.
    EXPECT_FALSE(fs::exists(disk.dir / "m")) << (fs::exists(out) ? snapshot_files(out).size() : 0u);
    // Room again: the rerun is not refused ("holds an earlier analysis"): it analyses.
    fs::remove(disk.dir / "filler");
    const CliResult again = run("analyze s --out " + shell_quote(out.string()) + " -q");
    EXPECT_EQ(again.status, 0) << again.err;
    EXPECT_EQ(slurp_file(out / "curves.csv"), slurp_file(work_ / "full" / "curves.csv"));
    fs::remove_all(disk.dir / "m");
  }
  EXPECT_GE(failed, 3) << "the disk never filled";

  // --force over a complete analysis on a full disk: the earlier analysis stays whole.
  ASSERT_EQ(run("analyze s --out " + shell_quote(out.string()) + " -q").status, 0);
  const auto earlier = snapshot_files(disk.dir / "m");
  disk.leave_free(0);
  const CliResult forced = run("analyze s --out " + shell_quote(out.string()) + " --force -q");
  EXPECT_EQ(forced.status, 1) << forced.err;
  EXPECT_EQ(snapshot_files(disk.dir / "m"), earlier);
}

// ---------------------------------------------------------------------------------------------------------------
// 13. A product beyond the bound is refused by its size, before it is enumerated.

std::string values(int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + std::to_string(i);
  return s + "]";
}

TEST_F(HardeningSweeps, HugeProductIsRefusedBeforeItIsEnumerated) {
  write_text(work_ / "big.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\nsuspension.seed = " +
                                     values(1000) + "\noutput.every = " + values(1000) + "\ntime.end = " +
                                     values(1000) + "\n");
  const auto before = everything();
  // Refused from the product's sizes, before any point is made: the message names the sizes and the limit (no
  // clock: enumerating 10^9 points would not end inside the child's limit, which fails the run).
  expect_input_error(run("sweep big.toml --plan", 60),
                     {"big.toml: [[product]] 1", "1000 x 1000 x 1000", std::to_string(kMaxSweepPoints)});
  // Blocks add up: two products of 6000 and 5000 points.
  write_text(work_ / "sum.toml", "base = \"base.toml\"\nroot = \"out\"\n[[product]]\nsuspension.seed = " +
                                     values(60) + "\ntime.end = " + values(100) + "\n[[product]]\noutput.every = " +
                                     values(50) + "\ntime.end = " + values(100) + "\n");
  expect_input_error(run("sweep sum.toml --local"), {"sum.toml: [[product]] 2", std::to_string(kMaxSweepPoints)});
  fs::remove(work_ / "sum.toml");
  EXPECT_EQ(everything(), before);
}

}  // namespace
