#pragma once
// One step of a run on another backend against the serial run's (the harness's compare of whole steps): the largest
// difference of the two node displacements and the largest serial displacement, from the positions before the step.
#include <algorithm>
#include <cmath>
#include <vector>

#include "host/physics/simulation.hpp"

namespace capsflow::test {

struct StepDifference {
  double worst = 0.0;  // max over nodes and components of |displacement(other) - displacement(serial)|
  double scale = 0.0;  // max |displacement(serial)|
};

// The positions of a simulation (the start of the step to compare).
struct Positions {
  std::vector<double> x, y, z;
  explicit Positions(const Simulation& s) : x(s.state().x), y(s.state().y), z(s.state().z) {}
};

inline StepDifference step_difference(const Positions& before, const Simulation& serial, const Simulation& other) {
  StepDifference d;
  const CapsuleState &a = serial.state(), &b = other.state();
  for (std::size_t i = 0; i < before.x.size(); ++i) {
    const double ds[3] = {a.x[i] - before.x[i], a.y[i] - before.y[i], a.z[i] - before.z[i]};
    const double db[3] = {b.x[i] - before.x[i], b.y[i] - before.y[i], b.z[i] - before.z[i]};
    for (int c = 0; c < 3; ++c) {
      d.scale = std::max(d.scale, std::abs(ds[c]));
      d.worst = std::max(d.worst, std::abs(db[c] - ds[c]));
    }
  }
  return d;
}

}  // namespace capsflow::test
