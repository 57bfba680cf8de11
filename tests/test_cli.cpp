// The capsflow executable (env CAPSFLOW_BINARY), run in a fresh temporary directory per test:
// help text, exit codes, one-line error messages, and that a failed run writes nothing.
//
// Tests named WithSolver* need a working GgemSolver (a successful `green` run); the others fail before the
// solver is constructed.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <csignal>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/run/checkpoint.hpp"
#include "host/physics/config.hpp"
#include "capsflow_version.hpp"
#include "host/base/build_info.hpp"

namespace {

namespace fs = std::filesystem;

// The environment variable, else the value compiled in by tests/CMakeLists.txt, else "".
std::string env_or_default(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  if (v && *v) return v;
  return fallback ? fallback : "";
}
#ifndef CAPSFLOW_TEST_DEFAULT_BINARY
#define CAPSFLOW_TEST_DEFAULT_BINARY nullptr
#endif
#ifndef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
#define CAPSFLOW_TEST_DEFAULT_SOURCE_DIR nullptr
#endif
std::string capsflow_binary() { return env_or_default("CAPSFLOW_BINARY", CAPSFLOW_TEST_DEFAULT_BINARY); }
std::string source_dir() { return env_or_default("CAPSFLOW_SOURCE_DIR", CAPSFLOW_TEST_DEFAULT_SOURCE_DIR); }

struct Result {
  int status = -1;
  std::string out, err;
};

const char* kConfig = R"([domain]
H = 4.0
Lx = 8.0
Lz = 8.0

[ggem]
alpha = 4.0
)";

const char* kSources =
    "x,y,z,fx,fy,fz\n"
    "4.0,2.0,4.0,1.0,0.0,0.0\n"
    "2.0,1.0,6.0,0.0,1.0,0.0\n"
    "6.5,3.5,1.5,0.0,0.0,-1.0\n";

const char* kTargets =
    "x,y,z\n"
    "4.0,2.0,4.0\n"       // on a source: its regular part
    "4.5,2.0,4.0\n"
    "0.1,0.0,7.9\n"       // on the wall y = 0
    "3.0,4.0,2.0\n"       // on the wall y = H
    "7.25,1.75,0.5\n";

class Cli : public testing::Test {
 protected:
  void SetUp() override {
    binary_ = capsflow_binary();
    if (binary_.empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
    std::string templ = (fs::temp_directory_path() / "capsflow_cli_XXXXXX").string();
    ASSERT_NE(::mkdtemp(templ.data()), nullptr);
    dir_ = templ;
    fs::create_directory(dir_ / "work");
    write("cfg.toml", kConfig);
    write("sources.csv", kSources);
    write("targets.csv", kTargets);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }

  // Files live in dir_/work, the command's working directory; its stdout and stderr go to dir_.
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / "work" / name, std::ios::binary) << text;
  }
  std::string read(const std::string& name) const { return slurp(dir_ / "work" / name); }
  bool exists(const std::string& name) const { return fs::exists(dir_ / "work" / name); }
  static std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // Names in the working directory other than the inputs (outputs and any temporary left behind).
  std::vector<std::string> extra_files() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_ / "work")) {
      const std::string n = e.path().filename().string();
      if (n != "cfg.toml" && n != "sources.csv" && n != "targets.csv" && n != "bad.csv" && n != "bad.toml")
        names.push_back(n);
    }
    return names;
  }

  // env: an optional command prefix, e.g. "env -u NAME ".
  Result run(const std::string& args, const std::string& env = "") const {
    const std::string cmd = "cd '" + (dir_ / "work").string() + "' && " + env + "'" + binary_ + "' " + args + " >'" +
                            (dir_ / "stdout.txt").string() + "' 2>'" + (dir_ / "stderr.txt").string() + "'";
    const int raw = std::system(cmd.c_str());
    Result r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(dir_ / "stdout.txt");
    r.err = slurp(dir_ / "stderr.txt");
    return r;
  }

  // `run` under an address-space limit of `kib` KiB (ulimit -v).
  Result run_limited(const std::string& args, long kib) const {
    const std::string cmd = "cd '" + (dir_ / "work").string() + "' && (ulimit -v " + std::to_string(kib) + " && '" +
                            binary_ + "' " + args + ") >'" + (dir_ / "stdout.txt").string() + "' 2>'" +
                            (dir_ / "stderr.txt").string() + "'";
    const int raw = std::system(cmd.c_str());
    Result r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(dir_ / "stdout.txt");
    r.err = slurp(dir_ / "stderr.txt");
    return r;
  }

  // `green` with the standard inputs plus `extra`.
  Result green(const std::string& extra = "", const std::string& config = "cfg.toml",
               const std::string& sources = "sources.csv", const std::string& targets = "targets.csv") const {
    return run("green " + config + " --sources " + sources + " --targets " + targets + " --out U.csv " + extra);
  }

  std::string binary_;
  fs::path dir_;
};

