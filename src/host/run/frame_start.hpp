#pragma once
// A frame of a run's output as the state another computation starts from (issue 53): `capsflow run CONFIG --from
// RUN.h5 [--frame N]` starts a new run there, `capsflow flow RUN.h5 [--frame N]` evaluates the fluid velocity of the
// frame. The frame gives the node positions, each capsule's species and pin, and the reference shapes (the placement
// the source run built them from); the configuration given gives the physics. Read through read_run_file, H5File and
// read_checkpoint, the readers that `analyze`, `render` and `--restart` use.
#include <cstddef>
#include <optional>
#include <string>

#include "host/physics/config.hpp"
#include "host/physics/step_records.hpp"

namespace capsflow {

struct FrameStart {
  std::string file;          // RUN.h5 as given
  std::size_t frame = 0;     // its index in /frames
  double strain = 0.0;       // its /frames/time
  Config source;             // the source run's configuration (/parameters/config)
  // The frame as a Simulation's snapshot: positions, reference placement (initial_centres, initial_orientations),
  // species, pins; no step history (the first step is Euler's), strain 0, pin centres left to the placement.
  SimulationSnapshot state;
};

// Frame `frame` of RUN.h5 (0 the first, negative from the end; nullopt: the last). The reference placement comes from
// the checkpoint beside RUN.h5 when it belongs to the same run (its /state/initial_centres and
// initial_orientations), else from placing the source's configuration again (the same arithmetic, so the same bits);
// a run that itself started from a frame has no other record of it than its checkpoint. InputError naming the file:
// not a run output, no frames, frame out of range, no reference placement to be had. `option` names the file's
// option in messages ("--from"; empty for a positional RUN.h5).
FrameStart read_frame_start(const std::string& file, std::optional<long> frame, const std::string& option = "--from");

// Refuses, with an InputError "RUN.h5 frame N and CONFIG disagree: ...", a configuration whose capsules are not the
// frame's: capsule count, mesh level, species (names, capsules of each, the species and pin of each [[capsule]]), and
// the keys the reference shapes are built from (radius, shape, inflation). Ca, bending, law, viscosity ratio, flow
// and numerics may differ: that is the physics the new run takes from its configuration.
void check_frame_fits(const FrameStart& f, const Config& cfg);

// The root attributes a run started from a frame carries (docs/output_format.md): the source file, frame index and
// the frame's strain.
inline constexpr const char* kAttrStartedFrom = "started_from";
inline constexpr const char* kAttrStartedFromFrame = "started_from_frame";
inline constexpr const char* kAttrStartedFromStrain = "started_from_strain";

}  // namespace capsflow
