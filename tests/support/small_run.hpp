#pragma once
// The tests' small run: two level-1 capsules (stiff Ca 0.2 below, floppy Ca 0.6 above) in simple shear in the
// smallest box the cutoff allows, a few ms per step. Shared by test_simulation and test_resident_step; a test changes
// what it needs in the parsed Config (or appends TOML sections through `extra`).
#include <string>

#include "host/physics/config.hpp"

namespace capsflow::test {

inline std::string small_run_text(const std::string& extra = "") {
  return R"(
[domain]
H = 6.0
Lx = 6.2
Lz = 6.2
[ggem]
alpha = 4.0
alpha_hm = 0.5
[run]
backend = "threads"
[flow]
type = "shear"
shear_rate = 1.0
[capsules]
mesh_level = 1
inflation = 0.05
[[species]]
name = "stiff"
ca = 0.2
[[species]]
name = "floppy"
ca = 0.6
[[capsule]]
species = "stiff"
center = [2.0, 2.6, 3.1]
[[capsule]]
species = "floppy"
center = [4.3, 3.5, 3.1]
[time]
end = 1.0
[output]
every = 0.05
frames_every = 0.2
checkpoint_every = 0.4
)" + extra;
}

// The small run parsed, on the serial backend, to strain `end`, a frame every 0.1: the frame-reading tests'
// (run --from, flow).
inline Config small_serial_config(double end, const std::string& extra = "") {
  Config c = parse_config(small_run_text(extra), "small.toml");
  c.run.backend = Backend::Serial;
  c.time.end = end;
  c.output.frames_every = 0.1;
  return c;
}

// The sweep tests' base configuration: two level-1 capsules placed at random (seed `seed`) in shear on a small grid,
// serial, to strain 0.3 (~0.05 s per step, ~14 steps per strain unit: a point's run takes about a second).
// `time_extra` adds keys to [time].
inline std::string sweep_base_text(int seed = 1, const std::string& time_extra = "") {
  return R"([domain]
H = 6.0
Lx = 8.0
Lz = 8.0
[ggem]
alpha = 2.0
alpha_hm = 0.5
[run]
backend = "serial"
[flow]
type = "shear"
[capsules]
mesh_level = 1
[[species]]
name = "a"
ca = 0.3
[[species]]
name = "b"
ca = 0.6
[suspension]
count = 2
fractions = [0.5, 0.5]
seed = )" + std::to_string(seed) + R"(
[time]
end = 0.3
)" + time_extra + R"([output]
file = "unused.h5"
every = 0.05
frames_every = 0.5
checkpoint_every = 0.25
)";
}

}  // namespace capsflow::test