// An input error: status 2, one line "capsflow: error: ..." holding every part, and no output written.
void expect_input_error(const Result& r, std::initializer_list<std::string> parts) {
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
  for (const auto& p : parts) EXPECT_NE(r.err.find(p), std::string::npos) << "'" << p << "' not in: " << r.err;
}

TEST_F(Cli, HelpExplainsEveryOption) {
  const Result top = run("--help");
  EXPECT_EQ(top.status, 0);
  for (const char* s : {"green", "info", "--version", "--help"})
    EXPECT_NE(top.out.find(s), std::string::npos) << s << " not in:\n" << top.out;

  const Result g = run("green --help");
  EXPECT_EQ(g.status, 0);
  for (const char* s : {"CONFIG.toml", "--sources", "--targets", "--out", "--backend", "--threads", "--force",
                        "--quiet", "x,y,z,fx,fy,fz", "x,y,z,ux,uy,uz", "serial", "threads", "device"})
    EXPECT_NE(g.out.find(s), std::string::npos) << s << " not in:\n" << g.out;

  EXPECT_EQ(run("info --help").status, 0);
}

TEST_F(Cli, Version) {
  const Result r = run("--version");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find(CAPSFLOW_VERSION_STRING), std::string::npos) << r.out;
  // The sources' commit (tools/build_commit.cmake): the checkout's HEAD, or "unknown" outside a git checkout.
  EXPECT_NE(r.out.find(std::string("(commit ") + capsflow::build_commit() + ")"), std::string::npos) << r.out;
  const std::string c = capsflow::build_commit();
  EXPECT_TRUE(c == "unknown" || (c.size() >= 12 && c.find_first_not_of("0123456789abcdef") >= 12)) << c;
}

