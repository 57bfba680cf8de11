#pragma once
// Diagnostics of the state that the record writes (docs/method.md section 4.5, docs/output_format.md): the bulk
// flow rate and relative viscosity from the force density, the species' volume profiles across the gap, and the
// tally of the steps since the last record (what set their size, their largest ratio, the interface solves).
// Functions of the state and the configuration alone (no Simulation), so the analysis and tests call them too.
#include <array>
#include <cstdint>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/step_records.hpp"
#include "host/physics/step_rule.hpp"
#include "host/solver/gmres.hpp"
#include "host/state/capsule_state.hpp"

namespace capsflow {

// Bulk diagnostics from the membrane force density at the current state (docs/method.md section 4.5): exact for
// the k = 0 (plane-averaged) flow of forces between two no-slip walls, with the force density linear on flat
// elements as the single layer uses it. NaN where the flow type does not define it.
struct FlowDiagnostics {
  double flow_rate_ratio = 0.0;     // Poiseuille at fixed pressure drop: Q / Q_0 = 1 + 3 M2 / (mu A gammadot_w H^2)
                                    // (lambda != 1: M2 also counts the inner fluid's flux, docs/method.md 4.5)
  double relative_viscosity = 0.0;  // shear: wall shear stress / mu gammadot = 1 - M1 / (mu gammadot A H)
};

// From the force density s.fx (valid after the membrane forces are computed) and positions of s. With a viscosity
// ratio other than 1, interface_velocity (the interface equation's solution at these positions, [x..., y..., z...])
// and lambda (per capsule) add the double layer's force dipoles mu (1 - lambda) (u n + n u) dS and, to the flow
// rate, the inner fluid's (1 - lambda) int_V u_x dV (the representation is lambda u inside a capsule, a
// cross-section's flux counts u there once); empty: forces only.
FlowDiagnostics flow_diagnostics(const CapsuleState& s, const Config& cfg,
                                 const std::vector<double>& interface_velocity = {},
                                 const std::vector<double>& lambda = {});

// Interior volume of each species' capsules in `bins` equal slabs of [0, H] (exact for the triangulated surfaces):
// [species][bin], row-major. Host positions.
std::vector<double> species_profile(const CapsuleState& s, const Config& cfg, int bins);

// The steps taken since the last record: the largest dt_n / dt_{n-1}, the count by what set their size (index:
// StepLimit) and the interface solves they served. The driver marks each record (mark()); checkpoints keep it.
struct RecordTally {
  double max_ratio = 0.0;
  std::array<std::int64_t, kStepLimitCount> limits{};
  GmresRecordStats gmres;

  void mark() {
    max_ratio = 0.0;
    limits.fill(0);
    gmres = GmresRecordStats{};
  }
  // A step kept; solve: the interface solve it served (null without one).
  void count(const StepInfo& info, const GmresResult* solve);
  void save(SimulationSnapshot& st) const;
  void restore(const SimulationSnapshot& st);
};

}  // namespace capsflow
