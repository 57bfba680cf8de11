// The implementation of run_output.hpp: RunOutput, which writes OUT.h5 and OUT.xdmf for a running Simulation.
#include "host/run/run_output.hpp"

#include "capsflow_version.hpp"
#include "host/base/backend_select.hpp"
#include "host/base/atomic_file.hpp"
#include "host/base/build_info.hpp"
#include "host/base/errors.hpp"
#include "host/run/frame_start.hpp"

#include <cctype>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <utility>
#include <vector>
#include <system_error>

namespace capsflow {

using namespace layout;

namespace {
const DatasetInfo& info(const char* path) {
  for (const DatasetInfo& d : output_datasets())
    if (std::string(d.path) == path) return d;
  throw std::logic_error(std::string("run_layout: no dataset ") + path);
}
using Keep = std::pair<Growth, std::int64_t>;

// Frame f's view of the per-frame dataset `src` (format 3), with the source's units.
void make_frame_view(H5File& f, const char* src, std::size_t frame) {
  const std::vector<std::size_t> d = f.dims(src);
  const std::string view = frame_view_path(src, frame);
  f.create_record_view(view, src, frame, std::vector<std::size_t>(d.begin() + 1, d.end()));
  if (f.has_attribute(src, kAttrDatasetUnits))
    f.set_attribute(view, kAttrDatasetUnits, f.attribute<std::string>(src, kAttrDatasetUnits));
}

// Truncates the growing datasets of `f` to the counts in `keep` and removes the frame views past the kept frames.
void truncate_to(H5File& f, const std::vector<Keep>& keep, std::int64_t version) {
  for (const auto& [growth, n] : keep)
    for (const DatasetInfo* d : extendable(growth, version))
      if (f.exists(d->path)) f.truncate(d->path, static_cast<std::size_t>(n));
  for (const char* src : frame_view_sources(version)) {
    const std::string group = frame_view_path(src, 0).substr(0, frame_view_path(src, 0).rfind('/'));
    if (!f.exists(group)) continue;
    for (const std::string& name : f.children(group))
      if (std::stoll(name) >= keep[1].second) f.remove(group + "/" + name);
  }
}

// The datasets a running output appends to record by record (the series, the events, the frame times): plain while
// the run lives (their chunks are rewritten in place), compressed once it has ended (compress_finished_output).
bool appended_by_record(const DatasetInfo& d) {
  return d.growth == Growth::PerRecord || d.growth == Growth::PerEvent ||
         (d.growth == Growth::PerFrame && std::string(d.shape) == "[F]");
}

// Copies the run file `h5` into the new file `dst`: every group but the frame views, attributes included; the datasets
// appended by record re-chunked with `series_level` (0: plain, as a running output needs them; else shuffle + deflate
// for a finished one); everything else as it is (the frames' compressed chunks are copied without being inflated).
// Of the growing datasets only the records in `keep` (when given) are copied; then the frame views are made again.
void copy_output(const std::filesystem::path& h5, const std::filesystem::path& dst_path, int series_level,
                 const std::vector<Keep>& keep, std::int64_t version) {
  const H5File src = H5File::open(h5, H5Access::ReadOnly);
  H5File dst = H5File::create(dst_path, false);
  src.copy_attributes("/", dst, "/");
  std::set<std::string> rechunk;
  for (const DatasetInfo& d : output_datasets())
    if (d.since <= version && appended_by_record(d)) rechunk.insert(d.path);
  const std::string views = std::string(kFrameViews).substr(1);
  for (const std::string& name : src.children("/")) {
    const std::string group = "/" + name;
    if (name == views) continue;
    bool holds_series = false;
    for (const std::string& p : rechunk) holds_series = holds_series || p.rfind(group + "/", 0) == 0;
    if (!holds_series) {
      src.copy_object(group, dst);
      continue;
    }
    dst.create_group(group);
    src.copy_attributes(group, dst, group);
    for (const std::string& child : src.children(group)) {
      const std::string p = group + "/" + child;
      // Only the records kept are read: past them, a file whose last flush did not finish may point to bytes that
      // were never written.
      std::size_t records = H5File::kAllRecords;
      for (const auto& [growth, n] : keep)
        for (const DatasetInfo* d : extendable(growth, version))
          if (p == d->path) records = static_cast<std::size_t>(n);
      if (rechunk.count(p)) src.copy_dataset_rechunked(p, dst, series_level, records);
      else src.copy_object(p, dst, records);
    }
  }
  if (!keep.empty()) truncate_to(dst, keep, version);  // (a growing dataset outside the groups above)
  const std::size_t frames = dst.exists(kFramePositions) ? dst.extent(kFramePositions) : 0;
  for (const char* s : frame_view_sources(version))
    if (dst.exists(s))
      for (std::size_t f = 0; f < frames; ++f) make_frame_view(dst, s, f);
  dst.close();
}

// A flush that failed on a full disk can leave the file's index pointing past its end: the records the checkpoint
// covers still read, but the file cannot be changed in place. Rebuilt instead (copy_output, with plain series), the
// growing datasets truncated to the checkpoint; the new file replaces the old atomically (the old one's records past
// the checkpoint are the ones a continuation drops anyway). Also how a finished output's compressed series become
// plain again when a restart continues it.
// A failure (a full disk) names the user's file, not the temporary, and says that the file is as it was.
void rebuild_output(const std::filesystem::path& h5, const std::vector<Keep>& keep, std::int64_t version) {
  try {
    replace_file_atomically(h5, [&](const std::filesystem::path& tmp) { copy_output(h5, tmp, 0, keep, version); });
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw H5Error(h5.string() + ": cannot rewrite it " +
                  (keep.empty() ? "with plain series to continue it" : "from the records the checkpoint covers") +
                  " (left unchanged): " + e.what());
  }
}

// Whether an output's series are compressed: a finished output (compress_finished_output).
bool series_compressed(const H5File& f) { return f.exists(kTime) && !f.filters(kTime).empty(); }

// The record shape of an extendable dataset from its layout shape ("[T, Np, 3]" -> {np, 3}).
std::vector<std::size_t> record_dims(const DatasetInfo& d, const std::map<std::string, std::size_t>& sym) {
  std::string shape = d.shape;
  shape = shape.substr(1, shape.size() - 2);
  std::vector<std::size_t> out;
  std::stringstream ss(shape);
  std::string part;
  bool first = true;
  while (std::getline(ss, part, ',')) {
    if (std::exchange(first, false)) continue;  // the growing dimension
    std::stringstream ps(part);
    std::string tok;
    std::size_t v = 1;
    while (ps >> tok) v *= std::isdigit(static_cast<unsigned char>(tok[0])) ? std::stoul(tok) : sym.at(tok);
    out.push_back(v);
  }
  return out;
}

}  // namespace

RunOutput::RunOutput(const RunPaths& paths, const Simulation& sim, const std::string& run_id, bool create,
                     bool force, const OutputSchedule& sched)
    : paths_(paths) {
  const CapsuleState& s = sim.state();
  const std::size_t nn = static_cast<std::size_t>(s.num_nodes());
  XdmfSeries xs;
  xs.h5_file_name = paths.h5.filename().string();
  xs.triangles = {kMeshTrianglesAll,
                  {static_cast<std::size_t>(s.num_capsules()) * s.triangles_per_capsule(), 3},
                  XdmfNumber::Int32};
  xs.positions_path = kFramePositions;
  xs.n_nodes = nn;
  xs.attributes.push_back({"species", XdmfCenter::Node, {kMeshNodeSpecies, {nn}, XdmfNumber::Int32}, false});
  xs.attributes.push_back({"capsule", XdmfCenter::Node, {kMeshNodeCapsule, {nn}, XdmfNumber::Int32}, false});
  xs.attributes.push_back({"velocity", XdmfCenter::Node, {kFrameVelocity, {nn, 3}, XdmfNumber::Float64}, true});
  xs.walls = XdmfBox{sim.config().domain.Lx, sim.config().domain.H, sim.config().domain.Lz};
  auto views = [](const std::string& p, std::size_t f) { return frame_view_path(p, f); };
  // The membrane fields exist from format 5 on; a continued older output is indexed without them.
  auto add_membrane_fields = [&xs, nn] {
    xs.attributes.push_back({"traction_jump", XdmfCenter::Node, {kFrameTractionJump, {nn, 3}, XdmfNumber::Float32}, true});
    xs.attributes.push_back({"tension_max", XdmfCenter::Node, {kFrameTensionMax, {nn}, XdmfNumber::Float32}, true});
    xs.attributes.push_back({"tension_min", XdmfCenter::Node, {kFrameTensionMin, {nn}, XdmfNumber::Float32}, true});
    xs.attributes.push_back({"energy_density", XdmfCenter::Node, {kFrameEnergyDensity, {nn}, XdmfNumber::Float32}, true});
  };
  if (create) {
    h5_.emplace(H5File::create(paths.h5, force));
    try {
      write_static(sim, run_id);
    } catch (...) {
      // A start that fails (disk full) leaves no half-made output to block the rerun.
      h5_.reset();
      std::error_code ec;
      std::filesystem::remove(paths.h5, ec);
      throw;
    }
    xs.frame_view = views;
    add_membrane_fields();
    xdmf_ = std::make_unique<XdmfWriter>(paths.xdmf, xs);
    return;
  }
  // Read-only until it must change: even opening a file for writing can rewrite bytes of its superblock, and a
  // restart with nothing to do changes no file.
  h5_.emplace(H5File::open(paths.h5, H5Access::ReadOnly));
  const std::string id =
      h5_->has_attribute("/", kAttrRunId) ? h5_->attribute<std::string>("/", kAttrRunId) : std::string("<none>");
  if (id != run_id)
    throw InputError(paths.h5.string() + ": belongs to another run (run_id " + id + ") than the checkpoint (run_id " +
                     run_id + "); pass the right file with --output");
  version_ = h5_->has_attribute("/", kAttrFormat) ? h5_->attribute<std::int64_t>("/", kAttrFormat) : 1;
  // Drop what was written after the checkpoint: the continued run writes it again, identically (the views of
  // dropped frames go too: their source records are gone).
  const std::vector<Keep> keep = {
      {Growth::PerRecord, sched.records}, {Growth::PerFrame, sched.frames}, {Growth::PerEvent, sched.events}};
  for (const auto& [growth, n] : keep)
    for (const DatasetInfo* d : extendable(growth, version_))
      if (h5_->exists(d->path) && h5_->extent(d->path) < static_cast<std::size_t>(n))
        throw InputError(paths.h5.string() + ": " + d->path + " holds fewer records than the checkpoint " +
                         "expects (the output is older than the checkpoint)");
  bool beyond = false;  // records written after the checkpoint, to be dropped
  for (const auto& [growth, n] : keep)
    for (const DatasetInfo* d : extendable(growth, version_))
      beyond = beyond || (h5_->exists(d->path) && h5_->extent(d->path) > static_cast<std::size_t>(n));
  if (series_compressed(*h5_)) {
    // A finished output: its series go back to plain chunks before they grow again (a compressed chunk is rewritten
    // at a new place on every append). Deferred to the first append, so that a restart with nothing to do changes no
    // file, unless records must be dropped now.
    if (beyond) {
      h5_.reset();
      rebuild_output(paths.h5, keep, version_);
      h5_.emplace(H5File::open(paths.h5, H5Access::ReadWrite));
    } else {
      sealed_ = true;
    }
  } else {
    // Longer than HDF5's allocated end: the last flush did not finish (a write failed on a full disk, or the process
    // was killed during it). Changed in place, the file would get its next blocks over the bytes past that end, which
    // its index may still point to (the records written after the checkpoint vanished, silently, in a test that
    // failed every write in turn: issue 55). Rebuilt instead, like a file that cannot be truncated.
    std::error_code size_ec;
    const std::uintmax_t size = std::filesystem::file_size(paths.h5, size_ec);
    const bool torn = !size_ec && size != h5_->allocated_end();
    h5_.reset();
    if (!torn) h5_.emplace(H5File::open(paths.h5, H5Access::ReadWrite));  // (a file that cannot be opened: refused)
    try {
      if (torn) throw H5Error(paths.h5.string() + " is longer than its allocated end: its last flush did not finish");
      truncate_to(*h5_, keep, version_);
      h5_->flush();
    } catch (const H5Error& damaged) {
      h5_.reset();
      try {
        rebuild_output(paths.h5, keep, version_);
      } catch (const std::exception& e) {
        throw InputError(paths.h5.string() + ": cannot continue this output: it cannot be changed in place (" +
                         damaged.what() + ") and rebuilding it from the records the checkpoint covers failed (" +
                         e.what() + ")");
      }
      repaired_ = true;
      h5_.emplace(H5File::open(paths.h5, H5Access::ReadWrite));
    }
  }
  records_ = sched.records;
  if (version_ >= 3) xs.frame_view = views;
  if (version_ >= 5) add_membrane_fields();
  xdmf_ = std::make_unique<XdmfWriter>(paths.xdmf, xs);
  std::vector<double> times;
  if (h5_->exists(kFrameTime)) times = h5_->read<double>(kFrameTime).data;
  xdmf_->set_frame_times(times);
  if (!sealed_) h5_->flush();
}

template <class T>
void RunOutput::append(const DatasetInfo& d, const T* data, const std::vector<std::size_t>& inner) {
  if (d.since <= version_) h5_->append(d.path, data, inner);
}

void RunOutput::unseal() {
  if (!sealed_) return;
  h5_.reset();
  rebuild_output(paths_.h5, {}, version_);
  h5_.emplace(H5File::open(paths_.h5, H5Access::ReadWrite));
  sealed_ = false;
}

void RunOutput::record(const Simulation& sim, const FlowDiagnostics& fd) {
  unseal();
  const CapsuleGeometry g = sim.geometry();
  const std::size_t np = static_cast<std::size_t>(sim.state().num_capsules());
  const double t = sim.time(), dt = sim.last_dt(), ratio = sim.max_step_ratio_since_record();
  const std::int64_t step = sim.step(), contacts = sim.total_contact_corrections();
  std::vector<double> D(np), incl(np);
  for (std::size_t k = 0; k < np; ++k) {
    D[k] = g.deformation[k].D;
    incl[k] = g.deformation[k].inclination;
  }
  const std::vector<double> c = sim.unwrapped_centroids(g);
  append(info(kTime), &t, {});
  append(info(kStep), &step, {});
  append(info(kDt), &dt, {});
  append(info(kMaxStepRatio), &ratio, {});
  append(info(kContactCorrections), &contacts, {});
  append(info(kCentroid), c.data(), {np, 3});
  append(info(kVelocity), sim.capsule_velocity().data(), {np, 3});
  append(info(kTaylorD), D.data(), {np});
  append(info(kInclination), incl.data(), {np});
  append(info(kVolume), g.volume.data(), {np});
  append(info(kArea), g.area.data(), {np});
  if (version_ >= 2) {
    const int bins = sim.config().output.profile_bins;
    const std::vector<double> prof = sim.species_profile(bins);
    const std::size_t ns = sim.config().species.size();
    append(info(kProfile), prof.data(), {ns, static_cast<std::size_t>(bins)});
    if (records_ == 0) h5_->set_attribute(kProfile, "bins", static_cast<std::int64_t>(bins));
    append(info(kFlowRateRatio), &fd.flow_rate_ratio, {});
    append(info(kRelativeViscosity), &fd.relative_viscosity, {});
  }
  if (version_ >= 4) {
    const auto& lim = sim.step_limits_since_record();
    append(info(kStepLimits), lim.data(), {lim.size()});
    const ClosingLimits cl = sim.closing_limits();
    append(info(kClosestGap), &cl.pair_gap, {});
    append(info(kWallGap), &cl.wall_gap, {});
    const double ab2 = sim.ab2_error_proxy();
    append(info(kAb2Error), &ab2, {});
  }
  if (version_ >= 6) {
    const Simulation::GmresRecordStats& gs = sim.gmres_since_record();
    const double mean_it = gs.steps > 0 ? static_cast<double>(gs.iterations) / static_cast<double>(gs.steps) : 0.0;
    append(info(kGmresIterations), &mean_it, {});
    append(info(kGmresResidual), &gs.max_residual, {});
  }
  ++records_;
  h5_->flush();
}

void RunOutput::frame(const Simulation& sim) {
  unseal();
  const CapsuleState& s = sim.state();
  const std::size_t nn = static_cast<std::size_t>(s.num_nodes());
  std::vector<double> p(3 * nn), u(3 * nn);
  for (std::size_t i = 0; i < nn; ++i) {
    p[3 * i] = s.x[i];
    p[3 * i + 1] = s.y[i];
    p[3 * i + 2] = s.z[i];
    u[3 * i] = sim.ux()[i];
    u[3 * i + 1] = sim.uy()[i];
    u[3 * i + 2] = sim.uz()[i];
  }
  const double t = sim.time();
  append(info(kFrameTime), &t, {});
  append(info(kFramePositions), p.data(), {nn, 3});
  append(info(kFrameVelocity), u.data(), {nn, 3});
  if (version_ >= 5) {
    // Single precision: 7 digits are plenty to colour by, at half the bytes of doubles (docs/output_format.md).
    const MembraneNodeFields m = membrane_node_fields(s);
    const auto single = [](const std::vector<double>& v) { return std::vector<float>(v.begin(), v.end()); };
    append(info(kFrameTractionJump), single(m.traction_jump).data(), {nn, 3});
    append(info(kFrameTensionMax), single(m.tension_max).data(), {nn});
    append(info(kFrameTensionMin), single(m.tension_min).data(), {nn});
    append(info(kFrameEnergyDensity), single(m.energy_density).data(), {nn});
  }
  const std::size_t f = h5_->extent(kFramePositions) - 1;
  for (const char* src : frame_view_sources(version_)) make_frame_view(*h5_, src, f);
  h5_->flush();  // before the index that lists the frame
  xdmf_->add_frame(t);
}

std::size_t RunOutput::events(const std::vector<ContactEventRecord>& ev) {
  if (ev.empty() || version_ < 2) return 0;
  unseal();
  const std::size_t n = ev.size();
  std::vector<double> t(n), gap(n), dy(2 * n);
  std::vector<std::int32_t> pq(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = ev[i].time;
    gap[i] = ev[i].gap_before;
    pq[2 * i] = ev[i].p;
    pq[2 * i + 1] = ev[i].q;
    dy[2 * i] = ev[i].dy_p;
    dy[2 * i + 1] = ev[i].dy_q;
  }
  h5_->append(kEventTime, t.data(), {}, n);
  h5_->append(kEventCapsules, pq.data(), {2}, n);
  h5_->append(kEventGap, gap.data(), {}, n);
  h5_->append(kEventDy, dy.data(), {2}, n);
  return n;
}

void RunOutput::close() { h5_->close(); }

bool compress_finished_output(const std::filesystem::path& h5, int level) {
  std::int64_t version = 1;
  {
    const H5File f = H5File::open(h5, H5Access::ReadOnly);
    if (level == 0 || series_compressed(f)) return false;
    if (f.has_attribute("/", kAttrFormat)) version = f.attribute<std::int64_t>("/", kAttrFormat);
  }
  replace_file_atomically(h5, [&](const std::filesystem::path& tmp) { copy_output(h5, tmp, level, {}, version); });
  return true;
}

void RunOutput::set_start(const std::string& file, std::size_t frame, double strain) {
  h5_->set_attribute("/", kAttrStartedFrom, std::filesystem::absolute(file).string());
  h5_->set_attribute("/", kAttrStartedFromFrame, static_cast<std::int64_t>(frame));
  h5_->set_attribute("/", kAttrStartedFromStrain, strain);
}

void RunOutput::write_static(const Simulation& sim, const std::string& run_id) {
  const Config& cfg = sim.config();
  const CapsuleState& s = sim.state();
  const GgemGrid& grid = sim.grid();
  h5_->set_attribute("/", kAttrVersion, CAPSFLOW_VERSION_STRING);
  h5_->set_attribute("/", kAttrCommit, build_commit());  // the build that started it (its checkpoint: the latest)
  h5_->set_attribute("/", kAttrFormat, version_);
  h5_->set_attribute("/", kAttrRunId, run_id);
  h5_->set_attribute("/", kAttrFlowRateRevision, kFlowRateRevision);
  h5_->set_attribute("/", kAttrUnits,
                     "lengths in a (the unit of [domain], normally the capsule radius); time in strain units "
                     "1/gammadot; velocities in gammadot a; stresses in mu gammadot; each dataset's attribute "
                     "`units` names its own");
  h5_->write_string(kConfig, to_toml(cfg));
  h5_->set_attribute(kParameters, "source", cfg.source);
  h5_->set_attribute(kParameters, "grid_nx", static_cast<std::int64_t>(grid.nx));
  h5_->set_attribute(kParameters, "grid_nz", static_cast<std::int64_t>(grid.nz));
  h5_->set_attribute(kParameters, "grid_ny", static_cast<std::int64_t>(grid.ny));
  h5_->set_attribute(kParameters, "cutoff", grid.cutoff);
  h5_->set_attribute(kParameters, "threads",
                     static_cast<std::int64_t>(cfg.run.backend == Backend::Serial ? 1 : host_thread_count()));

  const int np = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
  const std::vector<int>& tri = s.mesh().tri;
  std::vector<std::int32_t> t_local(tri.begin(), tri.end()), t_all(3 * static_cast<std::size_t>(np) * nt);
  for (int k = 0; k < np; ++k)
    for (int e = 0; e < 3 * nt; ++e) t_all[3 * static_cast<std::size_t>(k) * nt + e] = tri[e] + k * nv;
  h5_->write(kMeshTriangles, {static_cast<std::size_t>(nt), 3}, t_local);
  h5_->set_attribute(kMeshTriangles, "mesh_level", static_cast<std::int64_t>(cfg.capsules.mesh_level));
  h5_->write(kMeshTrianglesAll, {static_cast<std::size_t>(np) * nt, 3}, t_all);
  std::vector<std::int32_t> node_species(static_cast<std::size_t>(np) * nv), node_capsule(node_species.size());
  std::vector<std::int32_t> species(np), pinned(np);
  std::vector<double> ca(np);
  for (int k = 0; k < np; ++k) {
    species[k] = s.species_of(k);
    ca[k] = cfg.species[static_cast<std::size_t>(s.species_of(k))].ca;
    pinned[k] = sim.pinned()[k];
    for (int i = 0; i < nv; ++i) {
      node_species[static_cast<std::size_t>(k) * nv + i] = species[k];
      node_capsule[static_cast<std::size_t>(k) * nv + i] = k;
    }
  }
  h5_->write(kMeshNodeSpecies, {node_species.size()}, node_species);
  h5_->write(kMeshNodeCapsule, {node_capsule.size()}, node_capsule);
  h5_->write(kCapsuleSpecies, {static_cast<std::size_t>(np)}, species);
  h5_->write(kCapsuleCa, {static_cast<std::size_t>(np)}, ca);
  h5_->write(kCapsulePinned, {static_cast<std::size_t>(np)}, pinned);
  std::string names;
  for (const SpeciesSpec& sp : cfg.species) names += (names.empty() ? "" : ",") + sp.name;
  h5_->set_attribute(kCapsuleSpecies, "names", names);
  h5_->set_attribute(kCapsules, "radius", cfg.capsules.radius);
  // Every growing dataset exists from the start (events may never happen; the series and frames get their first
  // record at strain 0), so a reader sees the whole layout, and every dataset carries its units.
  const std::map<std::string, std::size_t> sym = {
      {"Np", static_cast<std::size_t>(np)},
      {"Nn", static_cast<std::size_t>(np) * nv},
      {"Ns", cfg.species.size()},
      {"B", static_cast<std::size_t>(cfg.output.profile_bins)}};
  for (const DatasetInfo& d : output_datasets()) {
    if (d.since > version_) continue;
    if (d.growth != Growth::Fixed) {
      const std::vector<std::size_t> inner = record_dims(d, sym);
      // Only the frames' node arrays are compressed ([output] compression): they are most of the file, and each
      // frame is a chunk written once (H5File::set_compression says why a compressed chunk must not be rewritten).
      // The series and events stay unfiltered: their chunks take many records and are rewritten in place.
      h5_->set_compression(d.growth == Growth::PerFrame && !inner.empty() ? cfg.output.compression : 0);
      const std::string type = d.type;
      if (type == "double") h5_->create_extendable<double>(d.path, inner);
      else if (type == "float32") h5_->create_extendable<float>(d.path, inner);
      else if (type == "int32") h5_->create_extendable<std::int32_t>(d.path, inner);
      else h5_->create_extendable<std::int64_t>(d.path, inner);
    }
    h5_->set_attribute(d.path, kAttrDatasetUnits, d.units);
  }
  h5_->set_compression(0);
  h5_->flush();
}

}  // namespace capsflow
