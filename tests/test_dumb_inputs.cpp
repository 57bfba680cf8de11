// Dumb inputs, in FINUFFT's manner: every configuration key and every command-line option is fed zero, negative, NaN,
// infinity, huge, wrongly typed and empty values. Driven by the definitions themselves, so that a new key or option is
// covered the day it appears:
//   - configuration keys from config_keys() (config_schema.hpp: the readers run in a describing mode);
//   - subcommands and options from the executable's own --help (CLI11 lists every option that takes a value).
// A refused value must give exit status 2, one line naming the key (or option) and what was expected, and no file
// created or changed. An accepted value must be one the key's declared range accepts (never NaN, infinity, a wrong
// type or an empty string).
#include <gtest/gtest.h>

#include <cctype>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/config_schema.hpp"
#include "host/base/errors.hpp"
#include "support/cli_runner.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace capsflow;
using capsflow::test::CliResult;
using capsflow::test::run_capsflow;
using capsflow::test::shell_quote;
using capsflow::test::snapshot_files;

// A configuration as sections of key = value lines (values as TOML text), so a probe can replace one key.
struct Doc {
  std::vector<std::pair<std::string, std::map<std::string, std::string>>> tables;  // in order; arrays repeat a name
  std::string render() const {
    std::string o;
    for (const auto& [name, keys] : tables) {
      const bool array = name == "species" || name == "capsule";
      o += (array ? "[[" : "[") + name + (array ? "]]\n" : "]\n");
      for (const auto& [k, v] : keys) o += k + " = " + v + "\n";
    }
    return o;
  }
  // The first table called `name` (created empty at the end if absent).
  std::map<std::string, std::string>& table(const std::string& name) {
    for (auto& t : tables)
      if (t.first == name) return t.second;
    tables.push_back({name, {}});
    return tables.back().second;
  }
};

// One pinned capsule in shear (explicit [[capsule]]) or a random suspension ([suspension]): between them every
// section is present. The output goes to out/run.h5, so that "nothing written" is easy to see.
Doc base_doc(bool suspension) {
  Doc d;
  d.tables.push_back({"domain", {{"H", "6.0"}, {"Lx", "8.0"}, {"Lz", "8.0"}}});
  d.tables.push_back({"ggem", {{"alpha", "4.0"}}});
  d.tables.push_back({"run", {{"backend", "\"serial\""}}});
  d.tables.push_back({"flow", {{"type", "\"shear\""}}});
  d.tables.push_back({"capsules", {{"mesh_level", "1"}}});
  d.tables.push_back({"species", {{"name", "\"a\""}, {"ca", "0.2"}}});
  if (suspension)
    d.tables.push_back({"suspension", {{"volume_fraction", "0.01"}}});
  else
    d.tables.push_back({"capsule", {{"species", "\"a\""}, {"center", "[4.0, 3.0, 4.0]"}, {"pinned", "true"}}});
  d.tables.push_back({"time", {{"end", "0.05"}}});
  d.tables.push_back({"output", {{"file", "\"out/run.h5\""}}});
  return d;
}

struct Probe {
  const char* name;
  std::string toml;  // the value as TOML text
};

// The values every key goes through. Numbers are given both as integers and floats where TOML tells them apart.
std::vector<Probe> probes_for(const ConfigKey& k) {
  std::vector<Probe> p = {{"zero", "0"},        {"zero float", "0.0"},          {"negative", "-1"},
                          {"negative float", "-1.5"}, {"nan", "nan"},           {"infinity", "inf"},
                          {"-infinity", "-inf"}, {"huge", "1e300"},            {"huge integer", "9223372036854775807"},
                          {"string", "\"x\""},  {"empty string", "\"\""},       {"boolean", "true"},
                          {"empty array", "[]"}, {"table", "{ a = 1 }"}};
  if (k.type == "numbers") {
    const std::size_t n = k.length ? k.length : 1;
    auto arr = [n](const std::string& v, std::size_t i) {
      std::string s = "[";
      for (std::size_t j = 0; j < n; ++j) s += (j ? ", " : "") + (j == i ? v : std::string("3.0"));
      return s + "]";
    };
    for (const char* v : {"nan", "inf", "-1e300", "1e300", "\"x\"", "0", "-1"}) p.push_back({"element", arr(v, n - 1)});
    p.push_back({"one element too many", arr("3.0", n) + "" });
    p.back().toml.insert(p.back().toml.size() - 1, ", 3.0");
  }
  return p;
}

std::string label(const ConfigKey& k) { return k.array_section ? "[[" + k.section + "]] 1 " : "[" + k.section + "] "; }

bool finite_number_literal(const std::string& t, double& v) {
  char* end = nullptr;
  v = std::strtod(t.c_str(), &end);
  return !t.empty() && end && *end == '\0' && std::isfinite(v) && t != "nan" && t != "inf";
}

class DumbInputs : public testing::Test {
 protected:
  void SetUp() override {
    if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
    work_ = tmp_.path / "work";
    fs::create_directories(work_ / "out");
  }
  capsflow::test::TempDir tmp_;
  fs::path work_;
};

