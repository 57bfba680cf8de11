#pragma once
// Constraints on the positions after the integrator's update (HOOMD's ForceConstraint, Mirheo's PinObject), applied
// in order (D11 revised: the volume projection before contact, so the contact control has the last word on gaps):
//   VolumeCorrection ([capsules] volume_correction): each capsule's volume restored by a uniform normal
//                    displacement, the safety net for the O(dt^2) remainder of the velocity projection;
//   ContactControl:  rigid contact control to [time] min_gap, pairs and walls (D5); every correction an event;
//   PinAndWrap:      pinned capsules translated back to their initial centre of mass (D10); capsules whose node mean
//                    left [0, Lx) x [0, Lz) shifted by a period (image counts keep the unwrapped trajectory).
// Then the stop rules (StepCheck hooks) judge the new positions before they are kept.
//
// Each takes the state and the workspace explicitly (ConstraintContext) and keeps its own data (target volumes,
// counters and events, pins and image counts); none includes the Simulation. commit() runs only for a step that is
// kept, so a refused step leaves no count behind.
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/step_records.hpp"
#include "host/physics/step_rule.hpp"
#include "host/state/capsule_state.hpp"
#include "host/state/step_workspace.hpp"

namespace capsflow {

struct ConstraintContext {
  CapsuleState& s;
  StepWorkspace& ws;
  Backend backend;           // the run's
  Backend geometry_backend;  // Serial on the host backends (the reference sums), Device on the device
  NodeVectors w;             // scratch node arrays (volume gradients)
  SimulationTimings& timings;
};

class Constraint {
 public:
  virtual ~Constraint() = default;
  virtual void apply(ConstraintContext& c, StepInfo& info) = 0;
  virtual void commit(const StepInfo&, double /*time after the step*/) {}
};

class VolumeCorrection final : public Constraint {
 public:
  explicit VolumeCorrection(std::vector<double> volume0) : volume0_(std::move(volume0)) {}
  void apply(ConstraintContext& c, StepInfo& info) override;
  const std::vector<double>& target() const { return volume0_; }  // initial volume per capsule

 private:
  std::vector<double> volume0_;
};

class ContactControl final : public Constraint {
 public:
  explicit ContactControl(const Config& cfg) : cfg_(&cfg) {}
  void apply(ConstraintContext& c, StepInfo& info) override;  // sets info.contact
  void commit(const StepInfo& info, double time) override;    // counters and events

  long corrections() const { return corrections_; }
  long steps_with_contacts() const { return steps_with_contacts_; }
  long unconverged() const { return unconverged_; }
  long events() const { return events_total_; }
  std::vector<ContactEventRecord> take_events() { return std::exchange(events_, {}); }
  void save(SimulationSnapshot& st) const;
  void restore(const SimulationSnapshot& st);

 private:
  const Config* cfg_;
  long corrections_ = 0, steps_with_contacts_ = 0, unconverged_ = 0, events_total_ = 0;
  std::vector<ContactEventRecord> events_;
};

class PinAndWrap final : public Constraint {
 public:
  // pinned: per capsule; centre: 3 per capsule (the initial centres of mass); image counts start at 0.
  PinAndWrap(const Config& cfg, std::vector<char> pinned, std::vector<double> centre);
  void apply(ConstraintContext& c, StepInfo& info) override;

  const std::vector<char>& pinned() const { return pinned_; }
  const std::vector<std::int64_t>& image() const { return image_; }
  // Centroids with the periodic shifts undone (3 per capsule).
  std::vector<double> unwrapped(const std::vector<double>& centroid) const;
  void save(SimulationSnapshot& st) const;
  void restore(const SimulationSnapshot& st);

 private:
  double Lx_, Lz_;
  std::vector<char> pinned_;
  std::vector<double> centre_;        // 3 per capsule (pinned ones)
  std::vector<std::int64_t> image_;   // 2 per capsule: periods shifted in x and z
};

// Stop rules: checks of the new positions before they are kept, in order (Mirheo's plugin hooks; a new rule is one
// more entry, not one more branch in the step). Each returns StopReason::None or the reason with its message.
struct StepCheckContext {
  const CapsuleState& s;
  StepWorkspace& ws;
  Backend backend, geometry_backend;
  const Config& cfg;
  double cutoff;  // the local sums' cutoff (the box must stay larger than 2 (cutoff + element radius))
};
using StepCheck = std::function<StopReason(StepCheckContext&, const StepInfo&, std::string& why)>;
// Finite positions, inside the slit, elements small enough for the box, a converged contact control.
std::vector<StepCheck> standard_step_checks();

}  // namespace capsflow
