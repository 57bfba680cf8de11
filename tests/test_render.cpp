// `capsflow render` without ParaView: its refusals (status 2, one line naming the option, file or Debian package,
// nothing written) and its plumbing, with a stand-in pvbatch that writes what the job file asks for (the outputs are
// named, staged in a hidden directory and renamed into place; a failing pvbatch leaves nothing behind). The pictures
// themselves, drawn by the real pvbatch, are checked by tests/python/test_render.py.
//
// Its children end with it (issue 52, item 7): stand-ins for xvfb-run (an "X server" in the background, the command
// in the foreground) and for pvbatch (a helper in the background that ignores SIGTERM, then drawing for ever) are
// started by `capsflow render`, which is sent a signal; every one of those processes must be gone within seconds.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/run/run_marker.hpp"
#include "support/cli_runner.hpp"
#include "support/small_run.hpp"
#include "support/small_tmpfs.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace capsflow::test;
namespace fs = std::filesystem;

// Reads the job, writes every PNG and the state, reports each frame as the real script does, keeps a copy of the job.
// FAKE_PVBATCH=fail: one frame, then an error line and status 1; nopng: every frame reported, no PNG written; nostate:
// no state written; big: PNGs of 256 KiB, and on a full disk what Debian's pvbatch 5.11 does (its PNG writer deletes
// the file and logs an error; the frame is reported and the exit status is 0).
constexpr const char* kFakePvbatch = R"(#!/usr/bin/python3
import json, os, sys
mode = os.environ.get("FAKE_PVBATCH", "")
job = json.load(open(sys.argv[-1]))
json.dump(job, open(os.path.join(os.path.dirname(sys.argv[0]), "last_job.json"), "w"))
for k, f in enumerate(job["frames"]):
    if mode == "big":
        try:
            open(f["png"], "wb").write(b"p" * 262144)
        except OSError:
            os.remove(f["png"])
            sys.stderr.write("ERR| vtkPNGWriter: Ran out of disk space; deleting file(s) already written\n")
    elif mode != "nopng":
        open(f["png"], "wb").write(b"frame %d" % f["index"])
    print("capsflow-render: frame %d %d" % (k + 1, len(job["frames"])), flush=True)
    if mode == "fail":
        sys.stderr.write("\x1b[31m(   0.1s) [pvbatch] ERR| vtkSomething: it broke\x1b[0m\n")
        sys.exit(1)
if mode != "nostate":
    open(job["state"], "w").write("<ParaView/>\n")
)";

// The names of the files that differ between two snapshots (snapshot_files), for a readable failure.
std::string changed_files(const std::map<std::string, std::string>& a, const std::map<std::string, std::string>& b) {
  std::string out;
  for (const auto& [name, content] : a)
    if (!b.count(name) || b.at(name) != content) out += name + (b.count(name) ? " (changed) " : " (removed) ");
  for (const auto& [name, content] : b)
    if (!a.count(name)) out += name + " (created) ";
  return out;
}

// Stand-ins for a render that never ends (the SIGTERM-ignoring helper needs the SIGKILL that follows the grace).
// Each records its process id in $FAKE_MARKS.
constexpr const char* kFakeXvfbRun = R"(#!/bin/bash
echo $$ > "$FAKE_MARKS/xvfb-run.pid"
/bin/sleep 1000 &
echo $! > "$FAKE_MARKS/xvfb.pid"
shift 7  # -a -n N -f AUTH_FILE -s SERVER_ARGS, as capsflow passes them
"$@"
)";
constexpr const char* kHangingPvbatch = R"(#!/bin/bash
(trap '' TERM; exec /bin/sleep 1000) &
echo $! > "$FAKE_MARKS/helper.pid"
echo $$ > "$FAKE_MARKS/pvbatch.pid"
exec /bin/sleep 1000
)";
const std::vector<std::string> kMarks = {"xvfb-run.pid", "xvfb.pid", "helper.pid", "pvbatch.pid"};

extern "C" char** environ;

// A process that has ended: gone, or a zombie nobody has reaped yet.
bool process_gone(long pid) {
  if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) return true;
  const std::string stat = slurp_file("/proc/" + std::to_string(pid) + "/stat");
  const std::size_t close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() && stat[close + 2] == 'Z';
}

// Polls `done` every 50 ms for up to `seconds`.
template <class F>
bool within(double seconds, F done) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    if (done()) return true;
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

