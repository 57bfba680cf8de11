// The run sections of the configuration ([flow], [capsules], [[species]], [suspension], [[capsule]], [time],
// [output]), validate_run_config, and the initial placement of capsules (place_capsules).
#include <gtest/gtest.h>

#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <string>

#include "host/physics/config.hpp"
#include "host/base/errors.hpp"
#include "host/physics/initial_conditions.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

// A box that fits capsules of radius 1 with the default cutoff 0.875: Lx, Lz >= 2 (0.875 + 2) = 5.75.
const char* kBox = R"(
[domain]
H = 10
Lx = 10
Lz = 10
)";

const char* kTwoSpecies = R"(
[[species]]
name = "stiff"
ca = 0.2
[[species]]
name = "floppy"
ca = 1.0
)";

std::string error_of(const std::string& text, bool validate = false) {
  try {
    Config c = parse_config(text, "case.toml");
    if (validate) validate_run_config(c);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

void expect_error(const std::string& text, std::initializer_list<std::string> parts, bool validate = false) {
  const std::string msg = error_of(text, validate);
  ASSERT_FALSE(msg.empty()) << "no error for:\n" << text;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind("case.toml: ", 0), 0u) << msg;
  for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
}

std::string placement_error(const std::string& text) {
  try {
    place_capsules(parse_config(text, "case.toml"));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(RunConfig, GreenOnlyFileTakesRunDefaults) {
  const Config c = parse_config(kBox, "g.toml");
  EXPECT_EQ(c.flow.type, FlowType::Poiseuille);
  EXPECT_EQ(c.flow.shear_rate, 1.0);
  EXPECT_EQ(c.capsules.mesh_level, 2);
  EXPECT_EQ(c.capsules.membrane.inflation, 0.1);
  EXPECT_EQ(c.capsules.membrane.law, MembraneLaw::NeoHookean);
  EXPECT_EQ(c.capsules.membrane.skalak_C, 1.0);
  EXPECT_EQ(c.capsules.radius, 1.0);
  EXPECT_TRUE(c.species.empty());
  EXPECT_FALSE(c.suspension.has_value());
  EXPECT_TRUE(c.capsule_list.empty());
  EXPECT_FALSE(c.defines_capsules());
  EXPECT_FALSE(c.time.end.has_value());
  EXPECT_EQ(c.time.cfl, 0.5);
  EXPECT_EQ(c.time.min_gap, 0.02);
  EXPECT_EQ(c.time.dt_floor, 1e-6);
  EXPECT_EQ(c.output.file, "capsflow-run.h5");
  EXPECT_EQ(c.output.every, 0.1);
  EXPECT_EQ(c.output.frames_every, 1.0);
  EXPECT_EQ(c.output.checkpoint_every, 10.0);
  // A small green-only box is not held to the capsule box rule (a period must hold the cutoff plus two radii).
  EXPECT_EQ(error_of("[domain]\nH = 1\nLx = 2\nLz = 2\n"), "");
}

TEST(RunConfig, EveryKeyRead) {
  const Config c = parse_config(std::string(kBox) + kTwoSpecies + R"(
[flow]
type = "shear"
shear_rate = 2
[capsules]
mesh_level = 3
inflation = 0
law = "skalak"
skalak_c = 10
radius = 1.5
[suspension]
fractions = [0.25, 0.75]
count = 12
seed = 42
[time]
end = 50
cfl = 0.25
min_gap = 0.01
dt_floor = 1e-8
[output]
file = "out.h5"
every = 0.5
frames_every = 2
checkpoint_every = 5
)",
                                "all.toml");
  EXPECT_EQ(c.flow.type, FlowType::Shear);
  EXPECT_EQ(c.flow.shear_rate, 2.0);
  EXPECT_EQ(c.capsules.mesh_level, 3);
  EXPECT_EQ(c.capsules.membrane.inflation, 0.0);
  EXPECT_EQ(c.capsules.membrane.law, MembraneLaw::Skalak);
  EXPECT_EQ(c.capsules.membrane.skalak_C, 10.0);
  EXPECT_EQ(c.capsules.radius, 1.5);
  ASSERT_EQ(c.species.size(), 2u);
  EXPECT_EQ(c.species[0].name, "stiff");
  EXPECT_EQ(c.species[0].ca, 0.2);
  EXPECT_EQ(c.species[1].name, "floppy");
  EXPECT_EQ(c.species_index("floppy"), 1);
  EXPECT_EQ(c.species_index("none"), -1);
  ASSERT_TRUE(c.suspension.has_value());
  EXPECT_FALSE(c.suspension->volume_fraction.has_value());
  EXPECT_EQ(c.suspension->fractions, (std::vector<double>{0.25, 0.75}));
  EXPECT_EQ(*c.suspension->count, 12);
  EXPECT_EQ(c.suspension->seed, 42u);
  EXPECT_EQ(*c.time.end, 50.0);
  EXPECT_EQ(c.time.cfl, 0.25);
  EXPECT_EQ(c.time.min_gap, 0.01);
  EXPECT_EQ(c.time.dt_floor, 1e-8);
  EXPECT_EQ(c.output.file, "out.h5");
  EXPECT_EQ(c.output.every, 0.5);
  EXPECT_EQ(c.output.frames_every, 2.0);
  EXPECT_EQ(c.output.checkpoint_every, 5.0);
  EXPECT_NO_THROW(validate_run_config(c));
}

TEST(RunConfig, SuspensionDefaults) {
  const Config c = parse_config(std::string(kBox) +
                                    "[[species]]\nname = \"a\"\nca = 0.1\n"
                                    "[suspension]\nvolume_fraction = 0.1\n[time]\nend = 1\n",
                                "s.toml");
  ASSERT_TRUE(c.suspension.has_value());
  EXPECT_EQ(c.suspension->fractions, (std::vector<double>{1.0}));  // one species: fractions may be left out
  EXPECT_FALSE(c.suspension->count.has_value());
  EXPECT_EQ(c.suspension->seed, 1u);
  EXPECT_NO_THROW(validate_run_config(c));
  EXPECT_EQ(suspension_count(c), 24);  // round(0.1 * 1000 / (4/3 pi)) = round(23.87)
}

TEST(RunConfig, ExplicitCapsules) {
  const Config c = parse_config(std::string(kBox) + kTwoSpecies + R"(
[[capsule]]
species = "floppy"
center = [1, 2, 3]
pinned = true
[[capsule]]
species = "stiff"
center = [9.5, 5.0, 9.5]
[time]
end = 10
)",
                                "e.toml");
  ASSERT_EQ(c.capsule_list.size(), 2u);
  EXPECT_EQ(c.capsule_list[0].species, "floppy");
  EXPECT_EQ(c.capsule_list[0].center, (std::array<double, 3>{1, 2, 3}));
  EXPECT_TRUE(c.capsule_list[0].pinned);
  EXPECT_FALSE(c.capsule_list[1].pinned);
  const auto p = place_capsules(c);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].species, 1);
  EXPECT_TRUE(p[0].pinned);
  EXPECT_EQ(p[1].species, 0);
  EXPECT_EQ(p[1].center, (std::array<double, 3>{9.5, 5.0, 9.5}));
}

