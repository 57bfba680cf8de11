// The implementation of embedded_demo.hpp: the embedded demo's configuration (`capsflow run` without CONFIG).
#include "host/run/embedded_demo.hpp"

namespace capsflow {

std::string embedded_demo_config() {
  return R"(# capsflow run's embedded demo: 8 capsules, 4 stiff (Ca = 0.2) and 4 floppy (Ca = 1), in pressure-driven flow
# through a slit of width H = 8a, all starting at 0.6a from a wall. The walls push deformed capsules toward the
# centreline (wall-induced migration); floppy capsules deform more and leave the walls faster. Segregation by
# rigidity (Kumar & Graham) starts from this difference.
[domain]
H = 8.0
Lx = 8.0
Lz = 8.0

[ggem]
alpha = 4.0
alpha_hm = 0.5

[run]
backend = "threads"

[flow]
type = "poiseuille"
shear_rate = 1.0

[capsules]
mesh_level = 2
inflation = 0.1
# The volumes are held by the defaults (velocity_projection and volume_correction, D11; docs/method.md section 3).

[[species]]
name = "stiff"
ca = 0.2

[[species]]
name = "floppy"
ca = 1.0

[[capsule]]
species = "stiff"
center = [2.0, 1.6, 2.0]
[[capsule]]
species = "floppy"
center = [6.0, 1.6, 2.0]
[[capsule]]
species = "floppy"
center = [2.0, 1.6, 6.0]
[[capsule]]
species = "stiff"
center = [6.0, 1.6, 6.0]
[[capsule]]
species = "stiff"
center = [0.0, 6.4, 4.0]
[[capsule]]
species = "stiff"
center = [4.0, 6.4, 0.0]
[[capsule]]
species = "floppy"
center = [4.0, 6.4, 4.0]
[[capsule]]
species = "floppy"
center = [0.0, 6.4, 0.0]

[time]
end = 40.0

[output]
file = "capsflow-run-demo/demo.h5"
every = 0.1
frames_every = 0.5
checkpoint_every = 5.0
)";
}

}  // namespace capsflow