class Render : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = tmp_.path / "work";
    bin_ = tmp_.path / "bin";
    fs::create_directories(work_);
    fs::create_directories(bin_);
    // A bin directory for PATH with only what a test puts there (timeout runs the command).
    fs::create_symlink("/usr/bin/timeout", bin_ / "timeout");
    std::ofstream(work_ / "c.toml") << small_run_text();
    const CliResult r = run_capsflow(work_, "run c.toml --end 0.65 --set run.backend=serial -q --output run.h5");
    ASSERT_EQ(r.status, 0) << r.err;
  }
  void add_fake_pvbatch() {
    std::ofstream(bin_ / "pvbatch") << kFakePvbatch;
    fs::permissions(bin_ / "pvbatch", fs::perms::owner_all);
  }
  // The environment of one call: PATH = bin_ only, a display (so that no xvfb-run is needed) unless `display` is empty.
  std::string env(const std::string& display = ":0", const std::string& extra = "") const {
    return "OMP_NUM_THREADS=1 CAPSFLOW_PVBATCH= PATH=" + shell_quote(bin_.string()) + " DISPLAY=" + display + " " + extra;
  }
  CliResult render(const std::string& args, const std::string& environment) {
    return run_capsflow(work_, "render run.h5 --out pics " + args, 60, environment);
  }
  // `capsflow render` in the background, its stderr to work_.stderr; its process id.
  pid_t start_render(const std::string& args, const std::string& environment) {
    const std::string cmd = "cd " + shell_quote(work_.string()) + " && " + environment + " exec " +
                            shell_quote(capsflow_binary_path()) + " render run.h5 --out pics " + args +
                            " >/dev/null 2>" + shell_quote(work_.string() + ".stderr") + " </dev/null";
    std::vector<char*> argv = {const_cast<char*>("sh"), const_cast<char*>("-c"), const_cast<char*>(cmd.c_str()),
                               nullptr};
    pid_t pid = -1;
    EXPECT_EQ(::posix_spawn(&pid, "/bin/sh", nullptr, nullptr, argv.data(), environ), 0);
    return pid;
  }
  // The stand-ins' process ids, once all of them have started (empty if they did not within a minute).
  std::vector<long> stand_in_pids() {
    std::vector<long> pids;
    within(60, [&] {
      pids.clear();
      for (const std::string& m : kMarks) {
        const std::string text = slurp_file(marks_ / m);
        if (text.empty() || text.back() != '\n') return false;
        pids.push_back(std::stol(text));
      }
      return true;
    });
    return pids.size() == kMarks.size() ? pids : std::vector<long>{};
  }
  // The exit status of `pid` (a child): 0..255 when it exited, 1000 + signal when a signal killed it, -1 when it has
  // not ended within `seconds`.
  static int wait_exit(pid_t pid, double seconds) {
    int raw = 0, status = -1;
    within(seconds, [&] {
      if (::waitpid(pid, &raw, WNOHANG) != pid) return false;
      status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 1000 + WTERMSIG(raw);
      return true;
    });
    return status;
  }
  void add_stand_ins() {
    fs::create_directories(marks_);
    for (const auto& [name, text] : {std::pair<std::string, std::string>{"xvfb-run", kFakeXvfbRun},
                                     {"xauth", "#!/bin/sh\nexit 0\n"},
                                     {"pvbatch", kHangingPvbatch}}) {
      std::ofstream(bin_ / name) << text;
      fs::permissions(bin_ / name, fs::perms::owner_all);
    }
  }
  // No display: the render runs under the stand-in xvfb-run.
  std::string stand_in_env() const { return env("", "FAKE_MARKS=" + shell_quote(marks_.string())); }
  void TearDown() override {
    // Whatever a failed test left running, ended by its recorded id, once that id is seen to be a stand-in's still
    // (a process that ended long ago may have passed its id on).
    for (const std::string& m : kMarks) {
      const std::string text = slurp_file(marks_ / m);
      const long pid = text.empty() ? 0 : std::stol(text);
      if (pid <= 0 || process_gone(pid)) continue;
      const std::string cmd = slurp_file("/proc/" + std::to_string(pid) + "/cmdline");
      if (cmd == std::string("/bin/sleep\0" "1000\0", 16) || cmd.find(bin_.string()) != std::string::npos)
        ::kill(static_cast<pid_t>(pid), SIGKILL);
    }
  }
  TempDir tmp_;
  fs::path work_, bin_, marks_ = tmp_.path / "marks";
};

