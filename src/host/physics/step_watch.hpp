#pragma once
// Steps far below what the configuration implies (issue 37). Under the membrane rule (docs/method.md 4.1) the step a
// configuration sets is dt_M = cfl Ca_ref h / a_ref (with bending combined): cfl, the capsules' Ca and the mesh. Four
// other keys can hold it lower, each for a reason: near_contact_factor (while a pair is within h_e), the collision
// cap c_gap max(g, min_gap) / w (a closing gap; a tiny min_gap lets gaps, and with them the cap, shrink without
// bound) and max_step_ratio (a step's growth). Set far too small, any of them makes a run that takes 1e5-1e6 steps
// per strain unit, which before this ran on without a word (`c_gap = 1e-6`: dt 2e-6, killed after 300 s), or was
// refused with the membrane rule's keys as the cause ("cfl").
//
//   step_limit_keys: what held one step below dt_M, naming the key and its value (for refusals and stops);
//   StepWatch:       fed every step of a run, it returns one warning the first time the mean step of a window of
//                    kWindow consecutive steps falls below dt_M / kFarBelow, naming the key responsible, the step and
//                    what the rest of the run costs at that rate.
//
//   StepWatch watch;
//   for (...) {
//     StepInfo info = sim.advance();
//     const std::string w = watch.observe(cfg, info, sim.time(), sim.near_contact_range());
//     if (!w.empty()) log << "capsflow run: warning: " << w << "\n";
//   }
#include <array>
#include <chrono>
#include <cstdint>
#include <string>

#include "host/physics/config.hpp"
#include "host/physics/step_rule.hpp"

namespace capsflow {

// What held the step `info` below the membrane rule's dt_M, with the key(s) and values: empty when nothing did (the
// rule itself, or the paper rule, whose own keys name the step). h_near is h_e (Simulation::near_contact_range()).
std::string step_limit_keys(const Config& c, const StepInfo& info, double h_near);

// Which key to change for a step held by `limit` (the advice of a warning): "raise [time] c_gap (default 0.25)".
std::string step_limit_advice(const Config& c, StepLimit limit);

class StepWatch {
 public:
  static constexpr int kWindow = 20;          // consecutive steps whose mean is compared
  static constexpr double kFarBelow = 20.0;   // "far below": the mean step under dt_M / kFarBelow

  // After each step taken (info as advance() returned it; strain the time after the step; h_near as for
  // step_limit_keys). The projection's seconds per step are the window's own (wall clock between the calls, so the
  // start's setup is not in it). Returns the warning once, the
  // first time the window's mean falls far below the rule's mean; empty otherwise. Only the membrane rule is watched
  // (the paper rule steps by the gap by design).
  std::string observe(const Config& c, const StepInfo& info, double strain, double h_near);
  bool warned() const { return warned_; }

 private:
  std::array<double, kWindow> dt_{}, dt_rule_{};
  std::array<StepLimit, kWindow> limit_{};
  std::array<std::chrono::steady_clock::time_point, kWindow> when_{};
  std::int64_t seen_ = 0;
  bool warned_ = false;
  std::array<StepInfo, kStepLimitCount> last_{};  // the last step each limit held (its gaps for the message)
};

}  // namespace capsflow
