// The embedded demo's closing text (demo_summary.hpp): the species' mean distances from the centreline read back
// from the run's output file, so that the numbers printed are the ones anyone can recompute from it.
#include "host/cli/demo_summary.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/cli/figures_command.hpp"
#include "host/run/run_layout.hpp"

namespace capsflow {
namespace fs = std::filesystem;

CentreDistanceSummary centre_distance_summary(const fs::path& run_h5) {
  check_run_output(run_h5.string());
  const H5File f = H5File::open(run_h5, H5Access::ReadShared);
  CentreDistanceSummary s;
  try {
    s.H = toml::parse(f.read_string(layout::kConfig))["domain"]["H"].value<double>().value_or(0.0);
  } catch (const toml::parse_error& e) {
    throw InputError(run_h5.string() + ": " + layout::kConfig + " is not TOML (" + std::string(e.description()) + ")");
  }
  if (!(s.H > 0)) throw InputError(run_h5.string() + ": no [domain] H > 0 in " + layout::kConfig);
  const std::vector<double> t = f.read<double>(layout::kTime).data;
  const H5Array<double> c = f.read<double>(layout::kCentroid);
  const std::vector<std::int32_t> slot = f.read<std::int32_t>(layout::kCapsuleSpecies).data;
  const std::vector<double> ca = f.read<double>(layout::kCapsuleCa).data;
  const std::size_t np = slot.size();
  // A live or cut-short file may hold one more time than centroid record: the records both hold.
  const std::size_t nt = std::min(t.size(), c.dims.empty() ? std::size_t{0} : c.dims[0]);
  if (nt == 0 || c.dims.size() != 3 || c.dims[1] != np || c.dims[2] != 3 || ca.size() != np)
    throw InputError(run_h5.string() + ": no records, or /series/centroid does not match /capsules");
  s.frames = f.exists(layout::kFramePositions) ? f.extent(layout::kFramePositions) : 0;

  std::stringstream names(f.has_attribute(layout::kCapsuleSpecies, "names")
                              ? f.attribute<std::string>(layout::kCapsuleSpecies, "names")
                              : std::string());
  for (std::string n; std::getline(names, n, ',');) s.species.push_back({n});
  for (std::size_t p = 0; p < np; ++p) {
    if (slot[p] < 0) continue;
    const auto k = static_cast<std::size_t>(slot[p]);
    while (s.species.size() <= k) s.species.push_back({"species " + std::to_string(s.species.size())});
    s.species[k].ca = ca[p];
    ++s.species[k].capsules;
  }
  // The second half: the capsules start from the configuration's placement and need strain to migrate.
  const double half = 0.5 * t[nt - 1];
  std::vector<double> sum(s.species.size(), 0.0);
  for (std::size_t r = 0; r < nt; ++r) {
    if (t[r] < half) continue;
    if (s.records == 0) s.from = t[r];
    s.to = t[r];
    ++s.records;
    for (std::size_t p = 0; p < np; ++p)
      if (slot[p] >= 0) sum[static_cast<std::size_t>(slot[p])] += std::abs(c.data[(r * np + p) * 3 + 1] - 0.5 * s.H);
  }
  for (std::size_t k = 0; k < s.species.size(); ++k)
    s.species[k].mean_distance =
        s.species[k].capsules ? sum[k] / static_cast<double>(s.species[k].capsules * s.records) : std::nan("");
  return s;
}

std::string demo_look_text(const fs::path& run_h5) {
  const CentreDistanceSummary s = centre_distance_summary(run_h5);
  std::string out;
  char line[4096];  // room for long paths
  std::snprintf(line, sizeof line,
                "\nWhat to look at: where each species sits across the slit (H = %g a; a wall is H/2 = %g a from the "
                "centreline).\nMean distance from the centreline over the second half of this run (strain %.4g to "
                "%.4g, %zu records of %s):\n",
                s.H, 0.5 * s.H, s.from, s.to, s.records, run_h5.string().c_str());
  out += line;
  for (const SpeciesCentreDistance& sp : s.species) {
    std::snprintf(line, sizeof line, "  %-8s Ca %-4g %3zu capsules   %.3f a = %.4f H\n", sp.name.c_str(), sp.ca,
                  sp.capsules, sp.mean_distance, sp.mean_distance / s.H);
    out += line;
  }
  if (s.species.size() == 2 && s.species[0].ca != s.species[1].ca) {
    // Stiff: the smaller capillary number (the stiffer membrane), as everywhere in capsflow.
    const bool first_stiff = s.species[0].ca < s.species[1].ca;
    const SpeciesCentreDistance& stiff = s.species[first_stiff ? 0 : 1];
    const SpeciesCentreDistance& floppy = s.species[first_stiff ? 1 : 0];
    const double diff = stiff.mean_distance - floppy.mean_distance;
    // "stiff (name)" where the configuration names its species otherwise.
    const std::string st = stiff.name == "stiff" ? "stiff" : "stiff (" + stiff.name + ")";
    const std::string fl = floppy.name == "floppy" ? "floppy" : "floppy (" + floppy.name + ")";
    const std::size_t n = stiff.capsules + floppy.capsules;
    if (std::abs(diff) < 0.0005)  // below the digits printed: not separated (yet)
      std::snprintf(line, sizeof line,
                    "The %s and %s capsules sit equally far from the centreline (to 0.001 a): this run is too short "
                    "for them to separate.\n", st.c_str(), fl.c_str());
    else if (diff > 0)
      std::snprintf(line, sizeof line,
                    "The %s capsules sit nearer the walls, %.3f a = %.4f H farther from the centreline than the %s "
                    "ones:\nthe segregation by membrane rigidity of Kumar & Graham (Phys. Rev. E 84, 2011): the floppy "
                    "capsules drift toward\nthe centre and push the stiff ones toward the walls (here %zu capsules, a "
                    "small sample).\n",
                    st.c_str(), diff, diff / s.H, fl.c_str(), n);
    else
      std::snprintf(line, sizeof line,
                    "The %s capsules sit nearer the walls here, %.3f a = %.4f H farther from the centreline than the "
                    "%s ones:\nthe opposite of Kumar & Graham's finding (stiff nearer the walls); %zu capsules over "
                    "%.4g strain are a small sample.\n",
                    fl.c_str(), -diff, -diff / s.H, st.c_str(), n, s.to);
    out += line;
  }
  // Where tools/demo.sh draws them: figures/ and pictures/ beside the run, the render's last frame numbered as
  // `capsflow render` numbers it (at least four digits).
  const fs::path dir = run_h5.parent_path(), stem = run_h5.stem();
  std::string frame = s.frames ? std::to_string(s.frames - 1) : "0";
  if (frame.size() < 4) frame.insert(0, 4 - frame.size(), '0');
  const fs::path diag = dir / "figures" / (stem.string() + "_run_diagnostics.png");
  const fs::path snap = dir / "figures" / "fig02_snapshots.png";
  const fs::path render = dir / "pictures" / (stem.string() + "_species_f" + frame + ".png");
  std::snprintf(line, sizeof line,
                "  diagnostics  %s  (a): every capsule's height y_c/H against strain\n"
                "  snapshot     %s  the last frame seen along z\n"
                "  render       %s  the last frame in 3D, side view\n",
                diag.string().c_str(), snap.string().c_str(), render.string().c_str());
  out += line;
  out += "(bash tools/demo.sh draws these three; by hand: capsflow analyze, figures and render, docs/usage.md)\n";
  return out;
}

}  // namespace capsflow
