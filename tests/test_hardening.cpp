// Extremes and faults (issue 13): each test feeds one input or fault that used to crash, hang, return wrong numbers
// with exit 0, fail after writing, or damage a file, and asserts the behaviour the docs promise.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "host/base/atomic_file.hpp"
#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/base/h5_file.hpp"
#include "host/run/run_driver.hpp"
#include "host/run/run_layout.hpp"
#include "host/run/stop_signal.hpp"
#include "host/base/thread_limits.hpp"
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

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

const char* kGreenConfig = "[domain]\nH = 4.0\nLx = 8.0\nLz = 8.0\n[ggem]\nalpha = 4.0\n";
const char* kSources = "x,y,z,fx,fy,fz\n4.0,2.0,4.0,1.0,0.0,0.0\n2.0,1.0,6.0,0.0,1.0,0.0\n";
const char* kTargets = "x,y,z\n4.5,2.0,4.0\n7.25,1.75,0.5\n";

// One pinned capsule at mid-height in shear: its height never changes (the case that hung the end-of-run plot).
std::string pinned_shear(const std::string& extra_time = "", const std::string& file = "pin/pin.h5") {
  return "[domain]\nH = 6.0\nLx = 8.0\nLz = 8.0\n[ggem]\nalpha = 4.0\n[flow]\ntype = \"shear\"\n[capsules]\n"
         "mesh_level = 1\n[[species]]\nname = \"a\"\nca = 0.2\n[[capsule]]\nspecies = \"a\"\n"
         "center = [4.0, 3.0, 4.0]\npinned = true\n[time]\nend = 0.3\n" + extra_time +
         "[output]\nfile = \"" + file + "\"\nevery = 0.1\nframes_every = 0.1\n";
}

class Hardening : public testing::Test {
 protected:
  void SetUp() override {
    if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
    work_ = tmp_.path / "work";
    fs::create_directories(work_);
    write_text(work_ / "cfg.toml", kGreenConfig);
    write_text(work_ / "sources.csv", kSources);
    write_text(work_ / "targets.csv", kTargets);
  }
  CliResult run(const std::string& args, int timeout_s = 120) const { return run_capsflow(work_, args, timeout_s); }
  CliResult green(const std::string& extra) const {
    return run("green cfg.toml --sources sources.csv --targets targets.csv --out U.csv " + extra);
  }
  TempDir tmp_;
  fs::path work_;
};

// ---------------------------------------------------------------------------------------------------------------
// Crashes

TEST_F(Hardening, ThreadCountsBeyondWhatCanBeCreatedAreRefused) {
  const ThreadLimits lim = thread_limits();
  ASSERT_GT(lim.hard, 0) << "no bound found on this machine";
  const std::string too_many = std::to_string(lim.hard + 1);
  const auto before = snapshot_files(work_);
  expect_input_error(green("--backend threads --threads " + too_many), {"--threads", std::to_string(lim.hard)});
  write_text(work_ / "threads.toml", std::string(kGreenConfig) + "[run]\nbackend = \"threads\"\nthreads = " +
                                         too_many + "\n");
  expect_input_error(run("green threads.toml --sources sources.csv --targets targets.csv --out U.csv"),
                     {"threads.toml: [run] threads", std::to_string(lim.hard)});
  expect_input_error(run("demo --out d --threads " + too_many), {"--threads"});
  write_text(work_ / "run.toml", pinned_shear());
  expect_input_error(run("run run.toml --backend threads --threads " + too_many), {"--threads"});
  fs::remove(work_ / "threads.toml");
  fs::remove(work_ / "run.toml");
  EXPECT_EQ(snapshot_files(work_), before);
}

TEST_F(Hardening, OversubscriptionWarnsAndRuns) {
  const ThreadLimits lim = thread_limits();
  const int n = lim.cpus + 1;
  if (lim.hard > 0 && n > lim.hard) GTEST_SKIP() << "the process may not create " << n << " threads";
  const CliResult r = green("-q --backend threads --threads " + std::to_string(n));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("warning: --threads = " + std::to_string(n)), std::string::npos) << r.err;
  // The same count through the serial backend is not used: no warning.
  EXPECT_EQ(run("green cfg.toml --sources sources.csv --targets targets.csv --out V.csv -q --backend serial "
                "--threads " + std::to_string(n)).err, "");
}