TEST_F(Cli, InfoListsBackends) {
  const Result r = run("info");
  EXPECT_EQ(r.status, 0) << r.err;
  for (const char* s : {CAPSFLOW_VERSION_STRING, "serial", "threads", "device", "devices"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << " not in:\n" << r.out;
}

// The host vector path (kernels/simd_path.hpp): `info` names the one in use, CAPSFLOW_SIMD and CAPSFLOW_NO_AVX512
// cap it (never above the CPU's best), and an unknown CAPSFLOW_SIMD is refused in one line before anything runs.
TEST_F(Cli, InfoNamesTheVectorPathAndTheEnvironmentCapsIt) {
  const auto path_of = [](const Result& r, const std::string& key) {
    const auto p = r.out.find(key);
    if (p == std::string::npos) return std::string("(missing)");
    const auto b = p + key.size();
    return r.out.substr(b, r.out.find_first_of(" ;)\n", b) - b);
  };
  const Result best = run("info", "env -u CAPSFLOW_SIMD -u CAPSFLOW_NO_AVX512 ");
  ASSERT_EQ(best.status, 0) << best.err;
  const std::string cpu = path_of(best, "this CPU's best: ");
  ASSERT_TRUE(cpu == "avx512" || cpu == "avx2" || cpu == "portable") << best.out;
  EXPECT_EQ(path_of(best, "vector     "), cpu) << best.out;
  EXPECT_EQ(path_of(run("info", "env CAPSFLOW_SIMD=portable "), "vector     "), "portable");
  EXPECT_EQ(path_of(run("info", "env CAPSFLOW_SIMD=avx512 "), "vector     "), cpu);  // a cap, never above the CPU
  const std::string avx2_or_less = cpu == "portable" ? "portable" : "avx2";
  EXPECT_EQ(path_of(run("info", "env CAPSFLOW_SIMD=avx2 "), "vector     "), avx2_or_less);
  EXPECT_EQ(path_of(run("info", "env -u CAPSFLOW_SIMD CAPSFLOW_NO_AVX512=1 "), "vector     "), avx2_or_less);
  expect_input_error(run("info", "env CAPSFLOW_SIMD=avx9 "), {"CAPSFLOW_SIMD", "'avx9'", "portable, avx2 or avx512"});
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv --out U.csv",
                         "env CAPSFLOW_SIMD=AVX2 "),
                     {"CAPSFLOW_SIMD", "'AVX2'"});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, UsageErrorsExitTwo) {
  expect_input_error(run(""), {"subcommand"});
  expect_input_error(run("frobnicate"), {});
  expect_input_error(run("green cfg.toml --targets targets.csv --out U.csv"), {"--sources"});
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv"), {"--out"});
  expect_input_error(green("--bogus"), {"--bogus"});
  expect_input_error(green("--threads two"), {"--threads"});
  expect_input_error(green("--threads -1"), {"--threads", ">= 0"});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, BadConfig) {
  write("bad.toml", "[domain]\nH = -4\nLx = 8\nLz = 8\n");
  expect_input_error(green("", "bad.toml"), {"bad.toml", "[domain] H", "> 0"});
  write("bad.toml", "[domain]\nH = 4\nLx = 8\nLz = 8\nwidth = 2\n");
  expect_input_error(green("", "bad.toml"), {"bad.toml", "[domain] width", "unknown key"});
  write("bad.toml", "[domain]\nH = 4\nLx = 8\nLz = 8\n[ggem]\ncutoff = 5\n");
  expect_input_error(green("", "bad.toml"), {"bad.toml", "Lx = 8 is too small for the cutoff 5"});
  write("bad.toml", "[domain\nH = 4\n");
  expect_input_error(green("", "bad.toml"), {"bad.toml:1:"});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, MissingFiles) {
  expect_input_error(green("", "none.toml"), {"none.toml"});
  expect_input_error(green("", "cfg.toml", "none.csv"), {"none.csv", "cannot open"});
  expect_input_error(green("", "cfg.toml", "sources.csv", "none.csv"), {"none.csv", "cannot open"});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, MalformedCsv) {
  write("bad.csv", "x,y,z,fx,fy,fz\n1,2,3,0,0,0\n1,2,3,0,zero,0\n");
  expect_input_error(green("", "cfg.toml", "bad.csv"), {"bad.csv:3:", "(fy)", "'zero'"});
  write("bad.csv", "x,y,z\n1,2\n");
  expect_input_error(green("", "cfg.toml", "sources.csv", "bad.csv"), {"bad.csv:2:", "expected 3 fields"});
  write("bad.csv", "x,y,z,fx,fy\n");
  expect_input_error(green("", "cfg.toml", "bad.csv"), {"bad.csv:1:", "header"});
  write("bad.csv", "x,y,z\n");
  expect_input_error(green("", "cfg.toml", "sources.csv", "bad.csv"), {"bad.csv", "no data rows"});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, PointsOutsideTheSlit) {
  write("bad.csv", "x,y,z,fx,fy,fz\n1,2,3,0,0,0\n1,5,3,0,0,0\n");
  expect_input_error(green("", "cfg.toml", "bad.csv"), {"bad.csv:3:", "row 2", "y = 5", "H = 4"});
  write("bad.csv", "x,y,z\n1,-0.5,3\n");
  expect_input_error(green("", "cfg.toml", "sources.csv", "bad.csv"), {"bad.csv:2:", "row 1", "y = -0.5"});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, UnknownBackend) {
  expect_input_error(green("--backend gpu"), {"--backend", "\"gpu\""});
  write("bad.toml", std::string(kConfig) + "[run]\nbackend = \"cuda\"\n");
  expect_input_error(green("", "bad.toml"), {"bad.toml", "[run] backend", "\"cuda\""});
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, DeviceBackendUnavailable) {
  if (capsflow::device_count() > 0) GTEST_SKIP() << "a device is visible: this build can run 'device'";
  // Without the test-only host-fallback switch (ctest sets it for the device tests), a build without a visible device
  // refuses 'device', also an offload build: never a silent fallback to the host.
  const std::string no_switch = "env -u CAPSFLOW_TEST_DEVICE_HOST_FALLBACK ";
  expect_input_error(run("green cfg.toml --sources sources.csv --targets targets.csv --out U.csv --backend device",
                         no_switch),
                     {"--backend", "'device' is not available"});
  write("bad.toml", std::string(kConfig) + "[run]\nbackend = \"device\"\n");
  expect_input_error(run("green bad.toml --sources sources.csv --targets targets.csv --out U.csv", no_switch),
                     {"bad.toml: [run] backend", "'device' is not available"});
  const Result r = run("run --backend device --output r.h5", no_switch);  // the demo: a note line, then the error
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("capsflow: error: --backend: backend 'device' is not available"), std::string::npos) << r.err;
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, ExistingOutputUntouched) {
  write("U.csv", "precious\n");
  expect_input_error(green(), {"U.csv", "already exists", "--force"});
  EXPECT_EQ(read("U.csv"), "precious\n");
  // Errors with --force leave it untouched as well.
  write("bad.csv", "x,y,z\n1,9,3\n");
  expect_input_error(green("--force", "cfg.toml", "sources.csv", "bad.csv"), {"bad.csv:2:"});
  expect_input_error(green("--force --backend gpu"), {"--backend"});
  EXPECT_EQ(read("U.csv"), "precious\n");
  EXPECT_EQ(extra_files(), std::vector<std::string>{"U.csv"});  // no temporary left behind
}

