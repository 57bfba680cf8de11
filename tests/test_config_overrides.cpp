// Overrides (`--set section.key=value`): applied to the parsed TOML before validation, so that an override is read
// and checked exactly like the same key in the file; restart rules; the --end/--backend/--threads aliases.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/base/errors.hpp"

namespace capsflow {
namespace {

const char* kBase = R"([domain]
H = 10.0
Lx = 10.0
Lz = 10.0

[[species]]
name = "stiff"
ca = 0.2

[[species]]
name = "floppy"
ca = 0.5

[suspension]
count = 10
fractions = [0.5, 0.5]

[time]
end = 5.0
)";

std::string error_of(const std::string& text, const std::vector<std::string>& overrides) {
  try {
    parse_config(text, "base.toml", overrides);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The part of a message after "<where>: ", which must start the message.
std::string after(const std::string& msg, const std::string& where) {
  EXPECT_EQ(msg.rfind(where + ": ", 0), 0u) << "'" << where << "' does not start: " << msg;
  return msg.substr(std::min(msg.size(), where.size() + 2));
}

TEST(ConfigOverrides, ValuesOfEveryType) {
  const Config c = parse_config(kBase, "base.toml",
                                {"suspension.seed=3", "time.cfl=0.25", "domain.H=12",
                                 "capsules.volume_correction=false", "run.backend=\"serial\"", "flow.type=shear",
                                 "suspension.fractions=[0.8, 0.2]", "output.file=out/run.h5",
                                 "time.max_step_ratio = 1.5"});
  ASSERT_TRUE(c.suspension);
  EXPECT_EQ(c.suspension->seed, 3u);
  EXPECT_EQ(c.time.cfl, 0.25);
  EXPECT_EQ(c.domain.H, 12.0);  // an integer where a number is expected, as in a file
  EXPECT_FALSE(c.capsules.volume_correction);
  EXPECT_EQ(c.run.backend, Backend::Serial);
  EXPECT_EQ(c.flow.type, FlowType::Shear);  // a bare word is a string
  EXPECT_EQ(c.suspension->fractions, (std::vector<double>{0.8, 0.2}));
  EXPECT_EQ(c.output.file, "out/run.h5");
  EXPECT_EQ(c.time.max_step_ratio, 1.5);  // spaces around '=' are allowed
  EXPECT_EQ(c.suspension->count, 10);     // untouched keys keep the file's values
}

TEST(ConfigOverrides, EntriesOfArraysOfTablesByNumberOrName) {
  Config c = parse_config(kBase, "base.toml", {"species.2.ca=0.6", "species.stiff.ca=0.1"});
  ASSERT_EQ(c.species.size(), 2u);
  EXPECT_EQ(c.species[0].ca, 0.1);
  EXPECT_EQ(c.species[1].ca, 0.6);
  // One past the last entry appends one; it needs every required key.
  c = parse_config(kBase, "base.toml",
                   {"species.3.name=mid", "species.3.ca=0.3", "suspension.fractions=[0.5, 0.25, 0.25]"});
  ASSERT_EQ(c.species.size(), 3u);
  EXPECT_EQ(c.species[2].name, "mid");
  EXPECT_EQ(c.species[2].ca, 0.3);
  // A section the file lacks is created; [[capsule]] entries by number.
  const std::string capsules = std::string(kBase).substr(0, std::string(kBase).find("[suspension]")) +
                               "[[capsule]]\nspecies = \"stiff\"\ncenter = [5.0, 3.0, 5.0]\n[time]\nend = 1.0\n";
  c = parse_config(capsules, "caps.toml", {"capsule.1.center=[4, 2.5, 6]", "capsule.1.pinned=true", "ggem.alpha=2"});
  ASSERT_EQ(c.capsule_list.size(), 1u);
  EXPECT_EQ(c.capsule_list[0].center[1], 2.5);
  EXPECT_TRUE(c.capsule_list[0].pinned);
  EXPECT_EQ(c.ggem.alpha, 2.0);
  EXPECT_EQ(c.ggem.cutoff, 1.75);  // the default cutoff (3.5 / alpha) follows the overridden alpha
  // The last of two overrides of one key wins.
  c = parse_config(kBase, "base.toml", {"suspension.seed=3", "suspension.seed=4"});
  EXPECT_EQ(c.suspension->seed, 4u);
}

TEST(ConfigOverrides, AnUnknownKeyReadsAsInTheFile) {
  const std::string file = error_of(std::string(kBase) + "[output]\nevry = 0.2\n", {});
  const std::string over = error_of(kBase, {"output.evry=0.2"});
  EXPECT_EQ(after(over, "--set output.evry"), after(file, "base.toml: [output] evry"));
  EXPECT_NE(over.find("got unknown key 'evry'"), std::string::npos) << over;

  const std::string file_sec = error_of(std::string(kBase) + "[outptu]\nevery = 0.2\n", {});
  const std::string over_sec = error_of(kBase, {"outptu.every=0.2"});
  EXPECT_EQ(after(over_sec, "--set outptu.every"), after(file_sec, "base.toml: [outptu]"));

  const std::string file_el = error_of(std::string(kBase) + "[[species]]\nname = \"x\"\nca = 1.0\ncaa = 2\n", {});
  const std::string over_el = error_of(kBase, {"species.floppy.caa=2"});
  EXPECT_EQ(after(over_el, "--set species.floppy.caa"), after(file_el, "base.toml: [[species]] 3 caa"));
}

TEST(ConfigOverrides, ABadValueReadsAsInTheFile) {
  struct Case {
    std::string key, value, file_section, file_key;
  };
  for (const Case& k : std::vector<Case>{{"suspension.seed", "-1", "[suspension]", "seed"},
                                         {"suspension.seed", "2.5", "[suspension]", "seed"},
                                         {"time.cfl", "\"fast\"", "[time]", "cfl"},
                                         {"time.cfl", "nan", "[time]", "cfl"},
                                         {"run.backend", "gpu", "[run]", "backend"},
                                         {"suspension.fractions", "[0.5, \"a\"]", "[suspension]", "fractions"},
                                         {"capsules.mesh_level", "9", "[capsules]", "mesh_level"}}) {
    // The same key with the same value written in the file.
    std::string text = kBase;
    const std::string header = k.file_section + "\n";
    const std::string line = k.file_key + " = " + (k.value == "gpu" ? "\"gpu\"" : k.value) + "\n";
    if (const auto at = text.find(header); at != std::string::npos) {
      auto next = text.find("\n[", at + header.size());
      if (next == std::string::npos) next = text.size();
      std::string block = text.substr(at + header.size(), next - at - header.size());
      // drop the key from the block if the file already has it
      const auto kpos = block.find(k.file_key + " =");
      if (kpos != std::string::npos) block.erase(kpos, block.find('\n', kpos) - kpos + 1);
      text = text.substr(0, at + header.size()) + line + block + text.substr(next);
    } else {
      text += header + line;
    }
    const std::string file = error_of(text, {});
    const std::string over = error_of(kBase, {k.key + "=" + k.value});
    ASSERT_FALSE(file.empty()) << text;
    EXPECT_EQ(after(over, "--set " + k.key), after(file, "base.toml: " + k.file_section + " " + k.file_key))
        << k.key << "=" << k.value;
  }
}

TEST(ConfigOverrides, ChecksAcrossKeysNameTheOverride) {
  std::string msg = error_of(kBase, {"domain.Lx=3"});
  EXPECT_EQ(msg.rfind("--set domain.Lx: Lx = 3 is too small", 0), 0u) << msg;
  msg = error_of(kBase, {"suspension.fractions=[0.7, 0.7]"});
  EXPECT_EQ(msg, "--set suspension.fractions: expected number fractions that sum to 1, got sum 1.4");
  msg = error_of(kBase, {"species.floppy.ca=0.1", "time.reference_ca=0.2"});
  EXPECT_EQ(msg.rfind("--set time.reference_ca: expected a number <= the smallest [[species]] ca (0.1)", 0), 0u)
      << msg;
}

TEST(ConfigOverrides, MalformedOverrides) {
  EXPECT_EQ(error_of(kBase, {"suspension.seed"}),
            "--set suspension.seed: expected section.key=value (e.g. suspension.seed=3), got 'suspension.seed'");
  EXPECT_EQ(error_of(kBase, {"seed=3"}), "--set seed: expected section.key=value (e.g. suspension.seed=3), got 'seed'");
  EXPECT_EQ(error_of(kBase, {"suspension.seed.x=3"}),
            "--set suspension.seed.x: expected suspension.key (a key of [suspension]), got 'suspension.seed.x'");
  EXPECT_EQ(error_of(kBase, {"species.ca=3"}),
            "--set species.ca: expected species.N.key or species.NAME.key (an entry of [[species]]), got 'species.ca'");
  EXPECT_EQ(error_of(kBase, {"species.medium.ca=3"}),
            "--set species.medium.ca: expected the number of a [[species]] entry (1 to 2, or 3 to add one) or the "
            "name of one (\"stiff\", \"floppy\"), got 'medium'");
  EXPECT_EQ(error_of(kBase, {"species.0.ca=3"}).rfind("--set species.0.ca: expected the number of a [[species]]", 0),
            0u);
  EXPECT_EQ(error_of(kBase, {"time.end=[1"}),
            "--set time.end: expected a TOML value (a number, true or false, \"text\", [a, b]), got '[1'");
  EXPECT_EQ(error_of(kBase, {"time.end=1\nx = 2"}).rfind("--set time.end: expected a TOML value", 0), 0u);
  EXPECT_EQ(error_of(kBase, {"output.file="}).rfind("--set output.file: expected a TOML value", 0), 0u);
}

TEST(ConfigOverrides, ResolvedTomlKeepsTheOverriddenValues) {
  const Config c = parse_config(kBase, "base.toml", {"suspension.seed=7", "species.floppy.ca=0.55"});
  const Config back = parse_config(to_toml(c), "base.toml");
  EXPECT_EQ(back.suspension->seed, 7u);
  EXPECT_EQ(back.species[1].ca, 0.55);
  EXPECT_EQ(to_toml(back), to_toml(c));
}

TEST(ConfigOverrides, RestartAcceptsRunControlOnly) {
  for (const char* k : {"time.end", "time.stop_pair_dx", "run.backend", "run.threads", "output.every",
                        "output.frames_every", "output.checkpoint_every", "gmres.max_iterations", "gmres.restart",
                        " time . end "})
    EXPECT_TRUE(is_run_control_key(k)) << k;
  for (const char* k : {"suspension.seed", "capsules.inflation", "species.1.ca", "time.cfl", "domain.H",
                        "output.file", "output.profile_bins", "time.min_gap", "gmres.tolerance",
                        "species.1.viscosity_ratio"})
    EXPECT_FALSE(is_run_control_key(k)) << k;
  EXPECT_NO_THROW(check_restart_overrides(parse_overrides({"time.end=100", "run.threads=2"})));
  try {
    check_restart_overrides(parse_overrides({"time.end=100", "capsules.inflation=0.05"}));
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("--set capsules.inflation: cannot change when continuing a run (--restart)", 0), 0u) << msg;
    EXPECT_NE(msg.find("only the run-control keys time.end, time.stop_pair_dx, run.backend, run.threads, "
                       "output.every, output.frames_every, output.checkpoint_every, gmres.max_iterations, gmres.restart, "
                       "gmres.preconditioner may "
                       "change"),
              std::string::npos)
        << msg;
  }
}

TEST(ConfigOverrides, CommandLineAliasesNameTheirOption) {
  auto err = [](const std::optional<double>& end, const std::optional<std::string>& backend,
                const std::optional<int>& threads) {
    try {
      resolve_config(kBase, "base.toml", run_flag_overrides(end, backend, threads));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(err(-1.0, std::nullopt, std::nullopt), "--end: expected a finite number > 0, got float -1.0");
  EXPECT_EQ(err(std::nullopt, "gpu", std::nullopt),
            "--backend: expected one of \"serial\", \"threads\", \"device\", got string \"gpu\"");
  EXPECT_EQ(err(std::nullopt, std::nullopt, -2), "--threads: expected an integer >= 0, got integer -2");
  const Config c = resolve_config(kBase, "base.toml", run_flag_overrides(12.5, "serial", 3));
  EXPECT_EQ(*c.time.end, 12.5);
  EXPECT_EQ(c.run.backend, Backend::Serial);
  EXPECT_EQ(c.run.threads, 3);
}

}  // namespace
}  // namespace capsflow