TEST(HardeningUnit, ThreadCheckBounds) {
  std::ostringstream warn;
  check_thread_count(0, "--threads", warn);
  EXPECT_EQ(warn.str(), "");
  EXPECT_THROW(check_thread_count(-1, "--threads", warn), InputError);
  const ThreadLimits lim = thread_limits();
  EXPECT_GE(lim.cpus, 1);
  if (lim.hard > 0 && lim.hard < 2147483647) {
    EXPECT_THROW(check_thread_count(static_cast<int>(lim.hard) + 1, "--threads", warn), InputError);
  }
  check_thread_count(1, "--threads", warn);
  EXPECT_EQ(warn.str(), "");
}

TEST_F(Hardening, DiskFullDuringTheRunExitsOneWithTheSystemsReason) {
  SmallTmpfs fsys(tmp_.path / "small", "1500k");
  if (!fsys.mounted) GTEST_SKIP() << fsys.why;
  write_text(fsys.dir / "earlier.txt", "an earlier file\n");
  write_text(work_ / "full.toml", pinned_shear("", (fsys.dir / "full.h5").string()));
  // Long enough to fill 1.5 MB with frames after the first checkpoint (about 15 s).
  const CliResult r = run("run full.toml -q --end 30");
  EXPECT_EQ(r.status, 1) << r.err;  // not a crash (139), not "internal"
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("internal"), std::string::npos) << r.err;
  EXPECT_EQ(test::slurp_file(fsys.dir / "earlier.txt"), "an earlier file\n");
  // The checkpoint written before the disk filled is whole: it still reads.
  if (fs::exists(fsys.dir / "full.checkpoint.h5")) {
    EXPECT_NO_THROW(H5File::open(fsys.dir / "full.checkpoint.h5"));
  }
}

TEST_F(Hardening, DiskFullAtTheStartLeavesNothingThatBlocksTheRerun) {
  // 1 MB: room to create the output, not for its first record (HDF5 allocates whole chunks; uncompressed, since
  // deflated chunks of one record would fit).
  SmallTmpfs fsys(tmp_.path / "tiny", "1m");
  if (!fsys.mounted) GTEST_SKIP() << fsys.why;
  write_text(work_ / "full.toml", pinned_shear("", (fsys.dir / "full.h5").string()) + "compression = 0\n");
  const CliResult r = run("run full.toml -q");
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("already exists"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(fsys.dir / "full.h5"));
  EXPECT_FALSE(fs::exists(fsys.dir / "full.xdmf"));
  // Room elsewhere: the rerun is not refused for an existing output (it fails for the same reason again).
  const CliResult again = run("run full.toml -q");
  EXPECT_EQ(again.status, 1) << again.err;
  EXPECT_EQ(again.err.find("already exists"), std::string::npos) << again.err;
}

// ---------------------------------------------------------------------------------------------------------------
// Hangs

TEST_F(Hardening, PinnedCapsuleAtConstantHeightEnds) {
  // Its constant height once hung the end-of-run plot (now gone: `capsflow figures`; SvgPlot.* keeps the case).
  write_text(work_ / "pin.toml", pinned_shear());
  fs::create_directories(work_ / "pin");
  const CliResult r = run("run pin.toml -q", 120);
  ASSERT_NE(r.status, 124) << "the run did not return";
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(work_ / "pin" / "pin.h5"));
}