TEST_F(Render, MissingProgramsAreNamedWithTheirDebianPackages) {
  const auto before = snapshot_files(work_);
  expect_input_error(render("", env()), {"pvbatch", "apt-get install paraview python3-paraview"});
  expect_input_error(render("", env(":0", "CAPSFLOW_PVBATCH=/nonexistent/pvbatch")),
                     {"CAPSFLOW_PVBATCH=/nonexistent/pvbatch", "not an executable"});
  add_fake_pvbatch();
  expect_input_error(render("", env("")), {"no display", "xvfb-run", "xvfb"});
  expect_input_error(render("--movie", env()), {"--movie", "ffmpeg", "apt-get install ffmpeg"});
  EXPECT_EQ(snapshot_files(work_), before);
}

TEST_F(Render, BadInputIsRefusedBeforeAnythingIsWritten) {
  add_fake_pvbatch();
  const auto before = snapshot_files(work_);
  expect_input_error(render("--frame 4", env()), {"--frame 4", "run.h5 has 4 frames"});
  expect_input_error(render("--frame -5", env()), {"--frame -5"});
  expect_input_error(render("--range 0:1", env()), {"--range 0:1", "only with a field"});
  expect_input_error(render("--color tension_max --range 2:1", env()), {"--range", "LO < HI"});
  expect_input_error(render("--movie --size 321x240", env()), {"--size 321x240", "even"});
  expect_input_error(render("--size 10x10", env()), {"--size", "WxH"});
  expect_input_error(render("--color pressure", env()), {"--color", "pressure"});
  expect_input_error(run_capsflow(work_, "render run.checkpoint.h5 --out pics", 60, env()), {"checkpoint"});
  expect_input_error(run_capsflow(work_, "render nothing.h5 --out pics", 60, env()), {"nothing.h5", "no such file"});
  fs::rename(work_ / "run.xdmf", work_ / "moved.xdmf");
  expect_input_error(render("", env()), {"run.xdmf", "missing"});
  fs::rename(work_ / "moved.xdmf", work_ / "run.xdmf");
  EXPECT_EQ(snapshot_files(work_), before);
}

TEST_F(Render, OutputsAreNamedPlacedTogetherAndNeverSilentlyReplaced) {
  add_fake_pvbatch();
  const CliResult r = render("--frame 0 --time 0.21 --color tension_max", env());
  ASSERT_EQ(r.status, 0) << r.err;
  // Frames 0 and the one nearest strain 0.21 (frames every 0.2), the state; nothing else, no temporary left.
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(work_ / "pics")) names.insert(e.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{"run_tension_max_f0000.png", "run_tension_max_f0001.png",
                                          "run_tension_max.pvsm"}));
  EXPECT_EQ(slurp_file(work_ / "pics" / "run_tension_max_f0001.png"), "frame 1");
  EXPECT_NE(r.err.find("colour tension_max [mu gammadot a]"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("ParaView"), std::string::npos) << r.err;

  // The job: the run's index, the frames at the run file's strains, the field's units and a range that holds it.
  const nlohmann::json job = nlohmann::json::parse(slurp_file(bin_ / "last_job.json"));
  EXPECT_EQ(job["xdmf"], (fs::canonical(work_) / "run.xdmf").string());
  EXPECT_EQ(job["frame_count"], 4);
  ASSERT_EQ(job["frames"].size(), 2u);
  EXPECT_EQ(job["frames"][1]["index"], 1);
  EXPECT_EQ(job["units"], "mu gammadot a");
  EXPECT_LT(job["range"][0].get<double>(), job["range"][1].get<double>());
  EXPECT_GT(job["range"][0].get<double>(), 0.0);  // inflated capsules: tension everywhere
  EXPECT_EQ(job["species"], (nlohmann::json{"stiff", "floppy"}));
  // The default view, the project's palette by Ca (stiff tab:blue, floppy tab:red) and a title naming the run.
  EXPECT_EQ(job["view"], "side");
  ASSERT_EQ(job["species_rgb"].size(), 2u);
  EXPECT_EQ(job["species_rgb"][0], (nlohmann::json{0.122, 0.467, 0.706}));
  EXPECT_EQ(job["species_rgb"][1], (nlohmann::json{0.839, 0.153, 0.157}));
  const std::string title = job["title"].get<std::string>();
  for (const char* part : {"run.h5", "X_f ", "stiff (Ca 0.2)", "floppy (Ca 0.6)"})
    EXPECT_NE(title.find(part), std::string::npos) << part << " not in " << title;
  EXPECT_EQ(render("--frame 0 --color tension_max --force -q --view top", env()).status, 0);
  EXPECT_EQ(nlohmann::json::parse(slurp_file(bin_ / "last_job.json"))["view"], "top");
  expect_input_error(render("--view front", env()), {"--view", "front"});

  // Again: refused without --force, the files unchanged; with --force replaced.
  const auto before = snapshot_files(work_);
  expect_input_error(render("--frame 0 --time 0.21 --color tension_max", env()),
                     {"run_tension_max_f0000.png", "exists", "--force"});
  EXPECT_EQ(snapshot_files(work_), before);
  EXPECT_EQ(render("--frame 0 --color tension_max --force -q", env()).status, 0);
}

