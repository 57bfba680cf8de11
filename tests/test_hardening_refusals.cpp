// Hardening, fourth round (issue 37, finding 7): inputs that make no sense are refused at input, naming the key the
// user wrote. A drop (law = "surface-tension") has no reference state: an inflation written for it, in [[species]]
// or in a [capsules] that only drops use, is refused, and so is a biconcave drop (a drop relaxes to a sphere; started
// from the red cell's disc it stopped early). A placement that fails names [suspension] count when count was given.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "host/base/errors.hpp"
#include "host/physics/config.hpp"
#include "host/physics/initial_conditions.hpp"
#include "support/cli_runner.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using namespace capsflow;
using capsflow::test::expect_input_error;
using capsflow::test::run_capsflow;
using capsflow::test::snapshot_files;

// One drop, serial, a small box. The cases add keys with --set.
const char* kDrop =
    "[domain]\nH = 5.0\nLx = 6.0\nLz = 6.0\n[ggem]\nalpha = 4.0\n[run]\nbackend = \"serial\"\n[flow]\n"
    "type = \"shear\"\n[capsules]\nmesh_level = 1\n[[species]]\nname = \"a\"\nca = 0.1\nlaw = \"surface-tension\"\n"
    "[[capsule]]\nspecies = \"a\"\ncenter = [3.0, 2.5, 3.0]\n[time]\nend = 0.1\n[output]\nfile = \"out/run.h5\"\n";