TEST(HardeningUnit, EndPhaseAnswersAStopRequest) {
  TempDir tmp;
  Config c = parse_config(pinned_shear("", (tmp.path / "end.h5").string()), "end.toml");
  c.time.end = 1e-10;  // the first record is the end: the loop ends before it looks at signals
  RunSettings s;
  s.quiet = true;
  request_stop(SIGTERM);
  const RunResult r = run_simulation(c, s, std::cerr);
  clear_stop_request();
  EXPECT_EQ(r.exit_code, 128 + SIGTERM);
  EXPECT_NE(r.stop_message.find("SIGTERM"), std::string::npos) << r.stop_message;
  EXPECT_TRUE(fs::exists(tmp.path / "end.checkpoint.h5"));
}

// ---------------------------------------------------------------------------------------------------------------
// Silent wrong numbers

TEST(HardeningUnit, GreenWrapsAnyCoordinateIntoTheBoxExactly) {
  const SlitGeometry geo{4.0, 8.0, 8.0, 1.0};
  GgemSolver solver(geo, GgemOptions{}, Backend::Serial);
  // Shifts by whole periods are exact in double for these values (multiples of 8 below 2^53).
  const double big = 8.0 * 137438953472.0;  // 2^40 periods: |x| ~ 1.1e12, far past the old 2.7e8 overflow
  const double f[3] = {1.0, 0.5, -0.25};
  const double sx0 = 4.0, sy = 2.0, sz0 = 3.0;
  const double tx0 = 4.5, ty = 2.2, tz0 = 3.5;
  double u0[3], u1[3], u2[3];
  solver.apply(1, &sx0, &sy, &sz0, &f[0], &f[1], &f[2], 1, &tx0, &ty, &tz0, &u0[0], &u0[1], &u0[2]);
  const double sx1 = sx0 + big, sz1 = sz0 - big, tx1 = tx0 - big, tz1 = tz0 + 3.0 * big;
  solver.apply(1, &sx1, &sy, &sz1, &f[0], &f[1], &f[2], 1, &tx1, &ty, &tz1, &u1[0], &u1[1], &u1[2]);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(u1[i], u0[i]) << i;
  EXPECT_NE(u0[0], 0.0);
  // 1e300 is a whole number of periods (8 divides it exactly in binary): the same as x = 0.
  const double sxh = 1e300, txh = -1e300, zero = 0.0, tx_zero = 0.0;
  solver.apply(1, &zero, &sy, &sz0, &f[0], &f[1], &f[2], 1, &tx_zero, &ty, &tz0, &u0[0], &u0[1], &u0[2]);
  solver.apply(1, &sxh, &sy, &sz0, &f[0], &f[1], &f[2], 1, &txh, &ty, &tz0, &u2[0], &u2[1], &u2[2]);
  ASSERT_EQ(std::fmod(1e300, 8.0), 0.0);
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(std::isfinite(u2[i]));
    EXPECT_EQ(u2[i], u0[i]) << i;
  }
}

TEST(HardeningUnit, CapsuleCentresFarOutsideTheBoxStartAtTheirImage) {
  // z = 8 * 2^45 + 4: the image at z = 4 exactly; unwrapped, its nodes would sit 1 apart on a grid of spacing 0.06.
  TempDir tmp;
  auto run_at = [&](const std::string& z, const std::string& name) {
    std::string text = pinned_shear("", (tmp.path / name).string());
    text.replace(text.find("center = [4.0, 3.0, 4.0]"), 24, "center = [4.0, 3.0, " + z + "]");
    Config c = parse_config(text, name);
    c.time.end = 0.1;
    RunSettings s;
    s.quiet = true;
    EXPECT_EQ(run_simulation(c, s, std::cerr).exit_code, 0);
    return read_run_file(tmp.path / name);
  };
  const RunFile near = run_at("4.0", "near.h5"), far = run_at("281474976710660.0", "far.h5");
  ASSERT_EQ(std::fmod(281474976710660.0, 8.0), 4.0);
  EXPECT_EQ(far.centroid, near.centroid);
  EXPECT_EQ(far.velocity, near.velocity);
}

