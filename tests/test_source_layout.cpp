// The house's structure as a test (issue 19; docs/method.md "Source layout"): src/host is split into wings, and an
// include may only go down the order
//     base < state < solver < physics < run < cli,       analysis: base only (beside the physics, below cli)
// src/kernels includes nothing of src/host, and no header takes part in an include cycle (the global-solve plans used
// to include the solver that owns them). Reads the sources, so it fails on the commit that adds a wrong arrow.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

#ifndef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
#define CAPSFLOW_TEST_DEFAULT_SOURCE_DIR ""
#endif

fs::path source_dir() {
  const char* v = std::getenv("CAPSFLOW_SOURCE_DIR");
  return fs::path(v && *v ? v : CAPSFLOW_TEST_DEFAULT_SOURCE_DIR);
}

const std::map<std::string, int> kRank = {{"base", 0}, {"state", 1}, {"solver", 2}, {"physics", 3},
                                          {"run", 4},  {"analysis", 3}, {"cli", 6}};

// "host/<wing>/<file>" includes of one file.
// (A plain parse: std::regex trips GCC 12's -Wmaybe-uninitialized under the sanitizers.)
std::vector<std::string> host_includes(const fs::path& file) {
  std::vector<std::string> out;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    std::size_t p = line.find_first_not_of(" \t");
    if (p == std::string::npos || line[p] != '#') continue;
    p = line.find_first_not_of(" \t", p + 1);
    if (p == std::string::npos || line.compare(p, 7, "include") != 0) continue;
    const std::size_t q = line.find('"', p + 7);
    if (q == std::string::npos || line.compare(q + 1, 5, "host/") != 0) continue;
    const std::size_t e = line.find('"', q + 1);
    if (e != std::string::npos) out.push_back(line.substr(q + 1, e - q - 1));
  }
  return out;
}

std::string wing_of(const std::string& include) {  // "host/solver/x.hpp" -> "solver"
  const auto a = include.find('/'), b = include.find('/', a + 1);
  return b == std::string::npos ? "" : include.substr(a + 1, b - a - 1);
}

bool is_source(const fs::path& p) { return p.extension() == ".cpp" || p.extension() == ".hpp"; }

}  // namespace

TEST(SourceLayout, EveryHostFileLivesInAWingAndIncludesOnlyDownward) {
  const fs::path host = source_dir() / "src" / "host";
  if (!fs::is_directory(host)) GTEST_SKIP() << "sources not found at " << host;
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(host)) {
    if (!e.is_regular_file() || !is_source(e.path())) continue;
    const fs::path rel = fs::relative(e.path(), host);
    ASSERT_EQ(std::distance(rel.begin(), rel.end()), 2) << rel << ": every file of src/host belongs in a wing folder";
    const std::string wing = rel.begin()->string();
    ASSERT_TRUE(kRank.count(wing)) << rel << ": unknown wing '" << wing << "'";
    ++files;
    for (const std::string& inc : host_includes(e.path())) {
      const std::string to = wing_of(inc);
      ASSERT_TRUE(kRank.count(to)) << rel << " includes " << inc << ", outside the wings";
      if (wing == "analysis") {
        EXPECT_TRUE(to == "analysis" || to == "base") << rel << " includes " << inc
                                                      << ": the analysis wing depends on nothing of the physics";
      } else if (to == "analysis") {
        EXPECT_EQ(wing, "cli") << rel << " includes " << inc << ": only the commands use the analysis wing";
      } else {
        EXPECT_LE(kRank.at(to), kRank.at(wing)) << rel << " includes " << inc << ": an include up the wings";
      }
    }
  }
  EXPECT_GT(files, 40);
}

TEST(SourceLayout, KernelsIncludeNothingOfTheHost) {
  const fs::path kernels = source_dir() / "src" / "kernels";
  if (!fs::is_directory(kernels)) GTEST_SKIP() << "sources not found at " << kernels;
  for (const auto& e : fs::directory_iterator(kernels)) {
    if (!e.is_regular_file() || !is_source(e.path())) continue;
    EXPECT_TRUE(host_includes(e.path()).empty()) << e.path().filename() << " includes host code";
  }
}