// ---- needs a working GgemSolver ---------------------------------------------------------------------------

std::vector<std::vector<double>> parse_rows(const std::string& text, std::string& header) {
  std::istringstream in(text);
  std::getline(in, header);
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::istringstream ls(line);
    std::string field;
    while (std::getline(ls, field, ',')) row.push_back(std::strtod(field.c_str(), nullptr));
    rows.push_back(row);
  }
  return rows;
}

void expect_velocity_file(const std::string& text) {
  std::string header;
  const auto rows = parse_rows(text, header);
  EXPECT_EQ(header, "x,y,z,ux,uy,uz");
  std::string th;
  const auto targets = parse_rows(kTargets, th);
  ASSERT_EQ(rows.size(), targets.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), 6u) << "row " << i;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(rows[i][k], targets[i][k]) << "row " << i << " column " << k;
    for (int k = 3; k < 6; ++k) EXPECT_TRUE(std::isfinite(rows[i][k])) << "row " << i << " column " << k;
  }
}

TEST_F(Cli, RunInputErrorsExitTwoAndWriteNothing) {
  write("bad.toml", "[domain]\nH = 8.0\nLx = 8.0\nLz = 8.0\n[[species]]\nname = \"s\"\nca = 0.2\n"
                    "[[capsule]]\nspecies = \"s\"\ncenter = [4.0, 0.5, 4.0]\n[time]\nend = 1.0\n");
  Result r = run("run bad.toml");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("bad.toml"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[[capsule]] 1"), std::string::npos) << r.err;
  EXPECT_TRUE(extra_files().empty());

  r = run("run --restart missing.checkpoint.h5");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("missing.checkpoint.h5"), std::string::npos) << r.err;

  r = run("run bad.toml --restart x.h5");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("not both"), std::string::npos) << r.err;

  r = run("run cfg.toml");  // a green-only file: no species, no capsules
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("[[species]]"), std::string::npos) << r.err;
  EXPECT_TRUE(extra_files().empty());
}

