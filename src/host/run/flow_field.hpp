#pragma once
// The fluid velocity of a run's frame at points off the membranes (`capsflow flow`, issue 53): where, how, and the
// files. The velocity is the solver's own operator evaluated at the points (VelocityModel::velocities_at): imposed
// flow + the GGEM single layer of the frame's membrane load (local element sums at the points, the global part
// interpolated there, the walls' correction) + the double layer where a viscosity ratio differs from 1. The load is
// recomputed from the frame's positions and the run's membrane law in double precision (the frame's traction_jump is
// single precision, for viewing).
//
//   FlowTargets t = plane_targets(cfg, "z=3.1", 0.1);         // or point_targets("pts.csv", cfg.domain.H)
//   FlowField u = frame_flow(frame_start, cfg, std::move(t));
//   write_flow_h5("flow.h5", u, frame_start); write_flow_xdmf("flow.xdmf", "flow.h5", u);
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "host/base/csv_io.hpp"
#include "host/physics/config.hpp"
#include "host/run/frame_start.hpp"

namespace capsflow {

struct FlowTargets {
  std::vector<double> x, y, z;
  // A plane: "z=3.1" as given, its normal axis (0 x, 1 y, 2 z) and value, and the grid: nu points along axis_u (the
  // fastest in the arrays), nv along axis_v, both ends included. Points from a file: plane empty, nu = count, nv = 1.
  std::string plane;
  int axis = -1, axis_u = 0, axis_v = 1;
  double value = 0.0;
  std::size_t nu = 0, nv = 1;
  std::size_t size() const { return x.size(); }
};

// The grid of the plane `spec` ("x=V", "y=V" or "z=V"; V finite, 0 <= V <= H for y) over the box, `spacing` apart
// (in a; the box's extent divided into whole steps, both ends included). InputError naming --plane or --spacing.
FlowTargets plane_targets(const Config& cfg, const std::string& spec, double spacing);
// Points read from the CSV file `csv` with header x,y,z (read_targets_csv, as `capsflow green --targets` reads them),
// checked to lie in the slit, 0 <= y <= H.
FlowTargets point_targets(TargetPoints points, double H, const std::string& csv);

struct FlowField {
  FlowTargets at;
  std::vector<double> ux, uy, uz;        // the fluid velocity (gammadot a)
  std::vector<double> dx, dy, dz;        // its disturbance u - u_inf (the capsules' share)
  std::vector<int> capsule;              // the capsule each point lies in, or -1
  std::size_t nodes_matched = 0;         // points that are membrane nodes (evaluated with the singular rule)
};

// The velocity of frame `f` at the targets, with the physics of `cfg` (the source run's configuration, its backend
// a host one). A point equal to a node position, bit for bit, is evaluated as that node (its own elements take the
// singular rule), so the node velocities of the solver come back.
FlowField frame_flow(const FrameStart& f, const Config& cfg, FlowTargets targets);

// FLOW.h5 (docs/output_format.md "capsflow flow"), written atomically; FLOW.xdmf, its ParaView index (a structured
// surface for a plane, points otherwise), naming the HDF5 file relative to itself.
void write_flow_h5(const std::filesystem::path& path, const FlowField& u, const FrameStart& f, const Config& cfg);
void write_flow_xdmf(const std::filesystem::path& path, const std::filesystem::path& h5, const FlowField& u);

}  // namespace capsflow
