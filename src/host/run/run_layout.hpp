#pragma once
// The layout of a run's files, in one place: every dataset of OUT.h5 and OUT.checkpoint.h5 with its path, growth,
// type, shape and meaning. The writer (run_output.cpp, checkpoint.cpp), the reader (read_run_file), the tests and
// docs/output_format.md (checked against kOutputDatasets by tests/test_run_layout.cpp) all take it from here, so a
// dataset cannot be added in one place and forgotten in another.
//
// Format versions (root attribute `format_version` of both files; absent = 1):
//   1  issue 4's layout (no format_version attribute).
//   2  format_version; /series/profile (per-species interior volume per wall-normal slab), /series/max_step_ratio,
//      /series/flow_rate_ratio, /series/relative_viscosity, /events (contact corrections); checkpoint /run
//      attribute `events`.
//   3  /xdmf/<name>/<f>: for each per-frame dataset /frames/<name> (positions, velocity) and frame f, an HDF5 virtual
//      dataset [Nn, 3] that shows frame f (no copy). The XDMF index refers to these plain datasets: ParaView's
//      Xdmf3ReaderS/T do not read the HyperSlab references of versions 1 and 2 (5.11 shows 0 points).
//   4  the step rule's diagnostics per record: /series/step_limits, /series/closest_gap, /series/wall_gap,
//      /series/ab2_error (docs/method.md section 4.1).
//   5  an attribute `units` on every dataset (DatasetInfo::units; the frame views copy their source's); per-node
//      membrane fields in the frames (traction_jump, tension_max, tension_min, energy_density) with their views;
//      extendable datasets shuffled and deflated unless [output] compression = 0 (transparent to readers).
//   6  the interface-velocity solve per record (viscosity ratio != 1): /series/gmres_iterations,
//      /series/gmres_residual (0 in runs without the solve).
// A reader accepts every version up to kFormatVersion; a writer continuing an older output (restart) keeps its
// version and writes only what that version holds.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "host/base/errors.hpp"

