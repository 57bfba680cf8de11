// The implementation of checkpoint.hpp: writing and reading OUT.checkpoint.h5, atomically.
#include "host/run/checkpoint.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

#include "capsflow_version.hpp"
#include "host/base/build_info.hpp"
#include "host/base/digest.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
#include "host/base/printable.hpp"
#include "host/physics/config_toml.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/run/run_layout.hpp"

namespace capsflow {

namespace {
// /state datasets and attributes (Simulation's snapshot).
constexpr const char* kInitialCentres = "/state/initial_centres";
constexpr const char* kSpecies = "/state/species";
constexpr const char* kPinned = "/state/pinned";
constexpr const char* kPinCentres = "/state/pin_centres";
constexpr const char* kImage = "/state/image";
constexpr const char* kPositions = "/state/positions";
constexpr const char* kUPrevious = "/state/u_previous";
constexpr const char* kUPrevious2 = "/state/u_previous2";  // since the step-rule change; absent before
constexpr const char* kInitialOrientations = "/state/initial_orientations";  // only with turned capsules
constexpr const char* kStepLimitsSince = "/state/step_limits_since_record";  // likewise
constexpr const char* kInterfaceVelocity = "/state/interface_velocity";  // only with a viscosity ratio != 1
constexpr const char* kInterfaceVelocityPrevious = "/state/interface_velocity_previous";  // likewise, after a solve
constexpr const char* kInterfaceVelocityPrevious2 = "/state/interface_velocity_previous2";  // after two solves
constexpr const char* kAttrDigest = "digest";  // on /state and on /parameters/config (since 2026-12-08)
}  // namespace

std::string checkpoint_state_digest(const Checkpoint& ck) {
  const SimulationSnapshot& st = ck.state;
  const std::size_t n = st.positions.size() / 3;
  Digest64 d;
  // Each value under its name, so that two same-shape datasets swapped are another digest. What write_checkpoint
  // writes only under a condition enters under the same condition, which read_checkpoint's result meets exactly when
  // the writer's state did (it reads a dataset or attribute whenever it is there).
  auto put = [&d](std::string_view name, const auto& value) {
    d.add(name);
    d.add(value);
  };
  put("format_version", ck.format_version);
  put("run_id", std::string_view(ck.run_id));
  put("next_record", ck.schedule.next_record);
  put("next_frame", ck.schedule.next_frame);
  put("next_checkpoint", ck.schedule.next_checkpoint);
  put("records", ck.schedule.records);
  put("frames", ck.schedule.frames);
  if (ck.format_version >= 2) put("events", ck.schedule.events);
  put("initial_centres", st.initial_centres);
  if (!st.initial_orientations.empty()) put("initial_orientations", st.initial_orientations);
  put("species", st.species);
  put("pinned", st.pinned);
  put("pin_centres", st.pin_centres);
  put("image", st.image);
  put("positions", st.positions);
  put("u_previous", st.u_previous);
  if (st.u_previous2.size() == 3 * n) {
    put("u_previous2", st.u_previous2);
    put("have_history2", std::int64_t{st.have_history2 ? 1 : 0});
  }
  put("time", st.time);
  put("step", st.step);
  put("dt_previous", st.dt_previous);
  put("have_history", std::int64_t{st.have_history ? 1 : 0});
  put("contact_corrections", st.contact_corrections);
  put("steps_with_contacts", st.steps_with_contacts);
  put("unconverged_contacts", st.unconverged_contacts);
  put("max_step_ratio_since_record", st.max_step_ratio_since_record);
  put("contact_events", st.contact_events);
  if (st.interface_velocity.size() == 3 * n) put("interface_velocity", st.interface_velocity);
  if (st.interface_velocity_previous.size() == 3 * n) {
    put("interface_velocity_previous", st.interface_velocity_previous);
    put("interface_velocity_previous_time", st.interface_velocity_previous_time);
  }
  if (st.interface_velocity_previous2.size() == 3 * n) {
    put("interface_velocity_previous2", st.interface_velocity_previous2);
    put("interface_velocity_previous2_time", st.interface_velocity_previous2_time);
  }
  if (st.gmres_steps_since_record > 0) {
    put("gmres_steps_since_record", st.gmres_steps_since_record);
    put("gmres_iterations_since_record", st.gmres_iterations_since_record);
    put("gmres_max_iterations_since_record", st.gmres_max_iterations_since_record);
    put("gmres_max_residual_since_record", st.gmres_max_residual_since_record);
  }
  if (!st.step_limits_since_record.empty()) put("step_limits_since_record", st.step_limits_since_record);
  return d.hex();
}

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& ck) {
  using namespace layout;
  write_checkpoint_atomically(path, [&](H5File& f) {
    const SimulationSnapshot& st = ck.state;
    const std::size_t np = st.species.size(), n = st.positions.size() / 3;
    f.set_attribute("/", kAttrVersion, CAPSFLOW_VERSION_STRING);
    f.set_attribute("/", kAttrCommit, build_commit());
    f.set_attribute("/", kAttrFormat, ck.format_version);
    f.set_attribute("/", kAttrRunId, ck.run_id);
    f.set_attribute("/", kAttrOutputFile, ck.output_file);
    f.write_string(kConfig, ck.config_text);
    f.set_attribute(kConfig, kAttrDigest, text_digest(ck.config_text));
    f.create_group(kRun);
    f.set_attribute(kRun, "next_record", ck.schedule.next_record);
    f.set_attribute(kRun, "next_frame", ck.schedule.next_frame);
    f.set_attribute(kRun, "next_checkpoint", ck.schedule.next_checkpoint);
    f.set_attribute(kRun, "records", ck.schedule.records);
    f.set_attribute(kRun, "frames", ck.schedule.frames);
    if (ck.format_version >= 2) f.set_attribute(kRun, "events", ck.schedule.events);
    f.write(kInitialCentres, {np, 3}, st.initial_centres);
    if (!st.initial_orientations.empty()) f.write(kInitialOrientations, {np, 9}, st.initial_orientations);
    f.write(kSpecies, {np}, st.species);
    f.write(kPinned, {np}, st.pinned);
    f.write(kPinCentres, {np, 3}, st.pin_centres);
    f.write(kImage, {np, 2}, st.image);
    f.write(kPositions, {n, 3}, st.positions);
    f.write(kUPrevious, {n, 3}, st.u_previous);
    if (st.u_previous2.size() == 3 * n) f.write(kUPrevious2, {n, 3}, st.u_previous2);
    f.set_attribute(kState, "time", st.time);
    f.set_attribute(kState, "step", st.step);
    f.set_attribute(kState, "dt_previous", st.dt_previous);
    f.set_attribute(kState, "have_history", st.have_history ? 1 : 0);
    f.set_attribute(kState, "have_history2", st.have_history2 ? 1 : 0);
    f.set_attribute(kState, "contact_corrections", st.contact_corrections);
    f.set_attribute(kState, "steps_with_contacts", st.steps_with_contacts);
    f.set_attribute(kState, "unconverged_contacts", st.unconverged_contacts);
    f.set_attribute(kState, "max_step_ratio_since_record", st.max_step_ratio_since_record);
    f.set_attribute(kState, "contact_events", st.contact_events);
    // Written only by runs that solve for the interface velocity (files of lambda = 1 runs stay as they were).
    if (st.interface_velocity.size() == 3 * n) f.write(kInterfaceVelocity, {3, n}, st.interface_velocity);
    if (st.interface_velocity_previous.size() == 3 * n) {
      f.write(kInterfaceVelocityPrevious, {3, n}, st.interface_velocity_previous);
      f.set_attribute(kState, "interface_velocity_previous_time", st.interface_velocity_previous_time);
    }
    if (st.interface_velocity_previous2.size() == 3 * n) {
      f.write(kInterfaceVelocityPrevious2, {3, n}, st.interface_velocity_previous2);
      f.set_attribute(kState, "interface_velocity_previous2_time", st.interface_velocity_previous2_time);
    }
    if (st.gmres_steps_since_record > 0) {
      f.set_attribute(kState, "gmres_steps_since_record", st.gmres_steps_since_record);
      f.set_attribute(kState, "gmres_iterations_since_record", st.gmres_iterations_since_record);
      f.set_attribute(kState, "gmres_max_iterations_since_record", st.gmres_max_iterations_since_record);
      f.set_attribute(kState, "gmres_max_residual_since_record", st.gmres_max_residual_since_record);
    }
    if (!st.step_limits_since_record.empty())
      f.write(kStepLimitsSince, {st.step_limits_since_record.size()}, st.step_limits_since_record);
    f.set_attribute(kState, kAttrDigest, checkpoint_state_digest(ck));
  });
}