std::string config_error(const std::string& text) {
  try {
    parse_config(text, "c.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(HardeningUnit, GridSizesBeyondTheBoundAreRefusedWithTheBound) {
  const std::string dom = "[domain]\nH = 4.0\nLx = 8.0\nLz = 8.0\n";
  std::string e = config_error(dom + "[ggem]\nalpha = 1e300\n");
  EXPECT_NE(e.find("[ggem] alpha"), std::string::npos) << e;
  EXPECT_NE(e.find("1048576"), std::string::npos) << e;
  e = config_error("[domain]\nH = 1e300\nLx = 8.0\nLz = 8.0\n");
  EXPECT_NE(e.find("[domain] H"), std::string::npos) << e;
  e = config_error("[domain]\nH = 4.0\nLx = 1e300\nLz = 8.0\n");
  EXPECT_NE(e.find("[domain] Lx"), std::string::npos) << e;
  e = config_error(dom + "[ggem]\nnz = 2000000000\n");
  EXPECT_NE(e.find("[ggem] nz"), std::string::npos) << e;
  // The largest grid that is allowed resolves to exactly the sizes asked for (no int overflow on the way).
  GgemOptions o;
  o.alpha = 4.0;
  const SlitGeometry wide{4.0, 8.0, 1e5, 1.0};  // nz = 8e5 points: allowed, and not wrapped to 8
  EXPECT_EQ(ggem_grid_size_error(wide, o), "");
  EXPECT_GE(resolve_ggem_grid(wide, o).nz, 800000);
}

// ---------------------------------------------------------------------------------------------------------------
// Late failures: refused before the first file

TEST_F(Hardening, InputsThatFailedAfterTheFirstFileAreRefusedFirst) {
  fs::create_directories(work_ / "pin");
  write_text(work_ / "gap.toml", pinned_shear("min_gap = 0\n"));
  expect_input_error(run("run gap.toml"), {"gap.toml: [time] min_gap", "> 0"});
  write_text(work_ / "colon.toml", pinned_shear("", "pin/a:b.h5"));
  expect_input_error(run("run colon.toml"), {"colon.toml: [output] file", "':'"});
  write_text(work_ / "run.toml", pinned_shear());
  expect_input_error(run("run run.toml --output pin/x:y.h5"), {"--output", "':'"});
  std::string sep = pinned_shear();
  sep.replace(sep.find("name = \"a\""), 10, "name = \"a,b\"");
  sep.replace(sep.find("species = \"a\""), 13, "species = \"a,b\"");
  write_text(work_ / "sep.toml", sep);
  expect_input_error(run("run sep.toml"), {"sep.toml: [[species]] 1 name", "without ','"});
  EXPECT_TRUE(fs::is_empty(work_ / "pin"));
}

// ---------------------------------------------------------------------------------------------------------------
// Files

TEST_F(Hardening, ForceNeverReplacesAnInputALinkOrADevice) {
  const auto before = snapshot_files(work_);
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv --out sources.csv --force"),
                     {"sources.csv", "input"});
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv --out ./cfg.toml --force"),
                     {"cfg.toml", "configuration"});
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv --out /dev/null --force"),
                     {"/dev/null", "not a regular file"});
  EXPECT_EQ(snapshot_files(work_), before);

  fs::create_symlink(work_ / "elsewhere.csv", work_ / "link.csv");
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv --out link.csv --force"),
                     {"link.csv", "symbolic link"});
  EXPECT_FALSE(fs::exists(work_ / "elsewhere.csv"));

  // A run whose output would be its own configuration.
  std::string self = pinned_shear("", "self.toml");
  write_text(work_ / "self.toml", self);
  expect_input_error(run("run self.toml --force"), {"self.toml", "configuration"});
  EXPECT_EQ(test::slurp_file(work_ / "self.toml"), self);

  // A linked directory above the output is fine.
  fs::create_directories(tmp_.path / "real");
  fs::create_directory_symlink(tmp_.path / "real", work_ / "linked");
  EXPECT_EQ(run("green cfg.toml --sources sources.csv --targets targets.csv --out linked/U.csv -q").status, 0);
  EXPECT_TRUE(fs::is_regular_file(tmp_.path / "real" / "U.csv"));
}