TEST_F(Render, AFailingPvbatchLeavesNothingBehind) {
  add_fake_pvbatch();
  const CliResult r = render("--frame 0 --frame -1", env(":0", "FAKE_PVBATCH=fail"));
  EXPECT_EQ(r.status, 1) << r.err;
  const std::string last = r.err.substr(r.err.rfind("capsflow: error: "));
  EXPECT_NE(last.find("pvbatch failed"), std::string::npos) << r.err;
  EXPECT_NE(last.find("1 of 2 frames"), std::string::npos) << r.err;
  EXPECT_NE(last.find("ERR| vtkSomething: it broke"), std::string::npos) << r.err;
  EXPECT_EQ(last.find('\x1b'), std::string::npos) << "colour codes in the message";
  EXPECT_FALSE(fs::exists(work_ / "pics"));  // the hidden temporary directory removed too, and the folder it made
}

// A signal to capsflow while pvbatch draws: every process it started (xvfb-run, the X server, pvbatch and pvbatch's
// helper that ignores SIGTERM) is gone within seconds, capsflow exits with 128 + the signal, nothing is left in the
// folder. Before the fix the signal killed capsflow alone and all four went on.
TEST_F(Render, ASignalEndsEveryProcessTheRenderStarted) {
  add_stand_ins();
  for (const auto& [sig, name] : {std::pair{SIGTERM, "SIGTERM"}, {SIGINT, "SIGINT"}, {SIGHUP, "SIGHUP"}}) {
    SCOPED_TRACE(name);
    fs::remove_all(marks_);
    fs::create_directories(marks_);
    const pid_t pid = start_render("--frame 0 -q", stand_in_env());
    const std::vector<long> pids = stand_in_pids();
    ASSERT_EQ(pids.size(), kMarks.size()) << slurp_file(work_.string() + ".stderr");
    ::kill(pid, sig);
    EXPECT_EQ(wait_exit(pid, 30), 128 + sig) << "capsflow's own exit, 128 + signal";
    for (std::size_t k = 0; k < pids.size(); ++k)
      EXPECT_TRUE(within(5, [&] { return process_gone(pids[k]); })) << kMarks[k] << " (pid " << pids[k] << ") lives on";
    const std::string err = slurp_file(work_.string() + ".stderr");
    EXPECT_NE(err.find(name), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(work_ / "pics")) << "the temporary directory, the lock and the folder it made removed";
    if (HasFailure()) return;
  }
}

// capsflow killed outright (SIGKILL: no handler runs): the processes it started are still gone within seconds, and
// the next render takes over the folder (the dead render's lock and temporary directory are stale).
TEST_F(Render, AKilledRenderLeavesNoProcessBehind) {
  add_stand_ins();
  fs::create_directories(marks_);
  const pid_t pid = start_render("--frame 0", stand_in_env());
  const std::vector<long> pids = stand_in_pids();
  ASSERT_EQ(pids.size(), kMarks.size()) << slurp_file(work_.string() + ".stderr");
  ::kill(pid, SIGKILL);
  EXPECT_EQ(wait_exit(pid, 30), 1000 + SIGKILL);
  for (std::size_t k = 0; k < pids.size(); ++k)
    EXPECT_TRUE(within(10, [&] { return process_gone(pids[k]); })) << kMarks[k] << " (pid " << pids[k] << ") lives on";
  add_fake_pvbatch();
  const CliResult r = render("--frame 0", env());
  EXPECT_EQ(r.status, 0) << r.err;
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(work_ / "pics")) names.insert(e.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{"run_species_f0000.png", "run_species.pvsm"}));
}

