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
  // As read: the digests written with it (checkpoint_state_digest, text_digest of config_text); empty in
  // checkpoints written before 2026-12-08, which are checked against their output instead.
  std::string state_digest, config_digest;
};

// The digest of everything a continuation's bits depend on besides the configuration: the format, the run id, the
// output schedule and every /state dataset and attribute, in the order write_checkpoint writes them (docs/
// output_format.md). Written as /state attribute digest; the configuration's as /parameters/config attribute digest.
std::string checkpoint_state_digest(const Checkpoint& ck);

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& ck);
// InputError (naming the file and the dataset) when it is not a capsflow checkpoint, is incomplete, or holds what no
// run writes: a dataset of another shape (Np capsules, Nn nodes), non-finite values, negative counts.
Checkpoint read_checkpoint(const std::filesystem::path& path);
// The state against the configuration stored with it (`cfg`, from checkpoint_config): the datasets this
// configuration needs (/state/initial_orientations where it turns capsules, /state/interface_velocity where it
// solves for it), capsules, species and rotations as it places them. InputError naming `file` and the dataset.
// read_checkpoint has checked every dataset's shape, finiteness and counts.
void check_checkpoint_state(const Checkpoint& ck, const Config& cfg, const std::string& file);
// The digests written with the checkpoint against what was read: a mismatch means the file was changed after
// capsflow wrote it (a moved node, swapped or grafted datasets, an edited time or configuration), and a
// continuation from it would not be the run's own. InputError naming `file` and the digest's attribute. A
// checkpoint without digests (written before 2026-12-08) passes here; check_checkpoint_output compares its
// configuration with the output's.
void check_checkpoint_digests(const Checkpoint& ck, const std::string& file);
// The checkpoint against the output it continues (`output`, the file the restart will extend): the file exists,
// is the same run's (run_id), holds at least the records the checkpoint counts, and the state's strain is at or
// after the last of them and, one step back (dt_previous), below /run next_record; a checkpoint without a
// configuration digest has the output's physics (its /parameters/config, the run-control keys aside). InputError
// naming the file and the dataset.
void check_checkpoint_output(const Checkpoint& ck, const Config& cfg, const std::filesystem::path& output,
                             const std::string& file);
// The run's configuration as the checkpoint recorded it. Keys that a checkpoint of an older format could not hold
// take the behaviour of that format (never today's default), so a continued run is the same physics.
// `overrides` (run-control keys: check_restart_overrides) apply on top, before the configuration is checked.
Config checkpoint_config(const Checkpoint& ck, const std::string& where,
                         const std::vector<ConfigOverride>& overrides = {});

}  // namespace capsflow
