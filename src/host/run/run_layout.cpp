// The implementation of run_layout.hpp: the layout of a run's files, in one place.
#include "host/run/run_layout.hpp"

#include <string>
#include <system_error>

#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"

namespace capsflow {

namespace layout {

std::string frame_view_path(const std::string& frames_dataset, std::size_t frame) {
  return std::string(kFrameViews) + "/" + frames_dataset.substr(frames_dataset.rfind('/') + 1) + "/" +
         std::to_string(frame);
}

const std::vector<DatasetInfo>& output_datasets() {
  using G = Growth;
  static const std::vector<DatasetInfo> table = {
      {kConfig, G::Fixed, "string", "scalar", 1, "none",
       "the resolved configuration as TOML: every key, defaults filled in, doubles in the shortest form that reads back exactly"},
      {kMeshTriangles, G::Fixed, "int32", "[Nt, 3]",
       1, "1", "triangles of one capsule (local node numbers, outward orientation); attribute `mesh_level`"},
      {kMeshTrianglesAll, G::Fixed, "int32", "[Np Nt, 3]", 1, "1",
       "all capsules' triangles, global node numbers (what XDMF draws)"},
      {kMeshNodeSpecies, G::Fixed, "int32", "[Nn]", 1, "1", "species index of each node"},
      {kMeshNodeCapsule, G::Fixed, "int32", "[Nn]", 1, "1", "capsule of each node (node k nv + i belongs to capsule k)"},
      {kCapsuleSpecies, G::Fixed, "int32", "[Np]", 1, "1",
       "species index of each capsule (in `[[species]]` order); attribute `names` (comma-separated)"},
      {kCapsuleCa, G::Fixed, "double", "[Np]", 1, "1", "capillary number of each capsule"},
      {kCapsulePinned, G::Fixed, "int32", "[Np]", 1, "1", "1 for a pinned capsule (D10)"},
      {kTime, G::PerRecord, "double", "[T]", 1, "1/gammadot",
       "strain of each record (the first step at or past each multiple of `every`)"},
      {kStep, G::PerRecord, "int64", "[T]", 1, "1", "step number"},
      {kDt, G::PerRecord, "double", "[T]", 1, "1/gammadot", "the last step size (strain; 0 at the start)"},
      {kMaxStepRatio, G::PerRecord, "double", "[T]", 2, "1",
       "largest dt_n / dt_(n-1) since the previous record (0 before the second step)"},
      {kContactCorrections, G::PerRecord, "int64", "[T]", 1, "1", "contact pushes so far (pairs + walls, iterations counted)"},
      {kCentroid, G::PerRecord, "double", "[T, Np, 3]", 1, "a",
       "centres of mass, with the periodic shifts in x and z undone (continuous trajectories)"},
      {kVelocity, G::PerRecord, "double", "[T, Np, 3]", 1, "gammadot a",
       "volume-averaged capsule velocities (before the pinning correction: a pinned capsule's migration velocity)"},
      {kTaylorD, G::PerRecord, "double", "[T, Np]", 1, "1", "Taylor deformation (L - B)/(L + B) in the x-y plane"},
      {kInclination, G::PerRecord, "double", "[T, Np]", 1, "rad", "angle of L from x (radians)"},
      {kVolume, G::PerRecord, "double", "[T, Np]", 1, "a^3", "enclosed volume"},
      {kArea, G::PerRecord, "double", "[T, Np]", 1, "a^2", "membrane area"},
      {kProfile, G::PerRecord, "double", "[T, Ns, B]", 2, "a^3",
       "interior volume of the capsules of each species in each of B = `profile_bins` equal slabs of [0, H] (exact "
       "for the triangulated surfaces); attribute `bins`"},
      {kFlowRateRatio, G::PerRecord, "double", "[T]", 2, "1",
       "Poiseuille: flow rate of the suspension over that of the particle-free slit at the same pressure drop "
       "(NaN in shear)"},
      {kRelativeViscosity, G::PerRecord, "double", "[T]", 2, "1",
       "shear: wall shear stress of the suspension over that of the particle-free slit (NaN in Poiseuille)"},
      {kStepLimits, G::PerRecord, "int64", "[T, 5]", 4, "1",
       "steps since the previous record by what set their size: membrane rule (or paper rule with h inside a "
       "capsule), membrane rule times near_contact_factor, collision cap, max_step_ratio, paper rule with h between "
       "capsules"},
      {kClosestGap, G::PerRecord, "double", "[T]", 4, "a",
       "smallest capsule-capsule gap (signed node-surface distance) if below h_e, the mean edge of the initial "
       "mesh; inf otherwise"},
      {kWallGap, G::PerRecord, "double", "[T]", 4, "a", "smallest node-wall gap if below h_e; inf otherwise"},
      {kAb2Error, G::PerRecord, "double", "[T]", 4, "a",
       "AB2 truncation proxy (5/12) dt max_i |u^n - 2 u^(n-1) + u^(n-2)| (length; NaN before two steps)"},
      {kGmresIterations, G::PerRecord, "double", "[T]", 6, "1",
       "viscosity ratio != 1: mean GMRES operator applications per step since the previous record (0 without the "
       "interface-velocity solve)"},
      {kGmresResidual, G::PerRecord, "double", "[T]", 6, "1",
       "viscosity ratio != 1: largest final relative GMRES residual since the previous record (0 without the solve)"},
      {kFrameTime, G::PerFrame, "double", "[F]", 1, "1/gammadot", "strain of each frame"},
      {kFramePositions, G::PerFrame, "double", "[F, Nn, 3]", 1, "a",
       "node coordinates (each capsule shifted by whole periods so that its node mean lies in the box)"},
      {kFrameVelocity, G::PerFrame, "double", "[F, Nn, 3]", 1, "gammadot a", "node velocities (the ones the surface moves with)"},
      {kFrameTractionJump, G::PerFrame, "float32", "[F, Nn, 3]", 5, "mu gammadot",
       "traction jump (sigma_out - sigma_in) n across the membrane (n outward) = minus the force per current area that "
       "the membrane exerts on the fluid, -F_i / A_i (the single layer's density with the sign turned); single "
       "precision, as the other membrane fields: for viewing"},
      {kFrameTensionMax, G::PerFrame, "float32", "[F, Nn]", 5, "mu gammadot a",
       "larger principal Cauchy tension (force per current length) of the elements at the node, averaged with their "
       "current areas as weights"},
      {kFrameTensionMin, G::PerFrame, "float32", "[F, Nn]", 5, "mu gammadot a",
       "smaller principal Cauchy tension, averaged as tension_max"},
      {kFrameEnergyDensity, G::PerFrame, "float32", "[F, Nn]", 5, "mu gammadot a",
       "strain energy W per unit reference area of the membrane law, averaged as tension_max"},
      {kEventTime, G::PerEvent, "double", "[E]", 2, "1/gammadot", "strain of the step whose contact control made the correction"},
      {kEventCapsules, G::PerEvent, "int32", "[E, 2]", 2, "1",
       "capsules (p, q) of a pair correction; a wall correction has q = -1 (wall y = 0) or -2 (wall y = H)"},
      {kEventGap, G::PerEvent, "double", "[E]", 2, "a", "gap before the correction (signed surface distance; < min_gap)"},
      {kEventDy, G::PerEvent, "double", "[E, 2]", 2, "a", "y-displacement of p and of q by this correction (0 for a wall)"},
  };
  return table;
}

std::vector<const char*> frame_view_sources(std::int64_t version) {
  std::vector<const char*> out;
  if (version < 3) return out;
  for (const DatasetInfo* d : extendable(Growth::PerFrame, version))
    if (std::string(d->path) != kFrameTime) out.push_back(d->path);
  return out;
}

std::vector<const DatasetInfo*> extendable(Growth growth, std::int64_t version) {
  std::vector<const DatasetInfo*> out;
  for (const DatasetInfo& d : output_datasets())
    if (d.growth == growth && d.since <= version) out.push_back(&d);
  return out;
}

}  // namespace layout

RunPaths run_paths(const std::string& output_file) {
  namespace fs = std::filesystem;
  RunPaths p;
  p.h5 = fs::path(output_file);
  p.xdmf = p.h5;
  p.xdmf.replace_extension(".xdmf");
  const std::string stem = p.h5.stem().string();
  p.checkpoint = p.h5.parent_path() / (stem + ".checkpoint.h5");
  p.lock = p.h5.parent_path() / (stem + ".lock");
  return p;
}

namespace {
// output.part-NNN.h5 (three digits or more), tools/run_store.py's name of a part: its number, or 0.
long store_part_number(const std::string& name) {
  const std::string head = "output.part-", tail = ".h5";
  if (name.size() < head.size() + 3 + tail.size() || name.compare(0, head.size(), head) != 0 ||
      name.compare(name.size() - tail.size(), tail.size(), tail) != 0)
    return 0;
  const std::string digits = name.substr(head.size(), name.size() - head.size() - tail.size());
  for (const char c : digits)
    if (c < '0' || c > '9') return 0;
  return digits.size() <= 9 ? std::stol(digits) : 0;
}

// The number of parts in `dir` (a store keeps them beside its base).
std::size_t parts_in(const std::filesystem::path& dir) {
  std::size_t n = 0;
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator(dir, ec); !ec && it != std::filesystem::directory_iterator();
       it.increment(ec))
    if (store_part_number(it->path().filename().string()) > 0) ++n;
  return n;
}

std::vector<std::string> split_names(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t c = s.find(',', start);
    out.push_back(s.substr(start, c == std::string::npos ? std::string::npos : c - start));
    if (c == std::string::npos) break;
    start = c + 1;
  }
  return out;
}
}  // namespace