// Two renders into one folder at once: the second is refused in one line naming the folder and its lock, whatever
// --force says, and changes nothing; a lock whose render is dead is taken over. Before the fix both drew.
TEST_F(Render, ASecondRenderIntoTheSameFolderIsRefused) {
  add_stand_ins();
  fs::create_directories(marks_);
  const pid_t first = start_render("--frame 0 -q", env(":0", "FAKE_MARKS=" + shell_quote(marks_.string())));
  ASSERT_TRUE(within(60, [&] { return !slurp_file(marks_ / "pvbatch.pid").empty(); }))
      << slurp_file(work_.string() + ".stderr");
  const auto before = snapshot_files(work_);
  const fs::path second = tmp_.path / "second";  // where a second stand-in would note itself (not before the fix)
  fs::create_directories(second);
  for (const char* force : {"", " --force"}) {
    SCOPED_TRACE(force);
    expect_input_error(run_capsflow(work_, std::string("render run.h5 --out pics --frame -1") + force, 20,
                                    env(":0", "FAKE_MARKS=" + shell_quote(second.string()))),
                       {"--out pics", "another capsflow render", "pics/render.lock", "pid " + std::to_string(first)});
    EXPECT_EQ(snapshot_files(work_), before);
  }
  ::kill(first, SIGTERM);
  EXPECT_EQ(wait_exit(first, 30), 128 + SIGTERM);
  EXPECT_FALSE(fs::exists(work_ / "pics" / "render.lock")) << "released";

  // The lock of a render that died (a process that has ended): stale, taken over, removed at the end.
  const pid_t dead = start_render("--help", env());
  ASSERT_EQ(wait_exit(dead, 30), 0);
  std::ofstream(work_ / "pics" / "render.lock")
      << R"({"run_id": "capsflow render", "host": ")" << capsflow::this_host() << R"(", "pid": )" << dead
      << R"(, "start_ticks": 0, "started": 0, "heartbeat": 0})" << "\n";
  add_fake_pvbatch();
  const CliResult r = render("--frame 0 -q", env());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(work_ / "pics" / "render.lock"));
  EXPECT_TRUE(fs::exists(work_ / "pics" / "run_species_f0000.png"));
}

// Failures after the drawing (issue 52, item 7), which used to end in raw std::filesystem text (or, with --force, in
// a picture renamed onto a directory): each ends in one line naming the file or folder the user can change, with the
// status the docs give (2: refused before drawing; 1: after), and every file in the working directory as it was: no
// output, no lock, no temporary directory. The full-disk cases fail the picture's write and its rename through the
// test-only fault injection (counted calls: 1 the lock, 2 the job, 3-6 the picture's write, sync, rename and the
// directory's sync).
TEST_F(Render, FailuresAfterTheDrawingEndInOneLineAndLeaveTheFolderAsItWas) {
  add_fake_pvbatch();
  struct Case {
    std::string name, args, environment;
    std::function<void()> setup;
    int status;
    std::vector<std::string> parts;
  };
  const fs::path pics = work_ / "pics";
  const auto none = [] {};
  const auto old_picture = [&] {
    fs::create_directories(pics);
    std::ofstream(pics / "run_species_f0000.png") << "an older picture\n";
  };
  const std::vector<Case> cases = {
      {"a directory where the picture goes, with --force", "--frame 0 --force", "",
       [&] { fs::create_directories(pics / "run_species_f0000.png" / "inside"); }, 2,
       {"pics/run_species_f0000.png", "is a directory", "--force"}},
      {"a directory where the picture goes, without --force", "--frame 0", "",
       [&] { fs::create_directories(pics / "run_species_f0000.png"); }, 2,
       {"pics/run_species_f0000.png", "is a directory"}},
      {"a directory where the ParaView state goes", "--frame 0 --force", "",
       [&] { fs::create_directories(pics / "run_species.pvsm"); }, 2, {"pics/run_species.pvsm", "is a directory"}},
      {"pvbatch reports the frames but writes no picture", "--frame 0 --frame 1", "FAKE_PVBATCH=nopng", none, 1,
       {"pvbatch", "reported 2 frames drawn", "wrote no pictures", "pics", "CAPSFLOW_PVBATCH"}},
      {"pvbatch writes no ParaView state", "--frame 0", "FAKE_PVBATCH=nostate", none, 1,
       {"pvbatch", "no ParaView state", "pics/run_species.pvsm"}},
      {"a full disk at the picture's write", "--frame 0", "CAPSFLOW_TEST_FAULT_AT=3", none, 1,
       {"pics/run_species_f0000.png", "No space left on device", "the disk holding pics is full", "--out"}},
      {"a full disk at the rename of a picture replaced with --force", "--frame 0 --force", "CAPSFLOW_TEST_FAULT_AT=5",
       old_picture, 1, {"pics/run_species_f0000.png", "No space left on device", "the disk holding pics is full"}},
      {"a full disk at the folder's sync after the picture's rename", "--frame 0 --force", "CAPSFLOW_TEST_FAULT_AT=6",
       old_picture, 1, {"pics", "No space left on device", "the disk holding pics is full"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    fs::remove_all(pics);
    c.setup();
    const auto before = snapshot_files(work_);
    const CliResult r = render(c.args + " -q", env(":0", c.environment + " CAPSFLOW_TEST_FAULT_ERRNO=ENOSPC"));
    EXPECT_EQ(r.status, c.status) << r.err;
    EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const std::string& p : c.parts)
      EXPECT_NE(r.err.find(p), std::string::npos) << "'" << p << "' not in: " << r.err;
    EXPECT_EQ(r.err.find("filesystem error"), std::string::npos) << r.err;
    EXPECT_EQ(changed_files(before, snapshot_files(work_)), "");
    if (HasFailure()) return;
  }
}

// A disk that fills up while pvbatch draws (a real one: a small tmpfs): Debian's pvbatch then deletes the picture it
// could not finish and still reports the frame; the line names the folder and says that its disk is full.
TEST_F(Render, ADiskThatFillsWhilePvbatchDrawsIsNamed) {
  add_fake_pvbatch();
  SmallTmpfs disk(tmp_.path / "small", "2m");
  if (!disk.mounted) GTEST_SKIP() << disk.why;
  disk.leave_free(64 * 1024);
  const fs::path pics = disk.dir / "pics";
  const CliResult r = run_capsflow(work_, "render run.h5 -q --frame 0 --out " + shell_quote(pics.string()), 60,
                                   env(":0", "FAKE_PVBATCH=big"));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const std::string& p : {"--out " + pics.string(), std::string("the disk is full"), std::string("free")})
    EXPECT_NE(r.err.find(p), std::string::npos) << "'" << p << "' not in: " << r.err;
  EXPECT_FALSE(fs::exists(pics)) << "no picture, no lock, no temporary directory, not the folder it made";
}