TEST_F(DumbInputs, EveryConfigurationKey) {
  const std::vector<ConfigKey> keys = config_keys();
  ASSERT_GT(keys.size(), 30u);
  // The base documents are valid: what a probe changes is the only thing wrong.
  for (bool susp : {false, true}) {
    Config c = parse_config(base_doc(susp).render(), "base.toml");
    EXPECT_NO_THROW(validate_run_config(c)) << base_doc(susp).render();
  }
  int refused = 0, accepted = 0;
  std::string accepted_list;
  for (const ConfigKey& k : keys) {
    for (const Probe& pr : probes_for(k)) {
      Doc d = base_doc(k.section == "suspension");
      d.table(k.section)[k.key] = pr.toml;
      const std::string text = d.render();
      SCOPED_TRACE(label(k) + k.key + " = " + pr.toml + " (" + pr.name + ")");
      std::string error;
      try {
        Config c = parse_config(text, "probe.toml");
        validate_run_config(c);
      } catch (const InputError& e) {
        error = e.what();
      }
      if (error.empty()) {
        // Accepted: only a value the key's type and range accept.
        ++accepted;
        accepted_list += " " + label(k) + k.key + "=" + pr.toml + ";";
        double v = 0.0;
        if (k.type == "number" || k.type == "integer") {
          ASSERT_TRUE(finite_number_literal(pr.toml, v)) << "accepted a non-number";
          EXPECT_TRUE(k.accepts(v)) << "accepted outside " << k.expected;
          if (k.type == "integer") {
            EXPECT_EQ(pr.toml.find_first_of(".e"), std::string::npos);
          }
        } else if (k.type == "boolean") {
          EXPECT_EQ(pr.toml, "true");
        } else if (k.type == "string") {
          EXPECT_EQ(pr.toml, "\"x\"");
        } else if (k.type == "choice") {
          ADD_FAILURE() << "a choice accepted a dumb value";
        } else if (k.type == "numbers") {
          EXPECT_EQ(pr.toml.find_first_of("nix\""), std::string::npos) << "accepted a non-finite or non-number";
        }
        continue;
      }
      ++refused;
      // The same file through the executable: exit 2, one line that names the key and what was expected, nothing
      // written.
      std::ofstream(work_ / "probe.toml", std::ios::binary) << text;
      const auto before = snapshot_files(work_);
      const CliResult r = run_capsflow(work_, "run probe.toml", 60);
      EXPECT_EQ(r.status, 2) << r.err;
      EXPECT_EQ(r.err.rfind("capsflow: error: probe.toml", 0), 0u) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_NE(r.err.find(k.key), std::string::npos) << "the key is not named: " << r.err;
      EXPECT_TRUE(r.err.find("expected") != std::string::npos || r.err.find("need") != std::string::npos) << r.err;
      EXPECT_EQ(snapshot_files(work_), before);
      if (HasFailure()) return;  // one clear failure rather than hundreds
    }
  }
  EXPECT_GT(refused, 10 * static_cast<int>(keys.size()));
  std::cerr << keys.size() << " keys: " << refused << " dumb values refused, " << accepted << " valid ones accepted:" << accepted_list << "\n";
}

// ---------------------------------------------------------------------------------------------------------------
// Command-line options

struct CliOption {
  std::string command, option;
};

// CLI11's help lines, read by hand (std::regex trips GCC 12's maybe-uninitialized warning under the sanitizers).
bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; }

// "  NAME  +Description": a subcommand of `capsflow --help`; "" otherwise.
std::string subcommand_of(const std::string& line) {
  if (line.rfind("  ", 0) != 0 || line.size() < 3 || !std::islower(static_cast<unsigned char>(line[2]))) return "";
  std::size_t i = 2;
  while (i < line.size() && (std::islower(static_cast<unsigned char>(line[i])) ||
                             std::isdigit(static_cast<unsigned char>(line[i])) || line[i] == '-'))
    ++i;
  const std::size_t end = i;
  while (i < line.size() && line[i] == ' ') ++i;
  return (i - end >= 2 && i < line.size()) ? line.substr(2, end - 2) : "";
}

// "  [-x,]--name TYPE ...": an option that takes a value (a type name after one space); "" otherwise.
std::string value_option_of(const std::string& line) {
  if (line.rfind("  ", 0) != 0) return "";
  std::size_t i = 2;
  if (line.size() > i + 2 && line[i] == '-' && line[i + 1] != '-' && line[i + 2] == ',') i += 3;
  if (line.compare(i, 2, "--") != 0 || line.size() < i + 3 || !std::islower(static_cast<unsigned char>(line[i + 2])))
    return "";
  const std::size_t start = i;
  i += 2;
  while (i < line.size() && is_word_char(line[i])) ++i;
  const bool value = i + 1 < line.size() && line[i] == ' ' && line[i + 1] != ' ';
  return value ? line.substr(start, i - start) : "";
}