void refuse_run_store_file(const H5File& f, const std::filesystem::path& path) {
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const std::string restore = "restore the store with tools/run_store.py restore " + dir.string() +
                              " RUN_DIR and give RUN_DIR/output.h5";
  const bool part = f.exists("/_store");
  if (!part && path.filename() != "output.h5") return;  // a store's base is always output.h5: nothing to list
  const std::size_t parts = parts_in(dir);
  if (part) {
    const long k = f.has_attribute("/_store", "part") ? static_cast<long>(f.attribute<std::int64_t>("/_store", "part"))
                                                 : store_part_number(path.filename().string());
    const std::string which = k > 0 ? "part " + std::to_string(k) + " of " + std::to_string(parts) : "a part";
    const std::string from = f.has_attribute("/_store", "series/time")
                                 ? ", its records from record " +
                                       std::to_string(f.attribute<std::int64_t>("/_store", "series/time")) + " on"
                                 : "";
    throw RunStoreFileError(path.string() + ": " + which + " of a run store (tools/run_store.py" + from +
                            "), not a run output: " + restore);
  }
  if (parts > 0)
    throw RunStoreFileError(path.string() + ": the base of a run store with " + std::to_string(parts) +
                            " part(s) beside it (the records to its first save only), not the whole run: " + restore);
}