TEST(RunConfig, KeyErrorsNameFileSectionAndKey) {
  const std::string b = kBox;
  expect_error(b + "[flow]\ntype = \"couette\"\n", {"[flow] type", "\"poiseuille\", \"shear\", \"none\"", "couette"});
  expect_error(b + "[flow]\nshear_rate = 0\n", {"[flow] shear_rate", "> 0", "integer 0"});
  expect_error(b + "[flow]\nrate = 1\n", {"[flow] rate", "unknown key 'rate'"});
  expect_error(b + "[capsules]\nmesh_level = 5\n", {"[capsules] mesh_level", "in [0, 4]", "integer 5"});
  expect_error(b + "[capsules]\nmesh_level = 2.0\n", {"[capsules] mesh_level", "expected an integer", "float 2.0"});
  expect_error(b + "[capsules]\ninflation = -0.1\n", {"[capsules] inflation", ">= 0"});
  expect_error(b + "[capsules]\nlaw = \"hooke\"\n", {"[capsules] law", "\"neo-hookean\", \"skalak\""});
  expect_error(b + "[capsules]\nskalak_c = 0\n", {"[capsules] skalak_c", "> 0"});
  expect_error(b + "[capsules]\nradius = -1\n", {"[capsules] radius", "> 0"});
  expect_error(b + "[[species]]\nca = 1\n", {"[[species]] 1 name", "non-empty string", "required"});
  expect_error(b + "[[species]]\nname = \"\"\nca = 1\n", {"[[species]] 1 name", "non-empty string", "string \"\""});
  expect_error(b + "[[species]]\nname = \"a\"\nca = 1\n[[species]]\nname = \"b\"\n",
               {"[[species]] 2 ca", "> 0", "required"});
  expect_error(b + "[[species]]\nname = \"a\"\nca = 0\n", {"[[species]] 1 ca", "> 0", "integer 0"});
  expect_error(b + "[[species]]\nname = \"a\"\nca = 1\nCa = 1\n", {"[[species]] 1 Ca", "unknown key 'Ca'"});
  expect_error(b + "[species]\nname = \"a\"\nca = 1\n", {"[[species]]", "expected an array of tables", "an array"});
  expect_error(b + "species = 3\n", {"[domain] species", "unknown key 'species'"});  // inside [domain]
  expect_error("species = 3\n" + b, {"[[species]]", "expected an array of tables", "integer 3"});
  expect_error("[[domain]]\nH = 1\n", {"[domain]", "expected a table"});

  const std::string s = b + kTwoSpecies;
  expect_error(s + "[suspension]\nvolume_fraction = 0.5\nfractions = [0.5, 0.5]\n",
               {"[suspension] volume_fraction", "in (0, 0.5)", "float 0.5"});
  expect_error(s + "[suspension]\nvolume_fraction = 0\nfractions = [0.5, 0.5]\n",
               {"[suspension] volume_fraction", "in (0, 0.5)"});
  expect_error(s + "[suspension]\nfractions = [0.5, 0.5]\n", {"[suspension] volume_fraction", "required"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\n", {"[suspension] fractions", "required"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = 0.5\n",
               {"[suspension] fractions", "array of finite numbers", "float 0.5"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, \"x\"]\n",
               {"[suspension] fractions", "element 2 string \"x\""});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [1.5, -0.5]\n",
               {"[suspension] fractions", "in [0, 1]", "element 1 float 1.5"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\ncount = 0\n",
               {"[suspension] count", ">= 1", "integer 0"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\nseed = -1\n",
               {"[suspension] seed", ">= 0"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\nseed = 1.5\n",
               {"[suspension] seed", "expected an integer"});
  expect_error(s + "[[capsule]]\ncenter = [5, 5, 5]\n", {"[[capsule]] 1 species", "required"});
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\n",
               {"[[capsule]] 1 center", "array of 3 finite numbers", "required"});
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 5]\n",
               {"[[capsule]] 1 center", "array of 3", "an array of 2 elements"});
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 5, 5]\npinned = 1\n",
               {"[[capsule]] 1 pinned", "boolean", "integer 1"});
  expect_error(b + "[time]\nend = 0\n", {"[time] end", "> 0"});
  expect_error(b + "[time]\ncfl = -1\n", {"[time] cfl", "> 0"});
  expect_error(b + "[time]\nmin_gap = -0.01\n", {"[time] min_gap", "> 0"});
  expect_error(b + "[time]\ndt_floor = 0\n", {"[time] dt_floor", "> 0"});
  expect_error(b + "[output]\nfile = \"\"\n", {"[output] file", "non-empty string"});
  expect_error(b + "[output]\nevery = 0\n", {"[output] every", "> 0"});
  expect_error(b + "[output]\nframes_every = 0\n", {"[output] frames_every", "> 0"});
  expect_error(b + "[output]\ncheckpoint_every = -1\n", {"[output] checkpoint_every", "> 0"});
}