std::string input_error(const std::string& text) {
  try {
    place_capsules(parse_config(text, "d.toml"));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string with(std::string text, const std::string& find, const std::string& replace) {
  const auto at = text.find(find);
  EXPECT_NE(at, std::string::npos) << find;
  return text.replace(at, find.size(), replace);
}

TEST(DropRefusals, InflationAndBiconcaveAreRefusedNamingTheKey) {
  if (capsflow::test::capsflow_binary_path().empty()) GTEST_SKIP() << "CAPSFLOW_BINARY is not set";
  capsflow::test::TempDir tmp;
  const fs::path work = tmp.path / "work";
  fs::create_directories(work / "out");
  // The drop with its own law (d) or with the law in [capsules], which the species inherits (c).
  const std::string own = kDrop;
  const std::string inherited = with(with(kDrop, "law = \"surface-tension\"\n", ""), "mesh_level = 1\n",
                                     "mesh_level = 1\nlaw = \"surface-tension\"\n");
  struct Case {
    bool law_inherited;
    const char* capsules_keys;  // more [capsules] lines
    const char* species_keys;   // more [[species]] lines
    const char* args;
    std::initializer_list<std::string> named;
  };
  const Case cases[] = {
      // A written inflation, even 0: a drop has no reference state.
      {false, "", "inflation = 0.1\n", "run d.toml", {"d.toml: [[species]] 1 inflation", "law = \"surface-tension\""}},
      {false, "", "inflation = 0\n", "run d.toml", {"d.toml: [[species]] 1 inflation", "got inflation = 0"}},
      {true, "", "inflation = 0.05\n", "run d.toml", {"d.toml: [[species]] 1 inflation", "[capsules] law"}},
      {false, "", "", "run d.toml --set species.1.inflation=0.1", {"--set species.1.inflation: expected no inflation"}},
      // [capsules] inflation when every capsule is a drop (no capsule would use it), from the file or an override.
      {false, "inflation = 0.0\n", "", "run d.toml", {"d.toml: [capsules] inflation", "every capsule is a drop"}},
      {true, "inflation = 0.2\n", "", "run d.toml", {"d.toml: [capsules] inflation", "got inflation = 0.2"}},
      {true, "", "", "run d.toml --set capsules.inflation=0.2", {"--set capsules.inflation", "every capsule is a drop"}},
      // A biconcave drop, its law its own or [capsules]'.
      {false, "", "shape = \"biconcave\"\n", "run d.toml", {"d.toml: [[species]] 1 shape", "\"biconcave\"", "law ="}},
      {true, "", "shape = \"biconcave\"\n", "run d.toml", {"d.toml: [[species]] 1 shape", "[capsules] law"}},
      // The dry run refuses them too.
      {false, "", "shape = \"biconcave\"\n", "run d.toml --dry-run", {"d.toml: [[species]] 1 shape"}},
      {true, "inflation = 0.1\n", "", "run d.toml --dry-run", {"d.toml: [capsules] inflation"}},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(std::string(k.args) + (k.law_inherited ? " (law in [capsules]) " : " ") + k.capsules_keys +
                 k.species_keys);
    std::string text = with(k.law_inherited ? inherited : own, "mesh_level = 1\n",
                            std::string("mesh_level = 1\n") + k.capsules_keys);
    text = with(text, "ca = 0.1\n", std::string("ca = 0.1\n") + k.species_keys);
    std::ofstream(work / "d.toml") << text;
    const auto before = snapshot_files(work);
    expect_input_error(run_capsflow(work, k.args, 60), k.named);
    EXPECT_EQ(snapshot_files(work), before);  // nothing written
  }
}

TEST(DropRefusals, WhatADropMayStillHave) {
  // No inflation: accepted, and the resolved text (capsflow's own, which leaves [capsules] inflation out when every
  // capsule is a drop) reads back to the same text.
  const Config c = parse_config(kDrop, "d.toml");
  EXPECT_EQ(to_toml(parse_config(to_toml(c), "d.toml")), to_toml(c));
  EXPECT_EQ(to_toml(c).find("inflation"), std::string::npos);
  // A run's stored config from before the refusal wrote [capsules] inflation for drops: it still reads (analyze,
  // --restart), with its value.
  const std::string stored = with(to_toml(c), "mesh_level = 1", "inflation = 0.0\nmesh_level = 1");
  EXPECT_EQ(parse_config(stored, "old.h5:/parameters/config").capsules.membrane.inflation, 0.0);
  // ... but the same text as a user's file (no resolved header) is refused.
  EXPECT_NE(input_error(with(stored, "# Resolved configuration", "# edited")).find("[capsules] inflation"),
            std::string::npos);
  // A [capsules] inflation beside a capsule species is that species' (the drop ignores it); a spheroidal drop relaxes.
  const std::string mixed =
      with(with(with(kDrop, "Lx = 6.0\nLz = 6.0", "Lx = 8.0\nLz = 8.0"), "mesh_level = 1\n",
                "mesh_level = 1\ninflation = 0.05\n"),
           "[[capsule]]",
           "[[species]]\nname = \"b\"\nca = 0.2\nshape = \"spheroid\"\naspect = 0.8\nlaw = \"surface-tension\"\n"
           "[[species]]\nname = \"c\"\nca = 0.2\n[[capsule]]");
  EXPECT_EQ(input_error(mixed), "");
  EXPECT_EQ(parse_config(mixed, "m.toml").species_membrane(2).inflation, 0.05);
}

// Mixed sizes placed at random: a placement that cannot be done names the key the user gave, count or
// volume_fraction (it named volume_fraction for both), and where an override set it.
TEST(PlacementRefusals, TheKeyGivenIsNamed) {
  const std::string box =
      "[domain]\nH = 10.15\nLx = 10.2\nLz = 10.2\n[[species]]\nname = \"big\"\nca = 0.2\n[[species]]\nname = "
      "\"small\"\nca = 0.2\nradius = 0.6\n[time]\nend = 1\n[suspension]\nfractions = [0.5, 0.5]\n";
  // 199 capsules are a volume fraction of 0.48 (< 0.5, so the count passes the config's check).
  struct Case {
    std::vector<std::string> sets;
    std::string starts, lower;
  };
  const Case cases[] = {
      {{"suspension.count=199"}, "--set suspension.count: count 199 (volume fraction 0.48) could not be placed",
       "lower [suspension] count or enlarge the box"},
      {{"suspension.volume_fraction=0.48"},
       "--set suspension.volume_fraction: volume fraction 0.48 could not be placed",
       "lower [suspension] volume_fraction or enlarge the box"},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.sets[0]);
    std::string msg;
    try {
      place_capsules(parse_config(box, "p.toml", k.sets));
    } catch (const InputError& e) {
      msg = e.what();
    }
    EXPECT_EQ(msg.rfind(k.starts, 0), 0u) << msg;
    EXPECT_NE(msg.find(k.lower), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  // In the file: the file names the key.
  std::string msg;
  try {
    place_capsules(parse_config(box + "count = 199\n", "p.toml"));
  } catch (const InputError& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg.rfind("p.toml: [suspension] count: count 199", 0), 0u) << msg;
}

}  // namespace