RunFile read_run_file(const std::filesystem::path& path) {
  using namespace layout;
  const H5File f = H5File::open(path, H5Access::ReadShared);
  RunFile r;
  r.path = path;
  refuse_run_store_file(f, path);
  if (!f.exists(kConfig) || !f.exists(kCapsuleSpecies))
    throw InputError(path.string() + ": not a capsflow run output (no " + std::string(kConfig) + " or " +
                     kCapsuleSpecies + ")");
  if (f.has_attribute("/", kAttrFormat)) r.format_version = f.attribute<std::int64_t>("/", kAttrFormat);
  if (r.format_version > kFormatVersion)
    throw InputError(path.string() + ": written in output format " + std::to_string(r.format_version) +
                     "; this capsflow reads formats up to " + std::to_string(kFormatVersion) + " (a newer capsflow wrote it)");
  if (f.has_attribute("/", kAttrRunId)) r.run_id = f.attribute<std::string>("/", kAttrRunId);
  if (f.has_attribute("/", kAttrVersion)) r.capsflow_version = f.attribute<std::string>("/", kAttrVersion);
  if (f.has_attribute("/", kAttrFlowRateRevision))
    r.flow_rate_revision = f.attribute<std::int64_t>("/", kAttrFlowRateRevision);
  r.config_text = f.read_string(kConfig);
  if (f.has_attribute(kCapsuleSpecies, "names"))
    r.species_names = split_names(f.attribute<std::string>(kCapsuleSpecies, "names"));
  r.species = f.read<std::int32_t>(kCapsuleSpecies).data;
  r.pinned = f.read<std::int32_t>(kCapsulePinned).data;
  r.ca = f.read<double>(kCapsuleCa).data;
  r.np = r.species.size();
  r.nspecies = r.species_names.size();

  // A live run appends the series one after the other: read each up to the shortest, so a record is complete.
  auto extent = [&](const char* p) { return f.exists(p) ? f.extent(p) : std::size_t{0}; };
  r.records = extent(kTime);
  for (const DatasetInfo* d : extendable(Growth::PerRecord, r.format_version))
    if (f.exists(d->path)) r.records = std::min(r.records, f.extent(d->path));
  auto rd = [&](const char* p, std::vector<double>& out) {
    if (f.exists(p) && r.records > 0) out = f.read_records<double>(p, 0, r.records).data;
  };
  auto ri = [&](const char* p, std::vector<std::int64_t>& out) {
    if (f.exists(p) && r.records > 0) out = f.read_records<std::int64_t>(p, 0, r.records).data;
  };
  rd(kTime, r.time);
  rd(kDt, r.dt);
  rd(kMaxStepRatio, r.max_step_ratio);
  ri(kStep, r.step);
  ri(kContactCorrections, r.contact_corrections);
  rd(kCentroid, r.centroid);
  rd(kVelocity, r.velocity);
  rd(kTaylorD, r.taylor_D);
  rd(kInclination, r.inclination);
  rd(kVolume, r.volume);
  rd(kArea, r.area);
  rd(kFlowRateRatio, r.flow_rate_ratio);
  rd(kRelativeViscosity, r.relative_viscosity);
  ri(kStepLimits, r.step_limits);
  rd(kClosestGap, r.closest_gap);
  rd(kWallGap, r.wall_gap);
  rd(kAb2Error, r.ab2_error);
  rd(kGmresIterations, r.gmres_iterations);
  rd(kGmresResidual, r.gmres_residual);
  if (f.exists(kProfile)) {
    const std::vector<std::size_t> d = f.dims(kProfile);
    if (d.size() == 3) {
      r.profile_bins = d[2];
      r.nspecies = d[1];
      rd(kProfile, r.profile);
    }
  }
  r.frames = extent(kFrameTime);
  for (const DatasetInfo* d : extendable(Growth::PerFrame, r.format_version))
    if (f.exists(d->path)) r.frames = std::min(r.frames, f.extent(d->path));
  if (r.frames > 0) r.frame_time = f.read_records<double>(kFrameTime, 0, r.frames).data;
  r.events = extent(kEventTime);
  for (const DatasetInfo* d : extendable(Growth::PerEvent, r.format_version))
    if (f.exists(d->path)) r.events = std::min(r.events, f.extent(d->path));
  if (r.events > 0) {
    r.event_time = f.read_records<double>(kEventTime, 0, r.events).data;
    r.event_gap = f.read_records<double>(kEventGap, 0, r.events).data;
    r.event_dy = f.read_records<double>(kEventDy, 0, r.events).data;
    r.event_capsules = f.read_records<std::int32_t>(kEventCapsules, 0, r.events).data;
  }
  return r;
}

}  // namespace capsflow
