#pragma once
// OUT.checkpoint.h5: what a bit-identical continuation needs (layout in run_layout.hpp and docs/output_format.md).
// Written atomically (a temporary renamed over the old file), so a crash or a full disk leaves the previous one.
#include <cstdint>
#include <filesystem>
#include <string>

#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"

namespace capsflow {

// How far the output had got when the checkpoint was taken (restart truncates OUT.h5 to this).
struct OutputSchedule {
  double next_record = 0.0, next_frame = 0.0, next_checkpoint = 0.0;
  std::int64_t records = 0, frames = 0, events = 0;
};

struct Checkpoint {
  std::int64_t format_version = 1;  // of the run's output (run_layout.hpp); 1 when the attribute is absent
  std::string run_id, output_file, config_text, capsflow_version;
  OutputSchedule schedule;
  SimulationSnapshot state;
};

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& ck);
// InputError (naming the file and the dataset) when it is not a capsflow checkpoint, is incomplete, or holds what no
// run writes: a dataset of another shape (Np capsules, Nn nodes), non-finite values, negative counts.
Checkpoint read_checkpoint(const std::filesystem::path& path);
// The state against the configuration stored with it (`cfg`, from checkpoint_config): the datasets this
// configuration needs (/state/initial_orientations where it turns capsules, /state/interface_velocity where it
// solves for it), capsules, species and rotations as it places them. InputError naming `file` and the dataset.
// read_checkpoint has checked every dataset's shape, finiteness and counts.
void check_checkpoint_state(const Checkpoint& ck, const Config& cfg, const std::string& file);
// The run's configuration as the checkpoint recorded it. Keys that a checkpoint of an older format could not hold
// take the behaviour of that format (never today's default), so a continued run is the same physics.
// `overrides` (run-control keys: check_restart_overrides) apply on top, before the configuration is checked.
Config checkpoint_config(const Checkpoint& ck, const std::string& where,
                         const std::vector<ConfigOverride>& overrides = {});

}  // namespace capsflow
