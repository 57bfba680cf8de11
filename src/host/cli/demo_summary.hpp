#pragma once
// What the README demo's run shows, read back from its output: each species' mean distance from the centreline over
// the second half of the run, and the text `capsflow run` prints after the embedded demo (tools/demo.sh repeats it at
// its end) saying what to look at and where the demo's figures and picture are.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace capsflow {

struct SpeciesCentreDistance {
  std::string name;
  double ca = 0;              // the species' capillary number (from /capsules/ca)
  std::size_t capsules = 0;
  double mean_distance = 0;   // mean over its capsules and the window's records of |y_c - H/2|, in a
};

struct CentreDistanceSummary {
  double H = 0;                    // slit height, in a
  double from = 0, to = 0;         // the window: strain of its first and last record
  std::size_t records = 0;         // records in the window
  std::size_t frames = 0;          // frames in the file (the render draws the last)
  std::vector<SpeciesCentreDistance> species;  // in [[species]] order
};

// Reads RUN.h5 (a capsflow run output) and averages |y_c - H/2| over the records of the second half of its strain
// (time >= half the last record's), where the random start has relaxed. InputError if the file is not a run output.
CentreDistanceSummary centre_distance_summary(const std::filesystem::path& run_h5);

// The demo's closing text: both species' mean distances in a and H, which one sits nearer the walls, and the paths
// of the diagnostics figure, the snapshot figure and the side-view render that tools/demo.sh writes beside RUN.h5
// (figures/, pictures/).
std::string demo_look_text(const std::filesystem::path& run_h5);

}  // namespace capsflow