namespace capsflow {

namespace layout {

inline constexpr std::int64_t kFormatVersion = 6;

// Root attributes.
inline constexpr const char* kAttrVersion = "capsflow_version";
// The build commit (build_info.hpp) that wrote the file: of an output, the build that started the run; of a
// checkpoint, the build that wrote it (since 2026-12-08; each continuation's build is in the run's log).
inline constexpr const char* kAttrCommit = "capsflow_commit";
inline constexpr const char* kAttrFormat = "format_version";
inline constexpr const char* kAttrRunId = "run_id";
inline constexpr const char* kAttrUnits = "units";
inline constexpr const char* kAttrOutputFile = "output_file";  // checkpoint only: absolute path of OUT.h5
// The definition of /series/flow_rate_ratio the file's records follow (root attribute; absent = 1): 1 counted the
// fluid inside a capsule of viscosity ratio lambda != 1 with weight lambda (its flow rate was wrong by
// (lambda - 1) U_x V / (A Q_0)); 2 (issue 37) counts it once. Written when the file is created, so a file begun
// before issue 37 and continued after it keeps 1: some of its records are wrong. Equal at lambda = 1.
inline constexpr const char* kAttrFlowRateRevision = "flow_rate_revision";
inline constexpr std::int64_t kFlowRateRevision = 2;

inline constexpr const char* kConfig = "/parameters/config";
inline constexpr const char* kParameters = "/parameters";

inline constexpr const char* kMeshTriangles = "/mesh/triangles";
inline constexpr const char* kMeshTrianglesAll = "/mesh/triangles_all";
inline constexpr const char* kMeshNodeSpecies = "/mesh/node_species";
inline constexpr const char* kMeshNodeCapsule = "/mesh/node_capsule";
inline constexpr const char* kCapsules = "/capsules";
inline constexpr const char* kCapsuleSpecies = "/capsules/species";
inline constexpr const char* kCapsuleCa = "/capsules/ca";
inline constexpr const char* kCapsulePinned = "/capsules/pinned";

inline constexpr const char* kTime = "/series/time";
inline constexpr const char* kStep = "/series/step";
inline constexpr const char* kDt = "/series/dt";
inline constexpr const char* kMaxStepRatio = "/series/max_step_ratio";
inline constexpr const char* kContactCorrections = "/series/contact_corrections";
inline constexpr const char* kCentroid = "/series/centroid";
inline constexpr const char* kVelocity = "/series/velocity";
inline constexpr const char* kTaylorD = "/series/taylor_D";
inline constexpr const char* kInclination = "/series/inclination";
inline constexpr const char* kVolume = "/series/volume";
inline constexpr const char* kArea = "/series/area";
inline constexpr const char* kProfile = "/series/profile";
inline constexpr const char* kFlowRateRatio = "/series/flow_rate_ratio";
inline constexpr const char* kRelativeViscosity = "/series/relative_viscosity";
inline constexpr const char* kStepLimits = "/series/step_limits";
inline constexpr const char* kClosestGap = "/series/closest_gap";
inline constexpr const char* kWallGap = "/series/wall_gap";
inline constexpr const char* kAb2Error = "/series/ab2_error";
inline constexpr const char* kGmresIterations = "/series/gmres_iterations";
inline constexpr const char* kGmresResidual = "/series/gmres_residual";

inline constexpr const char* kFrameTime = "/frames/time";
inline constexpr const char* kFramePositions = "/frames/positions";
inline constexpr const char* kFrameVelocity = "/frames/velocity";
inline constexpr const char* kFrameTractionJump = "/frames/traction_jump";
inline constexpr const char* kFrameTensionMax = "/frames/tension_max";
inline constexpr const char* kFrameTensionMin = "/frames/tension_min";
inline constexpr const char* kFrameEnergyDensity = "/frames/energy_density";

// Format 3: per-frame views of /frames/positions and /frames/velocity for the XDMF index (frame_view_path).
inline constexpr const char* kFrameViews = "/xdmf";
// "/frames/positions", 7 -> "/xdmf/positions/7".
std::string frame_view_path(const std::string& frames_dataset, std::size_t frame);
// The per-frame datasets that get views in format `version` (every per-frame dataset but /frames/time; none
// before format 3).
std::vector<const char*> frame_view_sources(std::int64_t version);
// The attribute that names a dataset's units (format 5).
inline constexpr const char* kAttrDatasetUnits = "units";

inline constexpr const char* kEventTime = "/events/time";
inline constexpr const char* kEventCapsules = "/events/capsules";
inline constexpr const char* kEventGap = "/events/gap_before";
inline constexpr const char* kEventDy = "/events/dy";

// Checkpoint: /run attributes (the output schedule) and /state datasets and attributes (Simulation's snapshot).
inline constexpr const char* kRun = "/run";
inline constexpr const char* kState = "/state";

enum class Growth { Fixed, PerRecord, PerFrame, PerEvent };

struct DatasetInfo {
  const char* path;
  Growth growth;
  const char* type;     // "double", "float32", "int32", "int64", "string"
  const char* shape;    // as docs/output_format.md writes it: "[T, Np, 3]", "scalar"
  std::int64_t since;   // first format version that has it
  const char* units;    // attribute `units` (format 5): in the scales of docs/usage.md, "1" for numbers, counts, ids
  const char* meaning;
};

// Every dataset of OUT.h5, in the order docs/output_format.md lists them.
const std::vector<DatasetInfo>& output_datasets();
// The extendable ones that grow with `growth` and exist in format `version` (restart truncation, padding).
std::vector<const DatasetInfo*> extendable(Growth growth, std::int64_t version);

}  // namespace layout

// The paths of the files of one run, from the output file name OUT.h5. `lock` is OUT.lock, the marker of a live
// run (run_marker.hpp): written before OUT.h5, refreshed while the run goes on, removed when it ends.
struct RunPaths {
  std::filesystem::path h5, xdmf, checkpoint, lock;
};
RunPaths run_paths(const std::string& output_file);

// A run's output read back (whole series): what `capsflow analyze` and the tests need.
// Arrays are row-major; absent datasets (older formats, runs without them) are empty.
struct RunFile {
  std::filesystem::path path;
  std::int64_t format_version = 1;
  std::int64_t flow_rate_revision = 1;  // kAttrFlowRateRevision (1 when absent)
  std::string run_id, capsflow_version, config_text;
  std::vector<std::string> species_names;
  std::vector<std::int32_t> species, pinned;  // [Np]
  std::vector<double> ca;                     // [Np]
  std::size_t np = 0, records = 0, frames = 0, events = 0, profile_bins = 0, nspecies = 0;
  std::vector<double> time, dt, max_step_ratio;           // [T]
  std::vector<std::int64_t> step, contact_corrections;    // [T]
  std::vector<double> centroid, velocity;                 // [T, Np, 3]
  std::vector<double> taylor_D, inclination, volume, area;  // [T, Np]
  std::vector<double> profile;                            // [T, nspecies, profile_bins]
  std::vector<double> flow_rate_ratio, relative_viscosity;  // [T]
  std::vector<std::int64_t> step_limits;                  // [T, 5] (format 4)
  std::vector<double> closest_gap, wall_gap, ab2_error;   // [T] (format 4)
  std::vector<double> gmres_iterations, gmres_residual;   // [T] (format 6)
  std::vector<double> frame_time;                         // [F] (positions are read per frame, not here)
  std::vector<double> event_time, event_gap, event_dy;    // [E], [E], [E, 2]
  std::vector<std::int32_t> event_capsules;               // [E, 2]: (p, q); q = -1 bottom wall, -2 top wall
};
// A file of a run store (tools/run_store.py keeps a long run as a base and append-only parts) where a run's output
// was expected: a part holds a stretch of records (its /_store group says from which record on), the base with parts
// beside it the records to the first save only. Read as a run, either is a short run that looks whole; `capsflow
// analyze` refuses it even when found in a directory (a run left out of the pool would change the statistics).
struct RunStoreFileError : InputError {
  using InputError::InputError;
};

class H5File;
// Throws RunStoreFileError when `f` (opened from `path`) is a run store's part (its /_store group, written by every
// save, the older ones included) or the base of one with parts beside it, naming the restore that makes the run.
// read_run_file and `capsflow render` call it.
void refuse_run_store_file(const H5File& f, const std::filesystem::path& path);

// Reads a run's output without locking it (a live run's file can be read between its flushes). InputError when
// the file is not a capsflow run output or is newer than this build understands; RunStoreFileError for a run
// store's part, or its base with parts beside it (the message names the restore that makes the run).
RunFile read_run_file(const std::filesystem::path& path);

}  // namespace capsflow
