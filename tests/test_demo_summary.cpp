// The embedded demo's closing text (src/host/cli/demo_summary.cpp) on hand-made run outputs whose answer is known:
// the window is the run's second half, the distances are |y_c - H/2| per species in a and H, the species nearer
// the walls is named the right way round (and neither when they are level), and the figure and picture paths are
// the ones tools/demo.sh writes. tests/python/test_demo_summary.py checks it against a real run.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/cli/demo_summary.hpp"
#include "support/temp_dir.hpp"

namespace capsflow::test {
namespace {

namespace fs = std::filesystem;

constexpr double kH = 8.0;

// A run output with the datasets the summary reads: 4 capsules (stiff, floppy, floppy, stiff), records at strain
// 0, 1, ..., 10; in the first half every capsule sits at the centreline, from strain 5 on each species at its
// distance (above the centreline for capsules 0 and 1, below for 2 and 3, so that a signed mean would give 0).
fs::path write_run(const fs::path& dir, double d_stiff, double d_floppy) {
  const fs::path p = dir / "demo.h5";
  H5File f = H5File::create(p, true);
  f.create_group("/parameters");
  f.write_string("/parameters/config", "[domain]\nH = 8.0\nLx = 8.0\nLz = 8.0\n");
  f.create_group("/capsules");
  const std::vector<std::int32_t> species = {0, 1, 1, 0};
  f.write("/capsules/species", {4}, species);
  f.set_attribute("/capsules/species", "names", std::string("stiff,floppy"));
  f.write("/capsules/ca", {4}, std::vector<double>{0.2, 1.0, 1.0, 0.2});
  f.create_group("/series");
  const std::size_t nt = 11;
  std::vector<double> t(nt), c(nt * 4 * 3, 1.0);
  for (std::size_t r = 0; r < nt; ++r) {
    t[r] = static_cast<double>(r);
    for (std::size_t k = 0; k < 4; ++k) {
      const double d = r < 5 ? 0.0 : (species[k] == 0 ? d_stiff : d_floppy);
      c[(r * 4 + k) * 3 + 1] = 0.5 * kH + (k < 2 ? d : -d);
    }
  }
  f.write("/series/time", {nt}, t);
  f.write("/series/centroid", {nt, 4, 3}, c);
  f.create_group("/frames");
  f.write("/frames/positions", {81, 1, 3}, std::vector<double>(81 * 3, 0.0));
  return p;
}

TEST(DemoSummary, AveragesTheDistanceFromTheCentrelineOverTheSecondHalf) {
  TempDir tmp;
  const CentreDistanceSummary s = centre_distance_summary(write_run(tmp.path, 3.0, 1.0));
  EXPECT_DOUBLE_EQ(s.H, kH);
  EXPECT_EQ(s.records, 6u);  // strain 5 to 10
  EXPECT_DOUBLE_EQ(s.from, 5.0);
  EXPECT_DOUBLE_EQ(s.to, 10.0);
  ASSERT_EQ(s.species.size(), 2u);
  EXPECT_EQ(s.species[0].name, "stiff");
  EXPECT_EQ(s.species[0].capsules, 2u);
  EXPECT_DOUBLE_EQ(s.species[0].ca, 0.2);
  EXPECT_DOUBLE_EQ(s.species[0].mean_distance, 3.0);
  EXPECT_EQ(s.species[1].name, "floppy");
  EXPECT_DOUBLE_EQ(s.species[1].mean_distance, 1.0);
}

TEST(DemoSummary, TheTextNamesTheSpeciesNearerTheWalls) {
  TempDir tmp;
  const std::string stiff_out = demo_look_text(write_run(tmp.path, 3.0, 1.0));
  EXPECT_NE(stiff_out.find("stiff    Ca 0.2    2 capsules   3.000 a = 0.3750 H"), std::string::npos) << stiff_out;
  EXPECT_NE(stiff_out.find("floppy   Ca 1      2 capsules   1.000 a = 0.1250 H"), std::string::npos) << stiff_out;
  EXPECT_NE(stiff_out.find("The stiff capsules sit nearer the walls, 2.000 a = 0.2500 H farther"), std::string::npos)
      << stiff_out;
  EXPECT_NE(stiff_out.find("strain 5 to 10, 6 records"), std::string::npos) << stiff_out;

  const std::string floppy_out = demo_look_text(write_run(tmp.path, 1.0, 2.5));
  EXPECT_NE(floppy_out.find("The floppy capsules sit nearer the walls here, 1.500 a = 0.1875 H farther"),
            std::string::npos)
      << floppy_out;
  EXPECT_NE(floppy_out.find("the opposite of Kumar & Graham's finding"), std::string::npos) << floppy_out;

  const std::string level = demo_look_text(write_run(tmp.path, 2.0, 2.0));
  EXPECT_NE(level.find("sit equally far from the centreline"), std::string::npos) << level;
  EXPECT_EQ(level.find("nearer the walls"), std::string::npos) << level;
}

TEST(DemoSummary, NamesTheFiguresAndThePictureThatTheDemoDraws) {
  TempDir tmp;
  const fs::path run = write_run(tmp.path, 3.0, 1.0);
  const std::string out = demo_look_text(run);
  for (const fs::path& p : {tmp.path / "figures" / "demo_run_diagnostics.png", tmp.path / "figures" / "fig02_snapshots.png",
                            tmp.path / "pictures" / "demo_species_f0080.png"})  // 81 frames: the last is 80
    EXPECT_NE(out.find(p.string()), std::string::npos) << p << " not in\n" << out;
}

TEST(DemoSummary, RefusesAFileThatIsNotARunOutput) {
  TempDir tmp;
  const fs::path p = tmp.path / "other.h5";
  { H5File f = H5File::create(p, true); f.create_group("/series"); }
  EXPECT_THROW(centre_distance_summary(p), InputError);
}

}  // namespace
}  // namespace capsflow::test