TEST(RunConfig, CrossCheckErrors) {
  const std::string s = std::string(kBox) + kTwoSpecies;
  // Exclusive: [suspension] and [[capsule]].
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\n"
                   "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 5, 5]\n",
               {"[suspension]", "either [suspension]", "[[capsule]]", "got both"});
  // Duplicate species.
  expect_error(std::string(kBox) + "[[species]]\nname = \"a\"\nca = 1\n[[species]]\nname = \"a\"\nca = 2\n",
               {"[[species]] 2 name", "\"a\"", "[[species]] 1"});
  // Fractions: one per species, summing to 1.
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [1]\n",
               {"[suspension] fractions", "one fraction per [[species]] (2)", "got 1"});
  expect_error(s + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.4]\n",
               {"[suspension] fractions", "sum to 1", "0.9"});
  // Capsules with no species, or an unknown one.
  expect_error(std::string(kBox) + "[suspension]\nvolume_fraction = 0.1\n", {"[[species]]", "at least one"});
  expect_error(s + "[[capsule]]\nspecies = \"soft\"\ncenter = [5, 5, 5]\n",
               {"[[capsule]] 1 species", "\"stiff\", \"floppy\"", "\"soft\""});
  // Walls (radius 1, min_gap 0.02, H = 10: 1.02 <= y <= 8.98).
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 5, 5]\n"
                   "[[capsule]]\nspecies = \"stiff\"\ncenter = [1, 5, 1]\n"
                   "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 0.5, 1]\n",
               {"[[capsule]] 3 center", "capsule 3 at y = 0.5 crosses the wall y = 0",
                "needs a + min_gap <= y <= H - a - min_gap", "1.02 <= y <= 8.98"});
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 1.01, 5]\n",
               {"[[capsule]] 1 center", "capsule 1 at y = 1.01 comes within min_gap of the wall y = 0"});
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 9.5, 5]\n",
               {"[[capsule]] 1 center", "crosses the wall y = H = 10"});
  EXPECT_EQ(error_of(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 1.02, 5]\n"), "");  // exactly at the limit
  // Overlap, through the periodic image in x: x = 0.5 and x = 9.0 are 1.5 apart.
  expect_error(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [0.5, 5, 5]\n"
                   "[[capsule]]\nspecies = \"floppy\"\ncenter = [9.0, 5, 5]\n",
               {"[[capsule]] 2 center", "capsule 2 overlaps capsule 1", "centre distance 1.5", "2a + min_gap = 2.02"});
  EXPECT_EQ(error_of(s + "[[capsule]]\nspecies = \"stiff\"\ncenter = [1, 5, 5]\n"
                         "[[capsule]]\nspecies = \"floppy\"\ncenter = [3.02, 5, 5]\n"),
            "");
  // Box: Lx, Lz >= 2 (cutoff + 2a) = 5.75 with capsules (default cutoff 3.5 / alpha = 0.875); a narrow slit.
  expect_error("[domain]\nH = 10\nLx = 5\nLz = 10\n" + std::string(kTwoSpecies) +
                   "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\n",
               {"[domain] Lx", "Lx = 5 is too small for capsules of radius 1", "need Lx >= 2 (cutoff + 2a) = 5.75"});
  expect_error("[domain]\nH = 10\nLx = 10\nLz = 5.7\n" + std::string(kTwoSpecies) +
                   "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 5, 5]\n",
               {"[domain] Lz", "need Lz >= 2 (cutoff + 2a) = 5.75"});
  expect_error("[domain]\nH = 2\nLx = 10\nLz = 10\n" + std::string(kTwoSpecies) +
                   "[[capsule]]\nspecies = \"stiff\"\ncenter = [5, 1, 5]\n",
               {"[domain] H", "too narrow", "H >= 2 (a + min_gap) = 2.04"});
}

