// parse_config: defaults, every kind of error, and the one-line "<file>: [section] key: ..." messages.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/solver/sample_problems.hpp"

namespace capsflow {
namespace {

const char* kMinimal = R"(
[domain]
H = 4
Lx = 8.0
Lz = 8
)";

// The InputError message of parse_config(text), or "" when it parses.
std::string error_of(const std::string& text, const std::string& source = "case.toml") {
  try {
    parse_config(text, source);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Every message: one line that starts with the file name and contains each of `parts`.
void expect_error(const std::string& text, std::initializer_list<std::string> parts) {
  const std::string msg = error_of(text);
  ASSERT_FALSE(msg.empty()) << "no error for:\n" << text;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind("case.toml:", 0), 0u) << msg;
  for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
}

TEST(Config, DefaultsOfAMinimalFile) {
  const Config c = parse_config(kMinimal, "min.toml");
  EXPECT_EQ(c.source, "min.toml");
  EXPECT_EQ(c.domain.H, 4.0);
  EXPECT_EQ(c.domain.Lx, 8.0);
  EXPECT_EQ(c.domain.Lz, 8.0);
  EXPECT_EQ(c.domain.viscosity, 1.0);
  EXPECT_EQ(c.ggem.alpha, 4.0);
  EXPECT_EQ(c.ggem.alpha_hm, 0.5);
  EXPECT_EQ(c.ggem.nx, 0);
  EXPECT_EQ(c.ggem.nz, 0);
  EXPECT_EQ(c.ggem.ny, 0);
  EXPECT_EQ(c.ggem.cutoff, 0.875);  // 3.5 / alpha
  EXPECT_EQ(c.ggem.chebyshev_rule, "midchannel");
  EXPECT_EQ(c.run.backend, default_backend());
  EXPECT_EQ(c.run.threads, 0);
}

TEST(Config, EveryKeyRead) {
  const Config c = parse_config(std::string(kMinimal) + R"(
viscosity = 2.5
[ggem]
alpha = 2
alpha_hm = 2.0
nx = 16
nz = 24
ny = 8
chebyshev_rule = "mean"
[run]
backend = "threads"
threads = 3
)",
                                "all.toml");
  EXPECT_EQ(c.domain.viscosity, 2.5);
  EXPECT_EQ(c.ggem.alpha, 2.0);
  EXPECT_EQ(c.ggem.alpha_hm, 2.0);
  EXPECT_EQ(c.ggem.nx, 16);
  EXPECT_EQ(c.ggem.nz, 24);
  EXPECT_EQ(c.ggem.ny, 8);
  EXPECT_EQ(c.ggem.cutoff, 1.75);  // default follows alpha
  EXPECT_EQ(c.ggem.chebyshev_rule, "mean");
  EXPECT_EQ(c.run.backend, Backend::Threads);
  EXPECT_EQ(c.run.threads, 3);
}

TEST(Config, ExplicitCutoffAndDeviceBackendParse) {
  // 'device' parses everywhere; whether it can run is checked by require_backend, not by the config.
  const Config c = parse_config(std::string(kMinimal) + "[ggem]\ncutoff = 4\n[run]\nbackend = \"device\"\n", "c");
  EXPECT_EQ(c.ggem.cutoff, 4.0);
  EXPECT_EQ(c.run.backend, Backend::Device);
}

TEST(Config, UnknownSection) {
  expect_error(std::string(kMinimal) + "[flowz]\nrate = 1\n", {"[flowz]", "unknown section 'flowz'", "[domain]"});
  expect_error(std::string("speed = 1\n") + kMinimal, {"unknown top-level key 'speed'"});
}

// An integer beyond the int the key is stored in: the message states the upper bound as well, so it cannot read
// "expected an integer >= 8, got 9223372036854775807".
TEST(Config, IntegerBeyondItsStorageNamesTheUpperBound) {
  expect_error(std::string(kMinimal) + "[ggem]\nnx = 9223372036854775807\n",
               {"[ggem] nx: expected an integer >= 8 and <= 2147483647, got integer 9223372036854775807"});
  expect_error(std::string(kMinimal) + "[run]\nthreads = 2147483648\n",
               {"[run] threads: expected an integer >= 0 and <= 2147483647, got integer 2147483648"});
}

TEST(Config, SectionThatIsNotATable) {
  expect_error("run = 3\n" + std::string(kMinimal), {"[run]", "expected a table", "integer 3"});
}

TEST(Config, UnknownKey) {
  expect_error(std::string(kMinimal) + "Ly = 3\n", {"[domain] Ly", "unknown key 'Ly'", "H, Lx, Lz, viscosity"});
  expect_error(std::string(kMinimal) + "[ggem]\nalpha_h = 1\n", {"[ggem] alpha_h", "unknown key"});
  expect_error(std::string(kMinimal) + "[run]\nthread = 1\n", {"[run] thread", "unknown key"});
}

TEST(Config, MissingRequiredKeys) {
  expect_error("[domain]\nLx = 8\nLz = 8\n", {"[domain] H", "expected a finite number > 0", "required"});
  expect_error("[domain]\nH = 4\nLz = 8\n", {"[domain] Lx", "required"});
  expect_error("[domain]\nH = 4\nLx = 8\n", {"[domain] Lz", "required"});
  expect_error("", {"[domain] H", "required"});
}

TEST(Config, WrongTypes) {
  expect_error("[domain]\nH = \"4\"\nLx = 8\nLz = 8\n", {"[domain] H", "expected a finite number", "string \"4\""});
  expect_error("[domain]\nH = true\nLx = 8\nLz = 8\n", {"[domain] H", "boolean true"});
  expect_error("[domain]\nH = [4]\nLx = 8\nLz = 8\n", {"[domain] H", "an array"});
  // A float where an integer is expected is an error, even when integral.
  expect_error(std::string(kMinimal) + "[ggem]\nnx = 16.0\n", {"[ggem] nx", "expected an integer >= 8", "float 16"});
  expect_error(std::string(kMinimal) + "[run]\nthreads = 1.5\n", {"[run] threads", "expected an integer", "float 1.5"});
  expect_error(std::string(kMinimal) + "[run]\nbackend = 1\n", {"[run] backend", "\"serial\"", "integer 1"});
  expect_error(std::string(kMinimal) + "[ggem]\nchebyshev_rule = 2\n", {"[ggem] chebyshev_rule", "integer 2"});
}

TEST(Config, BadChoices) {
  expect_error(std::string(kMinimal) + "[run]\nbackend = \"gpu\"\n",
               {"[run] backend", "one of \"serial\", \"threads\", \"device\"", "string \"gpu\""});
  expect_error(std::string(kMinimal) + "[ggem]\nchebyshev_rule = \"max\"\n",
               {"[ggem] chebyshev_rule", "\"midchannel\", \"mean\"", "\"max\""});
}

// [ggem] tolerance sets alpha_hm and cutoff from the fits in slit_parameters.hpp; keys given explicitly win; the
// stored text keeps the resolved values explicit, so a restart reads back the same numbers.
TEST(Config, GgemToleranceSetsTheGridAndCutoffUnlessGiven) {
  const Config d = parse_config(kMinimal, "c");
  EXPECT_EQ(d.ggem.tolerance, 0.0);
  EXPECT_EQ(d.ggem.alpha_hm, 0.5);
  EXPECT_EQ(d.ggem.cutoff, 3.5 / 4.0);
  const Config t = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 5e-3\n", "c");
  EXPECT_EQ(t.ggem.tolerance, 5e-3);
  EXPECT_NEAR(t.ggem.alpha_hm, 0.545, 1e-3);       // sqrt(1.15 / ln(0.12 / 2.5e-3))
  EXPECT_NEAR(t.ggem.cutoff * 4.0, 2.931, 1e-3);  // sqrt(ln(6.2 / 2.5e-3) / 0.91)
  // A looser tolerance, a coarser grid and a shorter cutoff; a tighter one, the reverse.
  const Config loose = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 2e-2\n", "c");
  const Config tight = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 1e-4\n", "c");
  EXPECT_GT(loose.ggem.alpha_hm, t.ggem.alpha_hm);
  EXPECT_LT(tight.ggem.alpha_hm, t.ggem.alpha_hm);
  EXPECT_LT(loose.ggem.cutoff, t.ggem.cutoff);
  EXPECT_GT(tight.ggem.cutoff, t.ggem.cutoff);
  const Config e = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 5e-3\nalpha_hm = 0.4\ncutoff = 1\n", "c");
  EXPECT_EQ(e.ggem.alpha_hm, 0.4);
  EXPECT_EQ(e.ggem.cutoff, 1.0);
  // A whole run's configuration (set A's step problem with the tolerance instead of alpha_hm), stored and read back.
  const std::string run_text = set_a_step_problem_toml_at_tolerance("5e-3");
  const Config run = parse_config(run_text, "c");
  const Config back = parse_config(to_toml(run), "c");
  EXPECT_EQ(back.ggem.alpha_hm, t.ggem.alpha_hm);
  EXPECT_EQ(back.ggem.cutoff, t.ggem.cutoff);
  EXPECT_EQ(back.ggem.tolerance, 5e-3);
  expect_error(std::string(kMinimal) + "[ggem]\ntolerance = 1e-6\n", {"[ggem] tolerance", "[1e-04, 0.02]"});
  expect_error(std::string(kMinimal) + "[ggem]\ntolerance = 0.1\n", {"[ggem] tolerance", "[1e-04, 0.02]"});
  expect_error(std::string(kMinimal) + "[ggem]\ntolerance = \"fine\"\n", {"[ggem] tolerance", "string"});
}

// tolerance = 0 is "none" said explicitly: a sweep over a preset that asks for a tolerance pins its runs to the
// split's defaults with it, and the run's stored text is then the one a configuration without the key gives (the
// reproduction sweeps' runs began before the presets had a tolerance and must find their stored configurations).
TEST(Config, GgemToleranceZeroIsTheDefaults) {
  const Config d = parse_config(kMinimal, "c");
  const Config z = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 0\n", "c");
  EXPECT_EQ(z.ggem.tolerance, 0.0);
  EXPECT_EQ(z.ggem.alpha_hm, d.ggem.alpha_hm);
  EXPECT_EQ(z.ggem.cutoff, d.ggem.cutoff);
  EXPECT_EQ(z.gmres.tolerance, d.gmres.tolerance);
  EXPECT_EQ(to_toml(z), to_toml(d));
  EXPECT_EQ(to_toml(z).find("tolerance = 0\n"), std::string::npos);
  expect_error(std::string(kMinimal) + "[ggem]\ntolerance = -1e-2\n", {"[ggem] tolerance", "0 (none"});
  expect_error(std::string(kMinimal) + "[ggem]\ntolerance = 5e-5\n", {"[ggem] tolerance", "[1e-04, 0.02]"});
}

// [gmres] tolerance, not given, is a thousandth of a given [ggem] tolerance (1e-6 without one: a thousandth of the
// default split's ~1e-3); given, it wins; the stored text writes it, so a restart keeps it.
TEST(Config, GmresToleranceFollowsTheGgemTolerance) {
  EXPECT_EQ(parse_config(kMinimal, "c").gmres.tolerance, 1e-6);
  const Config t = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 1e-2\n", "c");
  EXPECT_DOUBLE_EQ(t.gmres.tolerance, 1e-5);
  EXPECT_DOUBLE_EQ(parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 2e-2\n", "c").gmres.tolerance, 2e-5);
  const Config e = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 1e-2\n[gmres]\ntolerance = 1e-8\n", "c");
  EXPECT_EQ(e.gmres.tolerance, 1e-8);
  const std::string run_text = set_a_step_problem_toml_at_tolerance("1e-2");
  const Config run = parse_config(run_text, "c");
  EXPECT_DOUBLE_EQ(run.gmres.tolerance, 1e-5);
  const Config back = parse_config(to_toml(run), "c");
  EXPECT_EQ(back.gmres.tolerance, run.gmres.tolerance);
  EXPECT_EQ(back.ggem.tolerance, 1e-2);
}

// [quadrature]: the element rules. The defaults are the cheaper rules of issue 34, not the kernels' finer ones
// (fine_quadrature()), with or without a tolerance; keys given explicitly win; the stored text always writes the
// table, so a restart reads back the same rules; the bands must run outward.
TEST(Config, QuadratureDefaultsUnlessGiven) {
  const Config d = parse_config(kMinimal, "c");
  EXPECT_TRUE(d.quadrature == QuadratureOptions{});
  EXPECT_EQ(d.quadrature.far_ratio, 1.5);
  EXPECT_EQ(d.quadrature.regular_mid, 5);
  EXPECT_EQ(d.quadrature.near_ratio, 0.3);
  EXPECT_EQ(d.quadrature.near_points, 6);
  EXPECT_EQ(d.quadrature.kernel_degree, 9);
  EXPECT_NE(to_toml(d).find("[quadrature]"), std::string::npos) << "the table is always written";
  // The kernels' own rules (the defaults before issue 34), and the tolerance no longer changing the rules.
  const QuadratureOptions fine = fine_quadrature();
  EXPECT_TRUE(fine != QuadratureOptions{});
  EXPECT_EQ(fine.far_ratio, 2.5);
  EXPECT_EQ(fine.regular_mid, 7);
  EXPECT_EQ(fine.near_ratio, 0.5);
  EXPECT_EQ(fine.near_points, 8);
  EXPECT_EQ(fine.kernel_degree, 17);
  const Config t = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 2e-2\n", "c");
  EXPECT_TRUE(t.quadrature == QuadratureOptions{});
  const Config e = parse_config(std::string(kMinimal) + "[ggem]\ntolerance = 2e-2\n[quadrature]\nsingular = 8\n", "c");
  EXPECT_EQ(e.quadrature.singular, 8);
  EXPECT_EQ(e.quadrature.near_points, QuadratureOptions{}.near_points);
  const Config g = parse_config(std::string(kMinimal) + "[quadrature]\nregular_mid = 9\nnear_ratio = 0.4\n", "c");
  EXPECT_EQ(g.quadrature.regular_mid, 9);
  EXPECT_EQ(g.quadrature.near_ratio, 0.4);
  EXPECT_EQ(g.quadrature.singular, QuadratureOptions{}.singular);
  // Stored and read back (a whole run's configuration: set A's step problem): the same rules, with and without a
  // tolerance, and the finer rules given in full.
  const std::string tol_text = set_a_step_problem_toml_at_tolerance("2e-2");
  const Config rt = parse_config(tol_text, "c"), re = parse_config(tol_text + "[quadrature]\nsingular = 8\n", "c"),
               rg = parse_config(std::string(set_a_step_problem_toml()) + "[quadrature]\nregular_mid = 9\n", "c");
  EXPECT_TRUE(rt.quadrature == QuadratureOptions{});
  EXPECT_EQ(re.quadrature.singular, 8);
  EXPECT_EQ(rg.quadrature.regular_mid, 9);
  Config rf = rg;
  rf.quadrature = fine;
  for (const Config& c : {rt, re, rg, rf}) EXPECT_TRUE(parse_config(to_toml(c), "c").quadrature == c.quadrature);
  expect_error(std::string(kMinimal) + "[quadrature]\nmid_ratio = 0.2\n",
               {"[quadrature] mid_ratio", "at least near_ratio (0.3)", "0.2"});
  expect_error(std::string(kMinimal) + "[quadrature]\nfar_ratio = 1\n", {"[quadrature] far_ratio", "symmetric_ratio"});
  expect_error(std::string(kMinimal) + "[quadrature]\nsymmetric_ratio = 2\n",
               {"[quadrature] far_ratio", "at least symmetric_ratio (2)", "1.5"});
  expect_error(std::string(kMinimal) + "[quadrature]\nsingular = 1\n", {"[quadrature] singular", "integer 1"});
  expect_error(std::string(kMinimal) + "[quadrature]\nnear_points = 40\n", {"[quadrature] near_points"});
  expect_error(std::string(kMinimal) + "[quadrature]\norder = 3\n", {"[quadrature]", "order"});
  expect_error(std::string(kMinimal) + "[quadrature]\nkernel_degree = 11\n",
               {"[quadrature] kernel_degree", "17", "9", "integer 11"});
}

TEST(Config, OutOfRange) {
  expect_error("[domain]\nH = 0\nLx = 8\nLz = 8\n", {"[domain] H", "> 0", "integer 0"});
  expect_error("[domain]\nH = -1.5\nLx = 8\nLz = 8\n", {"[domain] H", "float -1.5"});
  expect_error("[domain]\nH = 4\nLx = -8\nLz = 8\n", {"[domain] Lx", "> 0"});
  expect_error("[domain]\nH = 4\nLx = 8\nLz = 0.0\n", {"[domain] Lz", "> 0"});
  expect_error(std::string(kMinimal) + "viscosity = 0\n", {"[domain] viscosity", "> 0"});
  expect_error("[domain]\nH = inf\nLx = 8\nLz = 8\n", {"[domain] H", "finite", "float inf"});
  expect_error("[domain]\nH = nan\nLx = 8\nLz = 8\n", {"[domain] H", "float nan"});
  expect_error(std::string(kMinimal) + "[ggem]\nalpha = 0\n", {"[ggem] alpha", "> 0"});
  expect_error(std::string(kMinimal) + "[ggem]\nalpha_hm = 0\n", {"[ggem] alpha_hm", "in (0, 2]"});
  expect_error(std::string(kMinimal) + "[ggem]\nalpha_hm = 2.5\n", {"[ggem] alpha_hm", "in (0, 2]", "2.5"});
  expect_error(std::string(kMinimal) + "[ggem]\nnx = 4\n", {"[ggem] nx", ">= 8", "integer 4"});
  expect_error(std::string(kMinimal) + "[ggem]\nnz = 0\n", {"[ggem] nz", ">= 8"});
  expect_error(std::string(kMinimal) + "[ggem]\nny = 7\n", {"[ggem] ny", ">= 8"});
  expect_error(std::string(kMinimal) + "[ggem]\nnx = 99999999999\n", {"[ggem] nx", "integer 99999999999"});
  expect_error(std::string(kMinimal) + "[ggem]\ncutoff = -1\n", {"[ggem] cutoff", "> 0"});
  expect_error(std::string(kMinimal) + "[run]\nthreads = -1\n", {"[run] threads", ">= 0", "integer -1"});
}

TEST(Config, PeriodTooSmallForCutoff) {
  expect_error("[domain]\nH = 4\nLx = 1.5\nLz = 8\n[ggem]\ncutoff = 1.0\n",
               {"[domain] Lx", "Lx = 1.5 is too small for the cutoff 1: need Lx >= 2 * cutoff = 2"});
  // A cutoff from alpha's default is alpha's doing: the message names alpha first, then the length.
  expect_error("[domain]\nH = 4\nLx = 8\nLz = 6.9\n[ggem]\nalpha = 1\n",  // default cutoff 3.5 / alpha = 3.5
               {"[ggem] alpha", "gives the local cutoff 3.5 / alpha = 3.5", "[domain] Lz >= 2 * cutoff = 7 (Lz = 6.9)"});
  expect_error("[domain]\nH = 4\nLx = 8\nLz = 8\n[ggem]\nalpha = 1e-300\n", {"[ggem] alpha", "larger alpha"});
  // A cutoff below 2 / alpha: the screened kernel is cut where it is not small (issue 24: 1e-300 gave Taylor D
  // 1.9e-4 against 3.2e-5 without a word).
  expect_error("[domain]\nH = 4\nLx = 8\nLz = 8\n[ggem]\nalpha = 4\ncutoff = 0.49\n",
               {"[ggem] cutoff", "at least 2 / alpha = 0.5", "0.49"});
  EXPECT_EQ(error_of("[domain]\nH = 4\nLx = 8\nLz = 8\n[ggem]\nalpha = 4\ncutoff = 0.5\n"), "");
  EXPECT_EQ(error_of("[domain]\nH = 4\nLx = 2\nLz = 2\n[ggem]\ncutoff = 1\n"), "");  // exactly 2 * cutoff is fine
}

TEST(Config, MalformedToml) {
  const std::string msg = error_of("[domain]\nH = 4\nLx = = 8\n");
  ASSERT_FALSE(msg.empty());
  EXPECT_EQ(msg.rfind("case.toml:3:", 0), 0u) << msg;  // file:line:column
  EXPECT_NE(msg.find("invalid TOML"), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;

  const std::string dup = error_of("[domain]\nH = 4\nH = 5\n");
  EXPECT_EQ(dup.rfind("case.toml:3:", 0), 0u) << dup;
}

TEST(Config, LoadConfigNamesTheFile) {
  try {
    load_config("/nonexistent/dir/cfg.toml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/dir/cfg.toml:", 0), 0u) << e.what();
  }

  const std::string path = testing::TempDir() + "capsflow_test_config.toml";
  {
    std::ofstream(path) << kMinimal << "[ggem]\nalpha = 0\n";
  }
  try {
    load_config(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": [ggem] alpha:", 0), 0u) << e.what();
  }
  {
    std::ofstream(path) << kMinimal;
  }
  EXPECT_EQ(load_config(path).source, path);
  std::remove(path.c_str());
}

TEST(Config, ExampleConfigLoads) {
  std::string dir;
  if (const char* env = std::getenv("CAPSFLOW_SOURCE_DIR"); env && *env) dir = env;
#ifdef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
  if (dir.empty()) dir = CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
#endif
  if (dir.empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  const Config c = load_config(dir + "/examples/green.toml");
  EXPECT_EQ(c.domain.H, 4.0);
  EXPECT_EQ(c.domain.Lx, 8.0);
  EXPECT_EQ(c.domain.Lz, 8.0);
}

}  // namespace
}  // namespace capsflow