Checkpoint read_checkpoint(const std::filesystem::path& path) {
  using namespace layout;
  const H5File f = H5File::open(path);
  const std::string where = path.string() + ": ";
  for (const char* p : {kConfig, kPositions, kUPrevious, kInitialCentres, kSpecies, kPinned, kPinCentres, kImage})
    if (!f.exists(p)) throw InputError(where + "not a capsflow checkpoint (missing " + std::string(p) + ")");
  for (const char* a : {"next_record", "next_frame", "next_checkpoint", "records", "frames"})
    if (!f.has_attribute(kRun, a))
      throw InputError(where + "not a capsflow checkpoint (missing attribute /run " + std::string(a) + ")");
  Checkpoint ck;
  if (f.has_attribute("/", kAttrFormat)) ck.format_version = f.attribute<std::int64_t>("/", kAttrFormat);
  if (ck.format_version < 1)
    throw InputError(where + "/ attribute format_version: expected a format >= 1, got " +
                     std::to_string(ck.format_version) + " (a damaged or hand-made checkpoint)");
  for (const char* a : {"time", "step", "dt_previous", "have_history", "contact_corrections", "steps_with_contacts",
                        "unconverged_contacts"})
    if (!f.has_attribute(kState, a))
      throw InputError(where + "not a capsflow checkpoint (missing attribute /state " + std::string(a) + ")");
  if (ck.format_version > kFormatVersion)
    throw InputError(where + "written in format " + std::to_string(ck.format_version) + " by a newer capsflow (" +
                     "this one reads up to " + std::to_string(kFormatVersion) + ")");
  ck.run_id = f.attribute<std::string>("/", kAttrRunId);
  ck.output_file = f.attribute<std::string>("/", kAttrOutputFile);
  if (f.has_attribute("/", kAttrVersion)) ck.capsflow_version = f.attribute<std::string>("/", kAttrVersion);
  ck.config_text = f.read_string(kConfig);
  // A digest attribute that is there but is not one (emptied, another type) is damage, not an older checkpoint.
  auto digest_attribute = [&](const char* object) -> std::string {
    if (!f.has_attribute(object, kAttrDigest)) return {};
    std::string d;
    try {
      d = f.attribute<std::string>(object, kAttrDigest);
    } catch (const std::exception&) {
    }
    if (d.size() != 20 || d.rfind("h64:", 0) != 0)
      throw InputError(where + object + " attribute digest: expected \"h64:\" and 16 hex digits (written with the "
                       "checkpoint), got \"" + printable(d) + "\" (a damaged or hand-made checkpoint)");
    return d;
  };
  ck.config_digest = digest_attribute(kConfig);
  ck.state_digest = digest_attribute(kState);
  ck.schedule.next_record = f.attribute<double>(kRun, "next_record");
  ck.schedule.next_frame = f.attribute<double>(kRun, "next_frame");
  ck.schedule.next_checkpoint = f.attribute<double>(kRun, "next_checkpoint");
  ck.schedule.records = f.attribute<std::int64_t>(kRun, "records");
  ck.schedule.frames = f.attribute<std::int64_t>(kRun, "frames");
  if (f.has_attribute(kRun, "events")) ck.schedule.events = f.attribute<std::int64_t>(kRun, "events");
  SimulationSnapshot& st = ck.state;
  // A checkpoint is an input like any other: what no run can have written is refused here, naming the file and the
  // dataset, before any file of the run is touched (a NaN time never reaches the end, a transposed array does not
  // continue as other physics). The shapes are those of the writer above: Np capsules (/state/species), Nn nodes
  // (/state/positions); which datasets the stored configuration needs is check_checkpoint_state's.
  auto bad = [&](const std::string& what, const std::string& expected) {
    return InputError(where + what + ": expected " + expected + " (a damaged or hand-made checkpoint)");
  };
  auto shape_text = [](const std::vector<std::size_t>& d) {
    std::string s = "[";
    for (std::size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
    return s + "]";
  };
  auto check_shape = [&](const char* p, const std::vector<std::size_t>& got, const std::vector<std::size_t>& want,
                         const char* what) {
    if (got != want)
      throw bad(p, "shape " + shape_text(want) + " (" + what + "), got " + shape_text(got));
  };
  // The writer's element types: a float32 copy reads back converted and continues off the run's own bits.
  auto check_type = [&](const char* p, const char* want, const char* what) {
    if (const std::string t = f.element_type(p); t != want)
      throw bad(p, std::string(want) + " values (" + what + ", as capsflow writes them), got " + t);
  };
  auto doubles = [&](const char* p, const std::vector<std::size_t>& want, const char* what) {
    check_type(p, "float64", what);
    H5Array<double> a = f.read<double>(p);
    check_shape(p, a.dims, want, what);
    for (double x : a.data)
      if (!std::isfinite(x)) throw bad(p, std::string("finite values (") + what + ")");
    return std::move(a.data);
  };
  auto integers = [&](const char* p, const std::vector<std::size_t>& want, const char* what, std::int64_t lo,
                      std::int64_t hi, const char* range) {
    check_type(p, "int64", what);
    H5Array<std::int64_t> a = f.read<std::int64_t>(p);
    check_shape(p, a.dims, want, what);
    for (std::int64_t v : a.data)
      if (v < lo || v > hi) throw bad(p, std::string(range) + ", got " + std::to_string(v));
    return std::move(a.data);
  };
  const std::vector<std::size_t> species_dims = f.dims(kSpecies), position_dims = f.dims(kPositions);
  if (species_dims.size() != 1) throw bad(kSpecies, "shape [Np] (one species index per capsule), got " +
                                                        shape_text(species_dims));
  if (position_dims.size() != 2 || position_dims[1] != 3)
    throw bad(kPositions, "shape [Nn, 3] (node positions), got " + shape_text(position_dims));
  const std::size_t np = species_dims[0], n = position_dims[0];
  constexpr std::int64_t kMaxInt = std::numeric_limits<std::int64_t>::max();
  st.species = integers(kSpecies, {np}, "one species index per capsule", 0, kMaxInt, "species indices >= 0");
  st.initial_centres = doubles(kInitialCentres, {np, 3}, "each capsule's initial centre");
  if (f.exists(kInitialOrientations))
    st.initial_orientations = doubles(kInitialOrientations, {np, 9}, "each capsule's initial rotation, row-major");
  st.pinned = integers(kPinned, {np}, "0 or 1 per capsule", 0, 1, "0 or 1");
  st.pin_centres = doubles(kPinCentres, {np, 3}, "each pinned capsule's centre");
  st.image = integers(kImage, {np, 2}, "periods shifted in x and z per capsule", -kMaxInt, kMaxInt, "a count");
  st.positions = doubles(kPositions, {n, 3}, "node positions");
  st.u_previous = doubles(kUPrevious, {n, 3}, "node velocities of the previous step, as /state/positions");
  st.time = f.attribute<double>(kState, "time");
  st.step = f.attribute<std::int64_t>(kState, "step");
  st.dt_previous = f.attribute<double>(kState, "dt_previous");
  const std::int64_t have_history = f.attribute<std::int64_t>(kState, "have_history");
  if (have_history != 0 && have_history != 1) throw bad("/state attribute have_history", "0 or 1");
  st.have_history = have_history != 0;
  // u^(n-2) and the step-limit tallies: written by every capsflow since output format 4.
  if (ck.format_version >= 4 || f.exists(kUPrevious2)) {
    if (!f.exists(kUPrevious2) || !f.has_attribute(kState, "have_history2"))
      throw bad(kUPrevious2, "the dataset and the /state attribute have_history2 (written since output format 4; "
                             "this checkpoint is of format " + std::to_string(ck.format_version) + ")");
    st.u_previous2 = doubles(kUPrevious2, {n, 3}, "node velocities of the step before, as /state/positions");
    const std::int64_t h2 = f.attribute<std::int64_t>(kState, "have_history2");
    if (h2 != 0 && h2 != 1) throw bad("/state attribute have_history2", "0 or 1");
    st.have_history2 = h2 != 0;
  }
  if (ck.format_version >= 4 && !f.exists(kStepLimitsSince))
    throw bad(kStepLimitsSince, "the dataset (the step limits since the last record; written since output format 4)");
  if (f.exists(kStepLimitsSince))
    st.step_limits_since_record = integers(kStepLimitsSince, {static_cast<std::size_t>(kStepLimitCount)},
                                           "steps per step limit since the last record", 0, kMaxInt, "counts >= 0");
  st.contact_corrections = f.attribute<std::int64_t>(kState, "contact_corrections");
  st.steps_with_contacts = f.attribute<std::int64_t>(kState, "steps_with_contacts");
  st.unconverged_contacts = f.attribute<std::int64_t>(kState, "unconverged_contacts");
  if (f.has_attribute(kState, "max_step_ratio_since_record"))
    st.max_step_ratio_since_record = f.attribute<double>(kState, "max_step_ratio_since_record");
  if (f.exists(kInterfaceVelocity))
    st.interface_velocity = doubles(kInterfaceVelocity, {3, n}, "the first guess of the interface-velocity solve at "
                                                                 "these positions: all x, all y, all z over the nodes");
  // The answer before that solve (the extrapolated guesses go on from it; written since 2026-12-03, issue 34).
  if (f.exists(kInterfaceVelocityPrevious)) {
    if (!f.has_attribute(kState, "interface_velocity_previous_time"))
      throw bad(kInterfaceVelocityPrevious, "the /state attribute interface_velocity_previous_time beside it");
    st.interface_velocity_previous = doubles(kInterfaceVelocityPrevious, {3, n}, "the interface velocity before the "
                                             "last solve: all x, all y, all z over the nodes");
    st.interface_velocity_previous_time = f.attribute<double>(kState, "interface_velocity_previous_time");
    if (!(std::isfinite(st.interface_velocity_previous_time) && st.interface_velocity_previous_time >= 0.0))
      throw bad("/state attribute interface_velocity_previous_time", "a finite strain >= 0");
  }
  // The answer before that one (the guesses extrapolate quadratically from three answers; written since
  // 2026-12-04, issue 34; a checkpoint without it continues with a linear extrapolation for one solve).
  if (f.exists(kInterfaceVelocityPrevious2)) {
    if (!f.exists(kInterfaceVelocityPrevious))
      throw bad(kInterfaceVelocityPrevious2, "interface_velocity_previous beside it (the answer after this one)");
    if (!f.has_attribute(kState, "interface_velocity_previous2_time"))
      throw bad(kInterfaceVelocityPrevious2, "the /state attribute interface_velocity_previous2_time beside it");
    st.interface_velocity_previous2 = doubles(kInterfaceVelocityPrevious2, {3, n}, "the interface velocity two "
                                              "solves back: all x, all y, all z over the nodes");
    st.interface_velocity_previous2_time = f.attribute<double>(kState, "interface_velocity_previous2_time");
    if (!(std::isfinite(st.interface_velocity_previous2_time) && st.interface_velocity_previous2_time >= 0.0 &&
          st.interface_velocity_previous2_time < st.interface_velocity_previous_time))
      throw bad("/state attribute interface_velocity_previous2_time",
                "a finite strain >= 0 below interface_velocity_previous_time");
  }
  const char* const gmres_tallies[] = {"gmres_steps_since_record", "gmres_iterations_since_record",
                                       "gmres_max_iterations_since_record", "gmres_max_residual_since_record"};
  const int gmres_present = static_cast<int>(
      std::count_if(std::begin(gmres_tallies), std::end(gmres_tallies),
                    [&](const char* a) { return f.has_attribute(kState, a); }));
  if (gmres_present != 0 && gmres_present != 4)
    throw bad("/state attributes gmres_*_since_record", "all four GMRES tallies or none");
  if (gmres_present == 4) {
    st.gmres_steps_since_record = f.attribute<std::int64_t>(kState, gmres_tallies[0]);
    st.gmres_iterations_since_record = f.attribute<std::int64_t>(kState, gmres_tallies[1]);
    st.gmres_max_iterations_since_record = f.attribute<std::int64_t>(kState, gmres_tallies[2]);
    st.gmres_max_residual_since_record = f.attribute<double>(kState, gmres_tallies[3]);
  }
  if (f.has_attribute(kState, "contact_events"))
    st.contact_events = f.attribute<std::int64_t>(kState, "contact_events");
  if (!(std::isfinite(st.time) && st.time >= 0.0)) throw bad("/state attribute time", "a finite strain >= 0");
  if (st.step < 0) throw bad("/state attribute step", "an integer >= 0");
  if (!(std::isfinite(st.dt_previous) && st.dt_previous >= 0.0))
    throw bad("/state attribute dt_previous", "a finite step >= 0");
  // AB2 divides by the previous step once there is one.
  if (st.have_history && !(st.dt_previous > 0.0))
    throw bad("/state attribute dt_previous", "a step > 0 with have_history = 1");
  for (const auto& [name, v] : {std::pair<const char*, double>{"next_record", ck.schedule.next_record},
                                {"next_frame", ck.schedule.next_frame},
                                {"next_checkpoint", ck.schedule.next_checkpoint}})
    if (!std::isfinite(v)) throw bad(std::string("/run attribute ") + name, "a finite strain");
  if (ck.schedule.records < 0 || ck.schedule.frames < 0 || ck.schedule.events < 0)
    throw bad("/run attributes records, frames, events", "counts >= 0");
  for (const auto& [name, v] : {std::pair<const char*, std::int64_t>{"contact_corrections", st.contact_corrections},
                                {"steps_with_contacts", st.steps_with_contacts},
                                {"unconverged_contacts", st.unconverged_contacts},
                                {"contact_events", st.contact_events},
                                {gmres_tallies[0], st.gmres_steps_since_record},
                                {gmres_tallies[1], st.gmres_iterations_since_record},
                                {gmres_tallies[2], st.gmres_max_iterations_since_record}})
    if (v < 0) throw bad(std::string("/state attribute ") + name, "a count >= 0, got " + std::to_string(v));
  if (!(std::isfinite(st.max_step_ratio_since_record) && st.max_step_ratio_since_record >= 0.0))
    throw bad("/state attribute max_step_ratio_since_record", "a finite ratio >= 0");
  if (!(std::isfinite(st.gmres_max_residual_since_record) && st.gmres_max_residual_since_record >= 0.0))
    throw bad(std::string("/state attribute ") + gmres_tallies[3], "a finite relative residual >= 0");
  // The largest solve's applications are among the total's, and a tally without steps is empty.
  if (st.gmres_max_iterations_since_record > st.gmres_iterations_since_record ||
      (st.gmres_steps_since_record == 0 && st.gmres_iterations_since_record != 0))
    throw bad("/state attributes gmres_*_since_record",
              "gmres_max_iterations_since_record <= gmres_iterations_since_record, and no iterations without steps");
  return ck;
}

Config checkpoint_config(const Checkpoint& ck, const std::string& where,
                         const std::vector<ConfigOverride>& overrides) {
  Config c = resolve_config(ck.config_text, where + ":/parameters/config", overrides);
  // The keys the stored text holds (resolve_config has checked it): what it lacks says which build wrote it.
  const toml::table stored = toml::parse(ck.config_text);
  if (ck.format_version < 2) {
    // Format 1 (issue 4) had no velocity projection and no cap on the step ratio: a key its configuration could
    // not hold takes that behaviour, not today's default. Keys it does hold (volume_correction) are as written.
    if (!stored["capsules"]["velocity_projection"]) c.capsules.velocity_projection = false;
    if (!stored["time"]["max_step_ratio"]) c.time.max_step_ratio = kUncappedStepRatio;
  }
  // A run made before a default changed continues with the rules it ran with (the step rule, the element rules).
  keep_earlier_build_rules(stored, c);
  return c;
}

void check_checkpoint_state(const Checkpoint& ck, const Config& cfg, const std::string& file) {
  const SimulationSnapshot& st = ck.state;
  const std::size_t np = st.species.size();
  auto bad = [&](const std::string& what, const std::string& expected) {
    return InputError(file + ": " + what + ": expected " + expected + " (a damaged or hand-made checkpoint)");
  };
  for (std::size_t k = 0; k < np; ++k)
    if (st.species[k] >= static_cast<std::int64_t>(cfg.species.size()))
      throw bad(kSpecies, "species indices below " + std::to_string(cfg.species.size()) +
                              " (the stored configuration's [[species]]), got " + std::to_string(st.species[k]));
  // The rotation each capsule started with: [[capsule]] orientation (exactly, as place_capsules makes it), the
  // identity for a sphere of [suspension], a rotation drawn at random for its other shapes.
  const std::vector<double>& rot = st.initial_orientations;
  bool turned = false;
  std::vector<Rotation> listed(np, kIdentityRotation);
  if (!cfg.capsule_list.empty()) {
    if (np != cfg.capsule_list.size())
      throw bad(kSpecies, std::to_string(cfg.capsule_list.size()) + " capsules (the stored configuration's " +
                              "[[capsule]] tables), got " + std::to_string(np));
    for (std::size_t k = 0; k < np; ++k) {
      const CapsuleSpec& c = cfg.capsule_list[k];
      if (st.species[k] != cfg.species_index(c.species) || (st.pinned[k] != 0) != c.pinned)
        throw bad(std::string(kSpecies) + ", " + kPinned,
                  "capsule " + std::to_string(k) + " of species \"" + c.species + "\"" +
                      (c.pinned ? ", pinned" : ", not pinned") + " (the stored configuration's [[capsule]] " +
                      std::to_string(k + 1) + ")");
      if (c.orientation) listed[k] = rotation_to_axis(*c.orientation);
      turned = turned || listed[k] != kIdentityRotation;
    }
  } else {
    for (std::size_t k = 0; k < np; ++k)
      turned = turned || cfg.species[static_cast<std::size_t>(st.species[k])].shape.kind != ShapeKind::Sphere;
  }
  if (turned && rot.empty())
    throw bad(std::string(kInitialOrientations) + " (missing)",
              "[" + std::to_string(np) + ", 9] rotations: the stored configuration turns capsules (" +
                  (cfg.capsule_list.empty() ? "[suspension] of non-spherical [[species]] shape"
                                            : "[[capsule]] orientation") +
                  "), and without them a continuation would start from other reference shapes");
  for (std::size_t k = 0; k < np && !rot.empty(); ++k) {
    const double* r = &rot[9 * k];
    const bool sphere = cfg.species[static_cast<std::size_t>(st.species[k])].shape.kind == ShapeKind::Sphere;
    double err = 0.0;
    if (!cfg.capsule_list.empty() || sphere) {
      // Known exactly from the configuration (rounding aside: another build's rotation_to_axis).
      for (int c = 0; c < 9; ++c) err = std::max(err, std::abs(r[c] - listed[k][static_cast<std::size_t>(c)]));
    } else {
      // A drawn rotation: orthonormal rows with determinant +1.
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const double d = r[3 * i] * r[3 * j] + r[3 * i + 1] * r[3 * j + 1] + r[3 * i + 2] * r[3 * j + 2];
          err = std::max(err, std::abs(d - (i == j ? 1.0 : 0.0)));
        }
      const double det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) +
                         r[2] * (r[3] * r[7] - r[4] * r[6]);
      err = std::max(err, std::abs(det - 1.0));
    }
    if (!(err <= 1e-12))
      throw bad(kInitialOrientations,
                "row " + std::to_string(k) + " to be capsule " + std::to_string(k) + "'s rotation (row-major, lab = R " +
                    "body) " + (!cfg.capsule_list.empty() ? "of its [[capsule]] orientation"
                                                          : sphere ? "of a sphere: the identity"
                                                                   : "drawn by the placement: orthonormal, det +1"));
  }
  // The interface-velocity solve's first guess is the previous solve's answer: a continuation without it (or with
  // one where no solve has run yet) takes another first guess and other bits.
  const bool solves = cfg.has_viscosity_contrast();
  if (solves && st.step > 0 && st.interface_velocity.empty())
    throw bad(std::string(kInterfaceVelocity) + " (missing)",
              "[3, " + std::to_string(st.positions.size() / 3) + "] values: the stored configuration has a " +
                  "[[species]] viscosity_ratio other than 1, and at step " + std::to_string(st.step) +
                  " its next solve starts from the last one's answer");
  if (solves && st.step == 0 && !st.interface_velocity.empty())
    throw bad(kInterfaceVelocity, "no such dataset at step 0 (the first solve starts from the imposed flow)");
  if (!solves && (st.gmres_steps_since_record != 0 || st.gmres_iterations_since_record != 0))
    throw bad("/state attributes gmres_*_since_record",
              "no GMRES tallies: the stored configuration has no [[species]] viscosity_ratio other than 1");
}

}  // namespace capsflow