// Subcommands from `capsflow --help`, and for each the options that take a value from `capsflow CMD --help`.
std::vector<CliOption> cli_options(const fs::path& work) {
  std::vector<CliOption> out;
  const std::string top = run_capsflow(work, "--help").out;
  bool in_subs = false;
  std::istringstream lines(top);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("Subcommands:", 0) == 0) in_subs = true;
    const std::string cmd = in_subs ? subcommand_of(line) : "";
    if (cmd.empty()) continue;
    std::istringstream help(run_capsflow(work, cmd + " --help").out);
    for (std::string l; std::getline(help, l);)
      if (const std::string opt = value_option_of(l); !opt.empty()) out.push_back({cmd, opt});
  }
  return out;
}

TEST_F(DumbInputs, EveryCommandLineOption) {
  std::ofstream(work_ / "run.toml") << base_doc(false).render();
  std::ofstream(work_ / "green.toml") << "[domain]\nH = 4.0\nLx = 8.0\nLz = 8.0\n";
  std::ofstream(work_ / "s.csv") << "x,y,z,fx,fy,fz\n4.0,2.0,4.0,1.0,0.0,0.0\n";
  std::ofstream(work_ / "t.csv") << "x,y,z\n4.5,2.0,4.0\n";
  std::ofstream(work_ / "sweep.toml") << "base = \"run.toml\"\nroot = \"sw\"\n[[point]]\ntime.end = 0.5\n";
  // What each command needs besides the option under test, so that the option is what is judged. A command not
  // listed here (a new one) is probed with nothing else: it must still refuse every dumb value with exit 2.
  const std::map<std::string, std::string> base = {
      {"green", "green.toml --sources s.csv --targets t.csv --out U.csv"},
      {"run", "run.toml"},
      {"demo", "--out demo"},
      {"analyze", "out --out A"},
      {"figures", "out --out F"},
      {"render", "out --out R"},
      {"sweep", "sweep.toml"},  // the default verb, --plan, writes nothing
      {"probe", "run.toml"},
      {"flow", "out --plane z=1 --out F.h5"},
  };
  // Probe values that are valid for an option (a file or directory name, 0 threads, no progress lines, a far end):
  // they are not run, since they would do real work.
  const std::map<std::pair<std::string, std::string>, std::set<std::string>> valid = {
      {{"green", "--out"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"green", "--threads"}, {"0"}},
      {{"run", "--output"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"run", "--threads"}, {"0"}},
      {{"run", "--end"}, {"1e300"}},
      {{"run", "--progress"}, {"0", "1e300"}},
      {{"demo", "--out"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"demo", "--threads"}, {"0"}},
      {{"analyze", "--out"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"figures", "--out"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"render", "--out"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"probe", "--out"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"render", "--frame"}, {"0", "-1"}},      // the first and the last frame
      {{"flow", "--frame"}, {"0", "-1"}},
      {{"flow", "--spacing"}, {"1e300"}},        // the coarsest grid: the plane's corners
      {{"flow", "--threads"}, {"0"}},
      {{"render", "--time"}, {"0", "1e300"}},    // the frame nearest that strain
      // sweep: free-form #SBATCH values are Slurm's to judge; 0 means "none" or "from the estimate"; --task 0 is
      // the sweep's one point and would run it.
      {{"sweep", "--partition"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"sweep", "--account"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"sweep", "--mem"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"sweep", "--sbatch-extra"}, {"0", "-1", "nan", "inf", "1e300", "abc"}},
      {{"sweep", "--gpus-per-task"}, {"0"}},
      {{"sweep", "--max-parallel"}, {"0"}},
      {{"sweep", "--signal-seconds"}, {"0"}},
      {{"sweep", "--task"}, {"0"}},
      {{"sweep", "--time"}, {"0"}},
  };
  const std::vector<CliOption> opts = cli_options(work_);
  std::set<std::string> commands;
  for (const auto& o : opts) commands.insert(o.command);
  for (const char* c : {"green", "run", "demo", "analyze"}) EXPECT_TRUE(commands.count(c)) << c;
  int probed = 0;
  for (const CliOption& o : opts) {
    for (const std::string v : {"0", "-1", "nan", "inf", "1e300", "abc", ""}) {
      const auto it = valid.find({o.command, o.option});
      if (it != valid.end() && it->second.count(v)) continue;
      const auto b = base.find(o.command);
      const std::string args =
          o.command + " " + (b == base.end() ? "" : b->second) + " " + o.option + "=" + shell_quote(v);
      SCOPED_TRACE("capsflow " + args);
      const auto before = snapshot_files(work_);
      const CliResult r = run_capsflow(work_, args, 60);
      ++probed;
      EXPECT_EQ(r.status, 2) << r.err;
      EXPECT_EQ(r.err.rfind("capsflow: error: ", 0), 0u) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      // Named: the option, or the file it named.
      const bool named = r.err.find(o.option) != std::string::npos || (!v.empty() && r.err.find(v) != std::string::npos);
      EXPECT_TRUE(named) << r.err;
      EXPECT_EQ(snapshot_files(work_), before);
      if (HasFailure()) return;
    }
  }
  std::cerr << opts.size() << " options of " << commands.size() << " commands: " << probed << " dumb values refused\n";
}

}  // namespace
