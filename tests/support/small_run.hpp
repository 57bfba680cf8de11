#pragma once
// The tests' small run: two level-1 capsules (stiff Ca 0.2 below, floppy Ca 0.6 above) in simple shear in the
// smallest box the cutoff allows, a few ms per step. Shared by test_simulation and test_resident_step; a test changes
// what it needs in the parsed Config (or appends TOML sections through `extra`).
#include <string>

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

}  // namespace capsflow::test