TEST(RunConfig, ValidateRunConfigRequirements) {
  const std::string b = kBox;
  expect_error(b, {"[[species]]", "at least one", "capsflow run"}, true);
  expect_error(b + kTwoSpecies + "[time]\nend = 1\n", {"[suspension]", "got neither"}, true);
  expect_error(b + kTwoSpecies + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\n",
               {"[time] end", "required by capsflow run"}, true);
  EXPECT_EQ(error_of(b + kTwoSpecies + "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\n"), "");
  EXPECT_EQ(error_of(b + kTwoSpecies +
                         "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\n"
                         "[time]\nend = 1\n",
                     true),
            "");
  // A Config built in code is held to the same cross-checks.
  Config c = parse_config(b + kTwoSpecies +
                              "[suspension]\nvolume_fraction = 0.1\nfractions = [0.5, 0.5]\n"
                              "[time]\nend = 1\n",
                          "code.toml");
  c.capsule_list.push_back({"stiff", {5, 5, 5}, false, std::nullopt});
  EXPECT_THROW(validate_run_config(c), InputError);
}

TEST(RunConfig, SpeciesCountsLargestRemainder) {
  EXPECT_EQ(species_counts(10, {0.5, 0.5}), (std::vector<long>{5, 5}));
  EXPECT_EQ(species_counts(11, {0.5, 0.5}), (std::vector<long>{6, 5}));             // tie: the lower index
  EXPECT_EQ(species_counts(10, {0.26, 0.37, 0.37}), (std::vector<long>{2, 4, 4}));  // 2.6, 3.7, 3.7
  EXPECT_EQ(species_counts(7, {1.0 / 3, 1.0 / 3, 1.0 / 3}), (std::vector<long>{3, 2, 2}));
  EXPECT_EQ(species_counts(5, {0.0, 1.0}), (std::vector<long>{0, 5}));
}

