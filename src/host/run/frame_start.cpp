// A run's frame as the start of another computation (frame_start.hpp): the frame read, its reference placement
// found, and a configuration checked against it.
#include "host/run/frame_start.hpp"

#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/printable.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/run/checkpoint.hpp"
#include "host/run/run_layout.hpp"
#include "host/state/icosphere.hpp"

namespace capsflow {

namespace fs = std::filesystem;

namespace {

// The shortest %g text that reads back as v: two values that differ never print alike.
std::string num(double v) {
  for (int d = 6; d < 17; ++d) {
    const std::string s = format_significant(v, d);
    if (std::strtod(s.c_str(), nullptr) == v) return s;
  }
  return format_significant(v, 17);
}

// The frame index `frame` asks for (negative: from the end), checked against the `count` frames of `file`.
std::size_t frame_index(const std::string& file, std::optional<long> frame, std::size_t count) {
  if (count == 0) throw InputError(file + ": no frames (a run writes one every [output] frames_every)");
  const long n = static_cast<long>(count);
  const long i = frame.value_or(-1);
  const long k = i < 0 ? n + i : i;
  if (k < 0 || k >= n)
    throw InputError("--frame " + std::to_string(i) + ": " + file + " has " + std::to_string(n) +
                     (n == 1 ? " frame (0, or -1 from the end)"
                             : " frames (0.." + std::to_string(n - 1) + ", or -1.." + std::to_string(-n) + " from the end)"));
  return static_cast<std::size_t>(k);
}

// The reference placement from the checkpoint beside the output, when it is this run's (the only record of it for a
// run that itself started from a frame). False when there is none or it belongs to another run.
bool placement_from_checkpoint(const std::string& file, const std::string& run_id, SimulationSnapshot& st) {
  const fs::path ck_path = run_paths(file).checkpoint;
  if (run_id.empty() || !fs::exists(ck_path)) return false;
  try {
    const Checkpoint ck = read_checkpoint(ck_path);
    if (ck.run_id != run_id) return false;
    st.initial_centres = ck.state.initial_centres;
    st.initial_orientations = ck.state.initial_orientations;
    return true;
  } catch (const std::exception&) {
    return false;  // a damaged checkpoint: the configuration's placement is the other record
  }
}

// The reference placement made again from the source's configuration; its species must be the file's, or the
// configuration did not place these capsules.
void placement_from_config(const FrameStart& f, const std::vector<std::int32_t>& species, SimulationSnapshot& st) {
  std::vector<CapsulePlacement> p;
  try {
    p = place_capsules(f.source);
  } catch (const InputError& e) {
    throw InputError(f.file + ": cannot place its capsules again from its /parameters/config: " + e.what());
  }
  bool same = p.size() == species.size();
  for (std::size_t k = 0; same && k < p.size(); ++k) same = p[k].species == species[k];
  if (!same)
    throw InputError(f.file + ": its /parameters/config does not place the capsules it holds, and " +
                     run_paths(f.file).checkpoint.string() + " (the record of their reference shapes) is missing");
  bool turned = false;
  for (const CapsulePlacement& c : p) {
    st.initial_centres.insert(st.initial_centres.end(), c.center.begin(), c.center.end());
    st.initial_orientations.insert(st.initial_orientations.end(), c.orientation.begin(), c.orientation.end());
    turned = turned || c.orientation != kIdentityRotation;
  }
  if (!turned) st.initial_orientations.clear();  // as a checkpoint stores them: none when every one is the identity
}

// Node positions of frame k, [Nn, 3], checked against the capsules and mesh level of the configuration.
std::vector<double> frame_positions(const FrameStart& f, std::size_t np) {
  const H5File h5 = H5File::open(f.file, H5Access::ReadShared);
  const std::vector<std::size_t> d = h5.dims(layout::kFramePositions);
  const std::size_t nv = icosphere(f.source.capsules.mesh_level).x.size();
  if (d.size() != 3 || d[1] != np * nv || d[2] != 3)
    throw InputError(f.file + ": " + layout::kFramePositions + " does not hold " + std::to_string(np) +
                     " capsules of mesh level " + std::to_string(f.source.capsules.mesh_level) + " (" +
                     std::to_string(np * nv) + " nodes)");
  return h5.read_records<double>(layout::kFramePositions, f.frame, 1).data;
}

}  // namespace

FrameStart read_frame_start(const std::string& file, std::optional<long> frame, const std::string& option) {
  const std::string named = option.empty() ? file : option + " " + file;
  if (!fs::exists(file)) throw InputError(named + ": no such file (expected a capsflow run's output, OUT.h5)");
  FrameStart f;
  f.file = file;
  RunFile r;
  try {
    r = read_run_file(file);
  } catch (const std::exception& e) {
    throw InputError(named + ": expected a capsflow run's output (OUT.h5): " + e.what());
  }
  f.frame = frame_index(file, frame, r.frames);
  f.strain = r.frame_time[f.frame];
  f.source = parse_config(r.config_text, file + ":/parameters/config");
  validate_run_config(f.source);

  SimulationSnapshot& st = f.state;
  const std::size_t np = r.np;
  st.species.assign(r.species.begin(), r.species.end());
  st.pinned.assign(r.pinned.begin(), r.pinned.end());
  st.image.assign(2 * np, 0);
  if (!placement_from_checkpoint(file, r.run_id, st)) {
    H5File h5 = H5File::open(file, H5Access::ReadShared);
    if (h5.has_attribute("/", kAttrStartedFrom))
      throw InputError(file + ": a run started from " + h5.attribute<std::string>("/", kAttrStartedFrom) +
                       "; the reference shapes of its capsules are recorded only in its checkpoint " +
                       run_paths(file).checkpoint.string() + ", which is missing or of another run");
    placement_from_config(f, r.species, st);
  }
  st.positions = frame_positions(f, np);
  st.u_previous.assign(st.positions.size(), 0.0);  // have_history = false: the first step is Euler's
  return f;
}

namespace {

std::string shape_text(const ShapeSpec& s) {
  switch (s.kind) {
    case ShapeKind::Sphere: return "sphere";
    case ShapeKind::Spheroid: return "spheroid of aspect " + num(s.aspect);
    case ShapeKind::Biconcave: return "biconcave";
  }
  return "?";
}

// What in species i builds its reference shape and differs between the two configurations ("" when nothing).
std::string reference_difference(const Config& a, const Config& b, std::size_t i) {
  const std::string name = "species '" + a.species[i].name + "' ";
  if (a.species_radius(i) != b.species_radius(i))
    return name + "radius " + num(a.species_radius(i)) + " in the frame, " + num(b.species_radius(i)) + " in CONFIG";
  const ShapeSpec &sa = a.species[i].shape, &sb = b.species[i].shape;
  if (sa.kind != sb.kind || sa.aspect != sb.aspect)
    return name + "shape " + shape_text(sa) + " in the frame, " + shape_text(sb) + " in CONFIG";
  const double ia = a.species_membrane(i).inflation, ib = b.species_membrane(i).inflation;
  if (ia != ib) return name + "inflation " + num(ia) + " in the frame, " + num(ib) + " in CONFIG";
  return "";
}

// What about the capsules themselves differs: their count, the capsules of each species, each [[capsule]]'s species
// and pin ("" when nothing).
std::string capsule_difference(const SimulationSnapshot& st, const Config& cfg) {
  const std::size_t np = st.species.size(), ns = cfg.species.size();
  const std::size_t want = cfg.capsule_list.empty() ? static_cast<std::size_t>(suspension_count(cfg))
                                                    : cfg.capsule_list.size();
  if (want != np)
    return "capsule count " + std::to_string(np) + " in the frame, " + std::to_string(want) + " in CONFIG";
  if (!cfg.capsule_list.empty()) {
    for (std::size_t k = 0; k < np; ++k) {
      const int s = cfg.species_index(cfg.capsule_list[k].species);
      if (s != st.species[k])
        return "[[capsule]] " + std::to_string(k + 1) + " is of species '" + cfg.capsule_list[k].species +
               "' in CONFIG, '" + cfg.species[static_cast<std::size_t>(st.species[k])].name + "' in the frame";
      if (cfg.capsule_list[k].pinned != (st.pinned[k] != 0))
        return "[[capsule]] " + std::to_string(k + 1) + " is " + (st.pinned[k] ? "" : "not ") +
               "pinned in the frame, " + (st.pinned[k] ? "not " : "") + "pinned in CONFIG";
    }
    return "";
  }
  std::vector<long> have(ns, 0);
  for (std::int64_t s : st.species) ++have[static_cast<std::size_t>(s)];
  const std::vector<long> want_each = species_counts(static_cast<long>(np), cfg.suspension->fractions);
  for (std::size_t i = 0; i < ns; ++i)
    if (have[i] != want_each[i])
      return "species '" + cfg.species[i].name + "' has " + std::to_string(have[i]) + " capsules in the frame, " +
             std::to_string(want_each[i]) + " by CONFIG's [suspension] fractions";
  for (std::int64_t p : st.pinned)
    if (p) return "the frame has pinned capsules, CONFIG's [suspension] pins none";
  return "";
}

}  // namespace

void check_frame_fits(const FrameStart& f, const Config& cfg) {
  const Config& src = f.source;
  std::string why;
  if (src.capsules.mesh_level != cfg.capsules.mesh_level) {
    why = "mesh level " + std::to_string(src.capsules.mesh_level) + " in the frame, " +
          std::to_string(cfg.capsules.mesh_level) + " in CONFIG ([capsules] mesh_level)";
  } else if (src.species.size() != cfg.species.size()) {
    why = std::to_string(src.species.size()) + " species in the frame, " + std::to_string(cfg.species.size()) +
          " in CONFIG";
  } else {
    for (std::size_t i = 0; why.empty() && i < src.species.size(); ++i)
      if (src.species[i].name != cfg.species[i].name)
        why = "species " + std::to_string(i + 1) + " is '" + src.species[i].name + "' in the frame, '" +
              cfg.species[i].name + "' in CONFIG";
    for (std::size_t i = 0; why.empty() && i < src.species.size(); ++i) why = reference_difference(src, cfg, i);
    if (why.empty()) why = capsule_difference(f.state, cfg);
  }
  if (!why.empty())
    throw InputError(f.file + " frame " + std::to_string(f.frame) + " and " + cfg.source + " disagree: " + why);
}

}  // namespace capsflow