TEST_F(Cli, SetOverridesAreCheckedLikeFileKeys) {
  // The same mistake in the file and as --set: the same message after the origin, status 2, nothing written.
  write("run.toml", "[domain]\nH = 8.0\nLx = 8.0\nLz = 8.0\n[[species]]\nname = \"s\"\nca = 0.2\n"
                    "[[capsule]]\nspecies = \"s\"\ncenter = [4.0, 4.0, 4.0]\n[time]\nend = 1.0\n");
  write("bad.toml", "[domain]\nH = 8.0\nLx = 8.0\nLz = 8.0\n[[species]]\nname = \"s\"\nca = 0.2\n"
                    "[[capsule]]\nspecies = \"s\"\ncenter = [4.0, 4.0, 4.0]\n[time]\nend = 1.0\ncfl = -1\n");
  const Result file = run("run bad.toml");
  const Result over = run("run run.toml --set time.cfl=-1");
  expect_input_error(file, {"bad.toml: [time] cfl: expected a finite number > 0, got integer -1"});
  expect_input_error(over, {"--set time.cfl: expected a finite number > 0, got integer -1"});
  const Result unknown = run("run run.toml --set time.cfll=1");
  expect_input_error(unknown, {"--set time.cfll: expected one of the keys of [time] (", "got unknown key 'cfll'"});
  expect_input_error(run("run run.toml --set species.s.ca=0 --set time.end=2"), {"--set species.s.ca: expected"});
  expect_input_error(run("run run.toml --set capsule.1.center=[4.0,0.5,4.0]"),
                     {"--set capsule.1.center: capsule 1 at y = 0.5 crosses the wall"});
  expect_input_error(run("run run.toml --end -1"), {"--end: expected a finite number > 0"});
  expect_input_error(green("--set domain.H=-4"), {"--set domain.H: expected a finite number > 0, got integer -4"});
  std::vector<std::string> left = extra_files();
  left.erase(std::remove(left.begin(), left.end(), "run.toml"), left.end());
  EXPECT_TRUE(left.empty()) << left.front();
  // --help names the option and its syntax.
  const Result help = run("run --help");
  EXPECT_NE(help.out.find("--set"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("section.key=value"), std::string::npos) << help.out;
}

TEST_F(Cli, WithSolverRestartRefusesPhysicsOverrides) {
  write("run.toml", "[domain]\nH = 6.0\nLx = 6.2\nLz = 6.2\n[capsules]\nmesh_level = 1\n[[species]]\nname = \"s\"\n"
                    "ca = 0.2\n[[capsule]]\nspecies = \"s\"\ncenter = [3.0, 3.0, 3.0]\n[time]\nend = 0.05\n"
                    "[output]\nfile = \"r.h5\"\nevery = 0.05\n");
  ASSERT_EQ(run("run run.toml -q").status, 0);
  const std::string before = read("r.h5");
  expect_input_error(run("run --restart r.checkpoint.h5 --set capsules.inflation=0.2 --end 0.1"),
                     {"--set capsules.inflation: cannot change when continuing a run (--restart)", "time.end"});
  EXPECT_EQ(read("r.h5"), before);
  const Result ok = run("run --restart r.checkpoint.h5 --set time.end=0.1 --set output.frames_every=0.05 -q");
  EXPECT_EQ(ok.status, 0) << ok.err;
}

TEST_F(Cli, DryRunPrintsTheResolvedPresetAndWritesNothing) {
  const std::string src = source_dir();
  if (src.empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  const std::string set_a = src + "/examples/presets/set_a.toml";
  const Result r = run("run " + set_a + " --set suspension.seed=3 --dry-run");
  ASSERT_EQ(r.status, 0) << r.err;
  // The resolved set A with seed 3: stdout is TOML (the summary lines are comments) that reads back as the preset
  // with the override applied.
  write("resolved.toml", r.out);
  const capsflow::Config back = capsflow::load_config((dir_ / "work" / "resolved.toml").string());
  const capsflow::Config want = capsflow::parse_config(slurp(set_a), set_a, {"suspension.seed=3"});
  auto body = [](const std::string& toml) { return toml.substr(toml.find('\n')); };  // past the "from <file>" line
  EXPECT_EQ(body(capsflow::to_toml(back)), body(capsflow::to_toml(want)));
  EXPECT_EQ(back.suspension->seed, 3u);
  EXPECT_EQ(*back.suspension->count, 50);
  EXPECT_EQ(back.domain.H, 10.155);
  EXPECT_NE(r.out.find("\nseed = 3\n"), std::string::npos) << r.out;
  for (const char* s : {"# grid", "grid points", "# memory    needs about", "may use", "# cost      ESTIMATE",
                        "per strain unit", "fresh placement", "developed suspension", "nothing was written"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << " not in:\n" << r.out;
  // Nothing written: the working directory holds only what the test put there.
  std::vector<std::string> left = extra_files();
  left.erase(std::remove(left.begin(), left.end(), "resolved.toml"), left.end());
  EXPECT_TRUE(left.empty()) << left.front();

  // A bad override fails the dry run like the run: status 2, one line.
  expect_input_error(run("run " + set_a + " --set suspension.seed=-3 --dry-run"),
                     {"--set suspension.seed: expected an integer >= 0, got integer -3"});
  // The embedded demo's dry run creates no directory.
  ASSERT_EQ(run("run --dry-run --output demo/d.h5").status, 0);
  EXPECT_FALSE(exists("demo"));
}

TEST_F(Cli, AGridThatCannotFitIsRefusedBeforeAnyFile) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: an address-space limit stops it";
#endif
  const std::string src = source_dir();
  if (src.empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  // The pair box at alpha 4 needs about 1.6 GB; under a 1.2 GB address-space limit it is refused with both sizes.
  const std::string pair = src + "/examples/presets/pair.toml";
  for (const char* extra : {"", " --dry-run"}) {
    const Result r = run_limited("run " + pair + " --set ggem.alpha=4 --set output.file=p.h5" + extra, 1200000);
    expect_input_error(r, {"--set ggem.alpha: the run needs about 1.6 GiB of memory (grid 240 x 240 x 379 = "
                           "21830400 points", "but this process may use 1.1 GiB (RLIMIT_AS"});
    EXPECT_TRUE(extra_files().empty()) << extra_files().front();
  }
}

TEST_F(Cli, WithSolverRunEmbeddedDemoShort) {
  // The README's main command, cut to a few steps: it must run, write its three files and say where they are.
  const Result r = run("run --end 0.06 --output demo/demo.h5 --progress 0");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("embedded demo"), std::string::npos) << r.err;
  for (const char* f : {"demo/demo.h5", "demo/demo.xdmf", "demo/demo.checkpoint.h5"})
    EXPECT_TRUE(exists(f)) << f;
  EXPECT_NE(r.err.find("demo/demo.xdmf"), std::string::npos) << r.err;
  // A second run refuses to overwrite.
  const Result again = run("run --end 0.06 --output demo/demo.h5");
  EXPECT_EQ(again.status, 2);
  EXPECT_NE(again.err.find("demo.h5"), std::string::npos) << again.err;
}

TEST_F(Cli, WithSolverRunSigintWritesACheckpointThatRestarts) {
  // A real SIGINT to a running process: exit 130 after a checkpoint; the restart continues from it.
  const fs::path work = dir_ / "work";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (::chdir(work.c_str()) != 0) ::_exit(99);
    const int devnull = ::open("/dev/null", O_WRONLY);
    ::dup2(devnull, 2);
    ::execl(binary_.c_str(), binary_.c_str(), "run", "--output", "s/demo.h5", "--end", "100", "--progress", "0",
            static_cast<char*>(nullptr));
    ::_exit(98);
  }
  // Wait for the first record (the output exists and the loop runs), then interrupt.
  for (int i = 0; i < 600 && !fs::exists(work / "s" / "demo.checkpoint.h5"); ++i) ::usleep(100000);
  ::usleep(300000);
  ::kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WEXITSTATUS(status), 130);
  ASSERT_TRUE(exists("s/demo.checkpoint.h5"));
  // The interrupt lands at a strain that depends on the machine's speed: continue a little beyond it (an --end below
  // the checkpoint's strain is refused).
  char end[32];
  std::snprintf(end, sizeof end, "%.6f", capsflow::read_checkpoint(work / "s" / "demo.checkpoint.h5").state.time + 0.03);
  const Result r = run("run --restart s/demo.checkpoint.h5 --end " + std::string(end) + " --progress 0");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("continuing from strain"), std::string::npos) << r.err;
}