const char* kSuspension = R"(
[domain]
H = 10.15
Lx = 10.2
Lz = 10.2
[[species]]
name = "stiff"
ca = 0.2
[[species]]
name = "floppy"
ca = 1.0
[time]
end = 1
[suspension]
fractions = [0.3, 0.7]
)";

TEST(RunConfig, RandomPlacementIsReproducibleNonOverlappingInsideTheWalls) {
  const Config c = parse_config(std::string(kSuspension) + "volume_fraction = 0.2\nseed = 7\n", "p.toml");
  const auto p = place_capsules(c);
  const long n = suspension_count(c);
  EXPECT_EQ(n, 50);  // round(0.2 * 10.15 * 10.2^2 / (4/3 pi)) = round(50.45)
  ASSERT_EQ(static_cast<long>(p.size()), n);

  // Number fractions by largest remainder: 15 stiff, 35 floppy.
  long stiff = 0;
  for (const auto& q : p) stiff += q.species == 0 ? 1 : 0;
  EXPECT_EQ(stiff, 15);

  const double a = 1.0, gap = 0.02, H = 10.15, L = 10.2;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto& x = p[i].center;
    EXPECT_FALSE(p[i].pinned);
    EXPECT_GE(x[1], a + gap);
    EXPECT_LE(x[1], H - a - gap);
    EXPECT_GE(x[0], 0.0);
    EXPECT_LT(x[0], L);
    EXPECT_GE(x[2], 0.0);
    EXPECT_LT(x[2], L);
    for (std::size_t j = 0; j < i; ++j) {
      const auto& y = p[j].center;
      const double dx = min_image(x[0] - y[0], L), dy = x[1] - y[1], dz = min_image(x[2] - y[2], L);
      EXPECT_GE(std::sqrt(dx * dx + dy * dy + dz * dz), 2 * a + gap) << i << " " << j;
    }
  }

  // The same seed gives the same capsules (bit for bit); another seed, others.
  const auto again = place_capsules(c);
  ASSERT_EQ(again.size(), p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(again[i].center, p[i].center);
    EXPECT_EQ(again[i].species, p[i].species);
  }
  const auto other = place_capsules(parse_config(std::string(kSuspension) + "volume_fraction = 0.2\nseed = 8\n", "q"));
  ASSERT_EQ(other.size(), p.size());
  EXPECT_NE(other[0].center, p[0].center);
}

TEST(RunConfig, CountOverridesVolumeFraction) {
  const Config c = parse_config(std::string(kSuspension) + "count = 9\n", "c.toml");
  const auto p = place_capsules(c);
  ASSERT_EQ(p.size(), 9u);
  long stiff = 0;
  for (const auto& q : p) stiff += q.species == 0 ? 1 : 0;
  EXPECT_EQ(stiff, 3);  // 2.7 -> 3, 6.3 -> 6
  expect_error(std::string(kSuspension) + "count = 9\nvolume_fraction = 0.1\n", {"[suspension] count", "not both"});
  expect_error(std::string(kSuspension) + "count = 1000000000000\n",
               {"[suspension] count", "< 0.5", "count = 1000000000000"});
}