namespace capsflow {

void check_checkpoint_digests(const Checkpoint& ck, const std::string& file) {
  auto changed = [&](const std::string& what, const std::string& stored, const std::string& now) {
    return InputError(file + ": " + what + ": expected the contents it was written with (digest " + stored +
                      "), got " + now + ": the file was changed after capsflow wrote it, and a continuation from it "
                      "would not be the run's own (continue from an unchanged checkpoint)");
  };
  if (!ck.config_digest.empty())
    if (const std::string now = text_digest(ck.config_text); now != ck.config_digest)
      throw changed(std::string(layout::kConfig) + " (attribute digest)", ck.config_digest, now);
  if (!ck.state_digest.empty())
    if (const std::string now = checkpoint_state_digest(ck); now != ck.state_digest)
      throw changed("/state (attribute digest over /state and /run)", ck.state_digest, now);
}

namespace {

// `c` with the run-control keys (those `--restart --set` may change: config.cpp kRunControlKeys) and the output's
// name taken from `from`: what is left is the physics.
Config with_run_control_of(Config c, const Config& from) {
  c.time.end = from.time.end;
  c.time.stop_pair_dx = from.time.stop_pair_dx;
  c.run = from.run;
  c.output.every = from.output.every;
  c.output.frames_every = from.output.frames_every;
  c.output.checkpoint_every = from.output.checkpoint_every;
  c.output.file = from.output.file;
  c.gmres.max_iterations = from.gmres.max_iterations;
  c.gmres.restart = from.gmres.restart;
  c.gmres.rigid_preconditioner = from.gmres.rigid_preconditioner;
  return c;
}

// The first line where two texts differ, or "" when they are equal.
std::pair<std::string, std::string> first_difference(const std::string& a, const std::string& b) {
  std::istringstream sa(a), sb(b);
  std::string la, lb;
  while (true) {
    const bool ga = static_cast<bool>(std::getline(sa, la)), gb = static_cast<bool>(std::getline(sb, lb));
    if (!ga && !gb) return {};
    if (!ga) la = "(nothing)";
    if (!gb) lb = "(nothing)";
    if (!ga || !gb || la != lb) return {la, lb};
  }
}

}  // namespace

void check_checkpoint_output(const Checkpoint& ck, const Config& cfg, const std::filesystem::path& output,
                             const std::string& file) {
  using namespace layout;
  const std::string out = output.string();
  if (!std::filesystem::exists(output))
    throw InputError(out + ": the output file of the checkpointed run does not exist (pass it with --output)");
  // Shared: a live run's file is refused by its marker, which the caller has read; this reads without HDF5's lock.
  std::optional<H5File> opened;
  try {
    opened.emplace(H5File::open(output, H5Access::ReadShared));
  } catch (const std::exception& e) {
    throw InputError(out + ": cannot read the output the checkpoint continues (" + e.what() + ")");
  }
  const H5File& f = *opened;
  const std::string id = f.has_attribute("/", kAttrRunId) ? f.attribute<std::string>("/", kAttrRunId) : "<none>";
  if (id != ck.run_id)
    throw InputError(out + ": belongs to another run (run_id " + id + ") than the checkpoint (run_id " + ck.run_id +
                     "); pass the right file with --output");
  const SimulationSnapshot& st = ck.state;
  const std::size_t records = static_cast<std::size_t>(ck.schedule.records);
  auto bad = [&](const std::string& what, const std::string& expected) {
    return InputError(file + ": " + what + ": expected " + expected + " (a damaged or hand-made checkpoint)");
  };
  const double tol = 1e-9 * std::max(1.0, std::abs(st.time));  // run_driver's due(): records fall due within it
  // An output torn by a full disk may not read back here: the restart repairs it from the records the checkpoint
  // covers (RunOutput), or says why it cannot; only an output that reads is compared.
  try {
    if (f.exists(kTime)) {
      const std::size_t have = f.extent(kTime);
      if (have < records)
        throw InputError(out + ": " + kTime + " holds " + std::to_string(have) + " records, fewer than the " +
                         std::to_string(records) + " the checkpoint " + file + " counts (the output is older than " +
                         "the checkpoint)");
      const double last = records > 0 ? f.read_records<double>(kTime, records - 1, 1).data.at(0) : -1.0;
      if (records > 0 && !(last <= st.time + tol))
        throw bad("/state attribute time", "a strain at or after the output's record " + std::to_string(records) +
                                               " (strain " + format_significant(last, 6) + " in " + out + " " +
                                               kTime + "), got " + format_significant(st.time, 6));
    }
  } catch (const H5Error&) {
  }
  // Every evaluated state before this one was below the next record's strain (a record falls due at the first state
  // at or past it, and the schedule then moves on): the state one step back, at time - dt_previous, was. This one may
  // be past it (a run stopped by its interface solve checkpoints before the outputs due there).
  if (!(st.time - st.dt_previous < ck.schedule.next_record + tol))
    throw bad("/state attribute time", "a strain at most one step (/state attribute dt_previous = " +
                                           format_significant(st.dt_previous, 6) + ") past /run attribute "
                                           "next_record (" + format_significant(ck.schedule.next_record, 6) +
                                           "), got " + format_significant(st.time, 6));
  // Without a configuration digest the output's copy is the reference: the same physics, run-control keys aside.
  if (ck.config_digest.empty() && f.exists(kConfig)) {
    Checkpoint as_output = ck;
    try {
      as_output.config_text = f.read_string(kConfig);
    } catch (const H5Error&) {
      return;  // (torn: as above)
    }
    // (Read under the checkpoint's name: to_toml names its source on its first line.)
    const Config theirs = with_run_control_of(checkpoint_config(as_output, file), cfg);
    if (const auto [a, b] = first_difference(to_toml(cfg), to_toml(theirs)); !a.empty() || !b.empty())
      throw bad(kConfig, "the physics of the run's output (" + out + " " + kConfig + ", run-control keys aside), " +
                             "which has `" + b + "` where the checkpoint has `" + a + "`");
  }
}

}  // namespace capsflow