TEST_F(Cli, WithSolverGreenWritesOneRowPerTarget) {
  const Result r = green("--backend serial");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;  // the summary goes to stderr
  EXPECT_NE(r.err.find("nx"), std::string::npos) << r.err;
  expect_velocity_file(read("U.csv"));
  EXPECT_EQ(extra_files(), std::vector<std::string>{"U.csv"});

  // A second run refuses to replace it; --force replaces it, --quiet prints nothing.
  expect_input_error(green(), {"already exists"});
  write("U.csv", "old\n");
  const Result f = green("--force --quiet --backend threads --threads 2");
  ASSERT_EQ(f.status, 0) << f.err;
  EXPECT_TRUE(f.err.empty()) << f.err;
  expect_velocity_file(read("U.csv"));
  EXPECT_EQ(extra_files(), std::vector<std::string>{"U.csv"});
}

TEST_F(Cli, WithSolverExampleRuns) {
  const std::string src = source_dir();
  if (src.empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  const std::string ex = src + "/examples/";
  const Result r = run("green " + ex + "green.toml --sources " + ex + "sources.csv --targets " + ex +
                       "targets.csv --out U.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  std::string header;
  const auto rows = parse_rows(read("U.csv"), header);
  EXPECT_EQ(header, "x,y,z,ux,uy,uz");
  EXPECT_EQ(rows.size(), 5u);
}

}  // namespace