TEST(SourceLayout, NoIncludeCycle) {
  const fs::path src = source_dir() / "src";
  if (!fs::is_directory(src / "host")) GTEST_SKIP() << "sources not found at " << src;
  std::map<std::string, std::vector<std::string>> edges;  // "host/wing/x.hpp" -> its host includes
  for (const auto& e : fs::recursive_directory_iterator(src / "host"))
    if (e.is_regular_file() && e.path().extension() == ".hpp")
      edges["host/" + fs::relative(e.path(), src / "host").generic_string()] = host_includes(e.path());
  std::map<std::string, int> state;  // 0 new, 1 on the path, 2 done
  std::vector<std::string> path;
  std::function<void(const std::string&)> visit = [&](const std::string& h) {
    state[h] = 1;
    path.push_back(h);
    for (const std::string& to : edges[h]) {
      if (state[to] == 1) {
        std::string cycle;
        for (auto it = std::find(path.begin(), path.end(), to); it != path.end(); ++it) cycle += *it + " -> ";
        ADD_FAILURE() << "include cycle: " << cycle << to;
      } else if (state[to] == 0) {
        visit(to);
      }
    }
    path.pop_back();
    state[h] = 2;
  };
  for (const auto& [h, _] : edges)
    if (state[h] == 0) visit(h);
  EXPECT_GT(edges.size(), 30u);
}

// Issue 36: the Simulation is a thin orchestrator over its parts (force terms, the velocity model, the step rule,
// the integrator, constraints, diagnostics), each taking its inputs explicitly. A part that includes simulation.hpp
// would read the Simulation's members again and close the circle the redesign removed; only the orchestrator and the
// stability probe (which drives a whole Simulation) may include it in the physics wing.
TEST(SourceLayout, PhysicsPartsDoNotIncludeTheSimulation) {
  const fs::path physics = source_dir() / "src" / "host" / "physics";
  if (!fs::is_directory(physics)) GTEST_SKIP() << "sources not found at " << physics;
  const std::set<std::string> allowed = {"simulation.hpp", "simulation.cpp", "stability_probe.hpp",
                                         "stability_probe.cpp"};
  int parts = 0;
  for (const auto& e : fs::directory_iterator(physics)) {
    if (!e.is_regular_file() || !is_source(e.path())) continue;
    const std::string name = e.path().filename().string();
    if (allowed.count(name)) continue;
    for (const std::string& inc : host_includes(e.path()))
      EXPECT_NE(inc, "host/physics/simulation.hpp") << name << " includes the Simulation: take its inputs explicitly";
    ++parts;
  }
  // The parts themselves are where the structure says (docs/method.md "Source layout").
  for (const char* part : {"force_terms", "velocity_model", "step_rule", "ab2_integrator", "constraints",
                           "flow_diagnostics", "step_records"})
    EXPECT_TRUE(fs::exists(physics / (std::string(part) + ".hpp"))) << part << ".hpp is missing";
  EXPECT_GT(parts, 10);
}

// The step formula has one home (issue 36): [time] cfl and bending_cfl are read from the Config in the step rule
// and nowhere else outside the configuration reader (the run and the dry run's estimate had drifted apart once).
TEST(SourceLayout, TheStepFormulaIsReadInOneFile) {
  const fs::path src = source_dir() / "src";
  if (!fs::is_directory(src / "host")) GTEST_SKIP() << "sources not found at " << src;
  std::set<std::string> readers;
  for (const auto& e : fs::recursive_directory_iterator(src)) {
    if (!e.is_regular_file() || !is_source(e.path())) continue;
    std::ifstream in(e.path());
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (text.find("time.cfl") != std::string::npos || text.find("time.bending_cfl") != std::string::npos)
      readers.insert(fs::relative(e.path(), src).generic_string());
  }
  // The reader (config.cpp, or the files it is split into) may read them; nothing else but the step rule.
  for (auto it = readers.begin(); it != readers.end();)
    it = it->rfind("host/physics/config", 0) == 0 ? readers.erase(it) : std::next(it);
  EXPECT_EQ(readers, (std::set<std::string>{"host/physics/step_rule.cpp"}));
}
