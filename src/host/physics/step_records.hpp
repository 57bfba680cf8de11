#pragma once
// The plain records a step's parts fill and the Simulation hands on: the stage timings, the contact events, the
// interface solve's tally and the snapshot for a bit-identical continuation. Their own header, so the parts
// (velocity_model, ab2_integrator, constraints) fill them without including the Simulation.
#include <cstdint>
#include <vector>

#include "host/solver/gmres.hpp"

namespace capsflow {

// One contact correction (contact.hpp's ContactEvent with the time of the step that made it).
struct ContactEventRecord {
  double time = 0.0;          // strain at the end of the step
  int p = 0, q = 0;           // capsules; a wall correction has q = -1 (wall y = 0) or -2 (wall y = H)
  double gap_before = 0.0;    // signed gap when first detected in the step
  double dy_p = 0.0, dy_q = 0.0;  // y-displacement of p and q by this correction (0 for the wall)
};

// The interface-velocity solves of the steps taken since the last record: steps, operator applications, the largest
// count and final residual (the run's whole tally is the same sum: one type, one add).
using GmresRecordStats = GmresTally;

struct SimulationTimings {        // seconds of the last evaluate() / advance()
  double forces = 0.0, local_nodes = 0.0, local_walls = 0.0, global = 0.0, velocity_total = 0.0;
  double step_size = 0.0, update = 0.0, contact = 0.0;
  double interface_solve = 0.0;  // viscosity ratio != 1: the GMRES solve (double-layer applications), within
                                 // velocity_total
  SimulationTimings& operator+=(const SimulationTimings& o) {  // summing over steps (run summary, benchmark)
    interface_solve += o.interface_solve;
    forces += o.forces;
    local_nodes += o.local_nodes;
    local_walls += o.local_walls;
    global += o.global;
    velocity_total += o.velocity_total;
    step_size += o.step_size;
    update += o.update;
    contact += o.contact;
    return *this;
  }
};

// Everything beyond the configuration that a bit-identical continuation needs (checkpoint.cpp stores it under
// /state). Vectors of points are interleaved x, y, z.
struct SimulationSnapshot {
  std::vector<double> initial_centres;    // 3 per capsule: they define the reference shapes exactly
  std::vector<double> initial_orientations;  // 9 per capsule (row-major body -> lab), or empty: all the identity
  std::vector<std::int64_t> species, pinned;  // per capsule
  std::vector<double> pin_centres;        // 3 per capsule
  std::vector<std::int64_t> image;        // 2 per capsule: periods shifted in x and z
  std::vector<double> positions;          // 3 per node
  std::vector<double> u_previous;         // 3 per node: the AB2 history u^{n-1}
  std::vector<double> u_previous2;        // 3 per node: u^{n-2} (only the AB2 error proxy reads it); may be empty
  std::vector<double> interface_velocity; // viscosity ratio != 1: the first guess of the solve at these positions,
                                          // [x..., y..., z...] (the one it used when the state was evaluated);
                                          // empty otherwise
  std::vector<double> interface_velocity_previous;  // the last answer before that solve (extrapolation); may be empty
  double interface_velocity_previous_time = 0.0;    // its strain
  std::vector<double> interface_velocity_previous2;  // the answer before that one (quadratic extrapolation); may be empty
  double interface_velocity_previous2_time = 0.0;    // its strain
  double time = 0.0, dt_previous = 0.0;
  std::int64_t step = 0;
  bool have_history = false;
  bool have_history2 = false;             // u_previous2 holds u^{n-2}
  std::int64_t contact_corrections = 0, steps_with_contacts = 0, unconverged_contacts = 0;
  double max_step_ratio_since_record = 0.0;
  // Interface-velocity solves since the last record (viscosity ratio != 1; zero otherwise and in older checkpoints).
  std::int64_t gmres_steps_since_record = 0, gmres_iterations_since_record = 0, gmres_max_iterations_since_record = 0;
  double gmres_max_residual_since_record = 0.0;
  std::int64_t contact_events = 0;
  std::vector<std::int64_t> step_limits_since_record;  // kStepLimitCount entries; empty in older checkpoints
};

// Three node arrays of one vector field (velocities, volume gradients), as a part is handed them. The vectors, not
// pointers: the workspace tracks them by buffer and a part may swap them.
struct NodeVectors {
  std::vector<double>& x;
  std::vector<double>& y;
  std::vector<double>& z;
};

}  // namespace capsflow