// ---------------------------------------------------------------------------------------------------------------
// Messages

TEST_F(Hardening, CommandLineValuesAreCheckedWithOneClearLine) {
  write_text(work_ / "run.toml", pinned_shear());
  fs::create_directories(work_ / "pin");
  const auto before = snapshot_files(work_);
  expect_input_error(run("frobnicate"), {"unknown command 'frobnicate'", "green", "run"});
  expect_input_error(run("run run.toml --end inf"), {"--end", "finite"});
  expect_input_error(run("run run.toml --end nan"), {"--end", "finite"});
  expect_input_error(run("run run.toml --progress -1"), {"--progress", ">= 0"});
  expect_input_error(run("run run.toml --progress nan"), {"--progress", "finite"});
  expect_input_error(run("run run.toml --output ''"), {"--output", "non-empty"});
  expect_input_error(run("run run.toml --backend ''"), {"--backend", "non-empty"});
  expect_input_error(green("--backend ''"), {"--backend", "non-empty"});
  EXPECT_EQ(snapshot_files(work_), before);
}

TEST_F(Hardening, RestartProblemsAreTheUsersToFixExitTwo) {
  write_text(work_ / "run.toml", pinned_shear());
  fs::create_directories(work_ / "pin");
  ASSERT_EQ(run("run run.toml -q").status, 0);
  // --end below the checkpoint's strain.
  expect_input_error(run("run --restart pin/pin.checkpoint.h5 --end 0.1"), {"--end", "checkpoint"});
  // A truncated checkpoint.
  const std::string ck = test::slurp_file(work_ / "pin" / "pin.checkpoint.h5");
  write_text(work_ / "cut.checkpoint.h5", ck.substr(0, ck.size() / 2));
  const CliResult r = run("run --restart cut.checkpoint.h5 --end 1");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("cut.checkpoint.h5"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("internal"), std::string::npos) << r.err;
}

TEST_F(Hardening, EarlyStopMessagesPrintShortNumbers) {
  // dt_floor = 1e300: the first step is below it (refused before any file since issue 24); the message must not
  // spell the number out in 300 digits.
  write_text(work_ / "floor.toml", pinned_shear("dt_floor = 1e300\n"));
  fs::create_directories(work_ / "pin");
  const CliResult r = run("run floor.toml -q");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_TRUE(fs::is_empty(work_ / "pin"));
  EXPECT_NE(r.err.find("dt_floor = 1e+300"), std::string::npos) << r.err;
  EXPECT_LT(r.err.size(), 400u) << r.err;
}

// ---------------------------------------------------------------------------------------------------------------
// ParaView: the XDMF refers to plain per-frame datasets that show the frames (ctest -L paraview opens it for real)

TEST(HardeningUnit, XdmfFramesArePlainDatasetsThatShowTheFrames) {
  TempDir tmp;
  const Config c = parse_config(pinned_shear("", (tmp.path / "v.h5").string()), "v.toml");
  RunSettings s;
  s.quiet = true;
  ASSERT_EQ(run_simulation(c, s, std::cerr).exit_code, 0);
  const std::string xdmf = test::slurp_file(tmp.path / "v.xdmf");
  EXPECT_EQ(xdmf.find("HyperSlab"), std::string::npos);
  const H5File f = H5File::open(tmp.path / "v.h5");
  EXPECT_EQ(f.attribute<std::int64_t>("/", layout::kAttrFormat), layout::kFormatVersion);
  const std::size_t frames = f.extent(layout::kFramePositions);
  ASSERT_GE(frames, 2u);
  for (std::size_t fr = 0; fr < frames; ++fr)
    for (const char* src : {layout::kFramePositions, layout::kFrameVelocity}) {
      const std::string view = layout::frame_view_path(src, fr);
      EXPECT_NE(xdmf.find("v.h5:" + view + "<"), std::string::npos) << view;
      EXPECT_EQ(f.read<double>(view).data, f.read_records<double>(src, fr, 1).data) << view;
    }
}

}  // namespace