// The folder's lock taken by eight processes at once, over no lock and over a dead render's: exactly one holds it
// (the run's marker, checked and then written, would let several through).
TEST(FolderLock, OfProcessesTakingItAtOnceExactlyOneHoldsIt) {
  TempDir tmp;
  const fs::path lock = tmp.path / "render.lock";
  for (const bool stale : {false, true}) {
    SCOPED_TRACE(stale ? "over a dead render's lock" : "over no lock");
    fs::remove(lock);
    if (stale)
      std::ofstream(lock) << R"({"run_id": "capsflow render", "host": ")" << capsflow::this_host()
                          << R"(", "pid": 999999999, "start_ticks": 1, "started": 1, "heartbeat": 1})" << "\n";
    int start[2], result[2];
    ASSERT_EQ(::pipe(start), 0);
    ASSERT_EQ(::pipe(result), 0);
    std::vector<pid_t> children;
    for (int k = 0; k < 8; ++k) {
      const pid_t pid = ::fork();
      if (pid == 0) {
        ::close(start[1]);
        char c;
        while (::read(start[0], &c, 1) > 0) {
        }  // all start when the parent closes the pipe
        char verdict = 'E';
        try {
          capsflow::FolderLock l(lock, "capsflow render");
          verdict = l.held() ? 'H' : 'R';
          if (l.held()) ::usleep(300000);  // held while the others try
        } catch (...) {
        }
        [[maybe_unused]] const ssize_t w = ::write(result[1], &verdict, 1);
        ::_exit(0);
      }
      children.push_back(pid);
    }
    ::close(start[0]);
    ::close(start[1]);
    ::close(result[1]);
    std::string verdicts;
    char c;
    while (::read(result[0], &c, 1) > 0) verdicts += c;
    ::close(result[0]);
    for (pid_t pid : children) ::waitpid(pid, nullptr, 0);
    EXPECT_EQ(std::count(verdicts.begin(), verdicts.end(), 'H'), 1) << verdicts;
    EXPECT_EQ(std::count(verdicts.begin(), verdicts.end(), 'R'), 7) << verdicts;
    EXPECT_FALSE(fs::exists(lock)) << "released by its holder";
  }
}

}  // namespace