// "Quickly" as work, not time: the placement gives up after kMaxTriesPerCapsule draws of the capsule it cannot place,
// so the attempts it reports are at most (placed + 1) x that cap.
TEST(RunConfig, ImpossibleVolumeFractionFailsQuickly) {
  const std::string msg = placement_error(std::string(kSuspension) + "volume_fraction = 0.45\n");
  ASSERT_FALSE(msg.empty());
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg.rfind("case.toml: [suspension] volume_fraction: volume fraction 0.45 could not be placed: "
                      "random sequential placement stopped at 0.",
                      0),
            0u)
      << msg;
  EXPECT_NE(msg.find(" attempts"), std::string::npos) << msg;
  EXPECT_NE(msg.find("lower [suspension] volume_fraction or enlarge the box"), std::string::npos) << msg;
  long attempts = -1, placed = -1;
  ASSERT_EQ(std::sscanf(msg.c_str() + msg.find(" after ") + 7, "%ld attempts (%ld of", &attempts, &placed), 2) << msg;
  EXPECT_GT(attempts, 0);
  EXPECT_LE(attempts, (placed + 1) * kMaxTriesPerCapsule) << msg;
}

TEST(RunConfig, ExampleRunConfigLoads) {
  std::string dir;
  if (const char* env = std::getenv("CAPSFLOW_SOURCE_DIR"); env && *env) dir = env;
#ifdef CAPSFLOW_TEST_DEFAULT_SOURCE_DIR
  if (dir.empty()) dir = CAPSFLOW_TEST_DEFAULT_SOURCE_DIR;
#endif
  if (dir.empty()) GTEST_SKIP() << "CAPSFLOW_SOURCE_DIR not set";
  const Config c = load_config(dir + "/examples/run_binary.toml");
  EXPECT_NO_THROW(validate_run_config(c));
  EXPECT_EQ(c.species.size(), 2u);
  const auto p = place_capsules(c);
  EXPECT_EQ(p.size(), 50u);
}


TEST(RunConfig, ResolvedTomlParsesBackToTheSameConfiguration) {
  // to_toml is what outputs and checkpoints store; a restart parses it back, so it must be a fixed point and keep
  // every value bit for bit (17 significant digits).
  Config c = parse_config(R"(
[domain]
H = 10.15
Lx = 10.2
Lz = 10.2
[ggem]
alpha = 4.0
nx = 40
[flow]
type = "shear"
shear_rate = 0.1
[capsules]
law = "skalak"
skalak_c = 2.5
inflation = 0.0
[[species]]
name = "a \"quoted\" name"
ca = 0.30000000000000004
[[species]]
name = "b"
ca = 1.0
[suspension]
count = 7
fractions = [0.25, 0.75]
seed = 42
[time]
end = 3.0
cfl = 0.25
)", "a.toml");
  const std::string t1 = to_toml(c);
  const Config back = parse_config(t1, "back.toml");
  EXPECT_EQ(back.species[0].name, "a \"quoted\" name");
  EXPECT_EQ(back.species[0].ca, 0.30000000000000004);
  EXPECT_EQ(back.ggem.nx, 40);
  EXPECT_EQ(back.ggem.nz, 0);
  EXPECT_EQ(back.flow.type, FlowType::Shear);
  EXPECT_EQ(back.capsules.membrane.law, MembraneLaw::Skalak);
  EXPECT_EQ(back.suspension->seed, 42u);
  EXPECT_EQ(*back.suspension->count, 7);
  EXPECT_FALSE(back.suspension->volume_fraction.has_value());
  const std::string t2 = to_toml(back);
  EXPECT_EQ(t1.substr(t1.find('\n')), t2.substr(t2.find('\n')));  // first line names the source
  // Explicit capsules survive too.
  const Config e = parse_config(to_toml(parse_config(R"(
[domain]
H = 8.0
Lx = 8.0
Lz = 8.0
[[species]]
name = "s"
ca = 0.2
[[capsule]]
species = "s"
center = [1.0, 4.0, 2.0]
pinned = true
[time]
end = 1.0
)", "e.toml")), "e2.toml");
  ASSERT_EQ(e.capsule_list.size(), 1u);
  EXPECT_TRUE(e.capsule_list[0].pinned);
  EXPECT_EQ(e.capsule_list[0].center[1], 4.0);
}

}  // namespace
}  // namespace capsflow
