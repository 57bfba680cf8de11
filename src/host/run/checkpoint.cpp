#include "host/run/checkpoint.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <utility>

#include "capsflow_version.hpp"
#include "host/base/errors.hpp"
#include "host/base/h5_file.hpp"
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
}  // namespace

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& ck) {
  using namespace layout;
  write_checkpoint_atomically(path, [&](H5File& f) {
    const SimulationSnapshot& st = ck.state;
    const std::size_t np = st.species.size(), n = st.positions.size() / 3;
    f.set_attribute("/", kAttrVersion, CAPSFLOW_VERSION_STRING);
    f.set_attribute("/", kAttrFormat, ck.format_version);
    f.set_attribute("/", kAttrRunId, ck.run_id);
    f.set_attribute("/", kAttrOutputFile, ck.output_file);
    f.write_string(kConfig, ck.config_text);
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
    if (st.gmres_steps_since_record > 0) {
      f.set_attribute(kState, "gmres_steps_since_record", st.gmres_steps_since_record);
      f.set_attribute(kState, "gmres_iterations_since_record", st.gmres_iterations_since_record);
      f.set_attribute(kState, "gmres_max_iterations_since_record", st.gmres_max_iterations_since_record);
      f.set_attribute(kState, "gmres_max_residual_since_record", st.gmres_max_residual_since_record);
    }
    if (!st.step_limits_since_record.empty())
      f.write(kStepLimitsSince, {st.step_limits_since_record.size()}, st.step_limits_since_record);
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
  if (ck.format_version > kFormatVersion)
    throw InputError(where + "written in format " + std::to_string(ck.format_version) + " by a newer capsflow (" +
                     "this one reads up to " + std::to_string(kFormatVersion) + ")");
  ck.run_id = f.attribute<std::string>("/", kAttrRunId);
  ck.output_file = f.attribute<std::string>("/", kAttrOutputFile);
  if (f.has_attribute("/", kAttrVersion)) ck.capsflow_version = f.attribute<std::string>("/", kAttrVersion);
  ck.config_text = f.read_string(kConfig);
  ck.schedule.next_record = f.attribute<double>(kRun, "next_record");
  ck.schedule.next_frame = f.attribute<double>(kRun, "next_frame");
  ck.schedule.next_checkpoint = f.attribute<double>(kRun, "next_checkpoint");
  ck.schedule.records = f.attribute<std::int64_t>(kRun, "records");
  ck.schedule.frames = f.attribute<std::int64_t>(kRun, "frames");
  if (f.has_attribute(kRun, "events")) ck.schedule.events = f.attribute<std::int64_t>(kRun, "events");
  SimulationSnapshot& st = ck.state;
  st.initial_centres = f.read<double>(kInitialCentres).data;
  if (f.exists(kInitialOrientations)) st.initial_orientations = f.read<double>(kInitialOrientations).data;
  st.species = f.read<std::int64_t>(kSpecies).data;
  st.pinned = f.read<std::int64_t>(kPinned).data;
  st.pin_centres = f.read<double>(kPinCentres).data;
  st.image = f.read<std::int64_t>(kImage).data;
  st.positions = f.read<double>(kPositions).data;
  st.u_previous = f.read<double>(kUPrevious).data;
  st.time = f.attribute<double>(kState, "time");
  st.step = f.attribute<std::int64_t>(kState, "step");
  st.dt_previous = f.attribute<double>(kState, "dt_previous");
  st.have_history = f.attribute<std::int64_t>(kState, "have_history") != 0;
  if (f.exists(kUPrevious2) && f.has_attribute(kState, "have_history2")) {
    st.u_previous2 = f.read<double>(kUPrevious2).data;
    st.have_history2 = f.attribute<std::int64_t>(kState, "have_history2") != 0;
  }
  st.contact_corrections = f.attribute<std::int64_t>(kState, "contact_corrections");
  st.steps_with_contacts = f.attribute<std::int64_t>(kState, "steps_with_contacts");
  st.unconverged_contacts = f.attribute<std::int64_t>(kState, "unconverged_contacts");
  if (f.has_attribute(kState, "max_step_ratio_since_record"))
    st.max_step_ratio_since_record = f.attribute<double>(kState, "max_step_ratio_since_record");
  if (f.exists(kInterfaceVelocity)) st.interface_velocity = f.read<double>(kInterfaceVelocity).data;
  if (f.exists(kInterfaceVelocityPrevious) && f.has_attribute(kState, "interface_velocity_previous_time")) {
    st.interface_velocity_previous = f.read<double>(kInterfaceVelocityPrevious).data;
    st.interface_velocity_previous_time = f.attribute<double>(kState, "interface_velocity_previous_time");
  }
  if (f.has_attribute(kState, "gmres_steps_since_record")) {
    st.gmres_steps_since_record = f.attribute<std::int64_t>(kState, "gmres_steps_since_record");
    st.gmres_iterations_since_record = f.attribute<std::int64_t>(kState, "gmres_iterations_since_record");
    st.gmres_max_iterations_since_record = f.attribute<std::int64_t>(kState, "gmres_max_iterations_since_record");
    st.gmres_max_residual_since_record = f.attribute<double>(kState, "gmres_max_residual_since_record");
  }
  if (f.has_attribute(kState, "contact_events"))
    st.contact_events = f.attribute<std::int64_t>(kState, "contact_events");
  if (f.exists(kStepLimitsSince)) st.step_limits_since_record = f.read<std::int64_t>(kStepLimitsSince).data;
  // A checkpoint is an input like any other: values no run can have written are refused here, not met in the loop
  // (a NaN time never reaches the end; a NaN position stops the first step).
  auto bad = [&](const std::string& what, const std::string& expected) {
    return InputError(where + what + ": expected " + expected + " (a damaged or hand-made checkpoint)");
  };
  if (!(std::isfinite(st.time) && st.time >= 0.0)) throw bad("/state attribute time", "a finite strain >= 0");
  if (st.step < 0) throw bad("/state attribute step", "an integer >= 0");
  if (!(std::isfinite(st.dt_previous) && st.dt_previous >= 0.0))
    throw bad("/state attribute dt_previous", "a finite step >= 0");
  for (const auto& [name, v] : {std::pair<const char*, double>{"next_record", ck.schedule.next_record},
                                {"next_frame", ck.schedule.next_frame},
                                {"next_checkpoint", ck.schedule.next_checkpoint}})
    if (!std::isfinite(v)) throw bad(std::string("/run attribute ") + name, "a finite strain");
  if (ck.schedule.records < 0 || ck.schedule.frames < 0 || ck.schedule.events < 0)
    throw bad("/run attributes records, frames, events", "counts >= 0");
  for (const std::vector<double>* a :
       {&st.positions, &st.u_previous, &st.u_previous2, &st.initial_centres, &st.initial_orientations})
    for (double x : *a)
      if (!std::isfinite(x)) throw bad(a == &st.positions ? "/state/positions" : "/state velocities and centres",
                                       "finite values");
  return ck;
}

Config checkpoint_config(const Checkpoint& ck, const std::string& where,
                         const std::vector<ConfigOverride>& overrides) {
  Config c = resolve_config(ck.config_text, where + ":/parameters/config", overrides);
  if (ck.format_version < 2) {
    // Format 1 (issue 4) had no velocity projection and no cap on the step ratio: a key its configuration could
    // not hold takes that behaviour, not today's default. Keys it does hold (volume_correction) are as written.
    const toml::table t = toml::parse(ck.config_text);
    if (!t["capsules"]["velocity_projection"]) c.capsules.velocity_projection = false;
    if (!t["time"]["max_step_ratio"]) c.time.max_step_ratio = kUncappedStepRatio;
  }
  // A run made before [time] step_rule existed stepped by the seed's rule: it continues with it, not today's default.
  if (!toml::parse(ck.config_text)["time"]["step_rule"]) c.time.step_rule = StepRule::Paper;
  return c;
}

}  // namespace capsflow
