// The implementation of step_watch.hpp: steps far below what the configuration implies (issue 37).
#include "host/physics/step_watch.hpp"

#include <cmath>
#include <cstdio>

#include "host/base/printable.hpp"

namespace capsflow {

namespace {

std::string num(double v) { return format_significant(v, 3); }

// The collision cap's key to blame: c_gap when below its default, else min_gap when below its default (scaled with
// the [capsules] radius, as every length of the problem: docs/method.md 4.1), else c_gap.
bool blame_min_gap(const Config& c) {
  const TimeOptions d;
  return !(c.time.c_gap < d.c_gap) && c.time.min_gap < d.min_gap * c.capsules.radius;
}

std::string duration(double seconds) {
  if (!std::isfinite(seconds)) return "an unknown time";
  if (seconds < 120.0) return num(seconds) + " s";
  if (seconds < 7200.0) return num(seconds / 60.0) + " minutes";
  if (seconds < 2.0 * 86400.0) return num(seconds / 3600.0) + " hours";
  return num(seconds / 86400.0) + " days";
}

}  // namespace

std::string step_limit_keys(const Config& c, const StepInfo& info, double h_near) {
  const std::string pair = std::isfinite(info.pair_gap) ? ", closest pair gap " + num(info.pair_gap) : "";
  switch (info.limit) {
    case StepLimit::NearContact:
      return "[time] near_contact_factor = " + num(c.time.near_contact_factor) + " (the membrane rule's step " +
             num(info.dt_membrane) + " times it while a capsule pair is closer than h_e = " + num(h_near) + pair + ")";
    case StepLimit::Collision: {
      const std::string cap = "[time] c_gap = " + num(c.time.c_gap) + " x max(gap, [time] min_gap = " +
                              num(c.time.min_gap) + ") / closing speed = " + num(info.dt_collision);
      const std::string why = " (a step closes at most c_gap of a gap below h_e = " + num(h_near) + pair + ")";
      if (blame_min_gap(c))
        return "[time] min_gap = " + num(c.time.min_gap) + ", which lets gaps close to it, in the collision cap " +
               cap + why;
      return "the collision cap " + cap + why;
    }
    case StepLimit::Ratio:
      return "[time] max_step_ratio = " + num(c.time.max_step_ratio) + " (a step at most that many times the previous)";
    case StepLimit::Membrane:
    case StepLimit::PaperGap:
      break;
  }
  return "";
}

std::string step_limit_advice(const Config& c, StepLimit limit) {
  const TimeOptions d;
  switch (limit) {
    case StepLimit::NearContact:
      return "raise [time] near_contact_factor (default " + num(d.near_contact_factor) +
             ", which the stability probe allows: docs/method.md 4.1)";
    case StepLimit::Collision:
      if (blame_min_gap(c))
        return "raise [time] min_gap (default " + num(d.min_gap) + " a)";
      if (c.time.c_gap < d.c_gap)
        return "raise [time] c_gap (default " + num(d.c_gap) + ": a quarter of a gap per step)";
      return "a gap closes fast at the defaults [time] c_gap = " + num(d.c_gap) + " and min_gap = " +
             num(d.min_gap) + " a; check the capsules' placement and the flow";
    case StepLimit::Ratio:
      return "raise [time] max_step_ratio (default " + num(d.max_step_ratio) + ")";
    case StepLimit::Membrane:
    case StepLimit::PaperGap:
      break;
  }
  return "";
}

std::string StepWatch::observe(const Config& c, const StepInfo& info, double strain, double h_near) {
  if (warned_ || c.time.step_rule != StepRule::Membrane) return "";
  const auto i = static_cast<std::size_t>(seen_ % kWindow);
  dt_[i] = info.dt;
  dt_rule_[i] = info.dt_membrane;
  limit_[i] = info.limit;
  when_[i] = std::chrono::steady_clock::now();
  last_[static_cast<std::size_t>(info.limit)] = info;
  ++seen_;
  if (seen_ < kWindow) return "";
  double sum = 0.0, rule = 0.0;
  std::array<int, kStepLimitCount> count{};
  for (std::size_t k = 0; k < dt_.size(); ++k) {
    sum += dt_[k];
    rule += dt_rule_[k];
    ++count[static_cast<std::size_t>(limit_[k])];
  }
  if (!(sum < rule / kFarBelow)) return "";
  // The limit that held most of the window's steps (the rule itself excluded: it cannot be far below itself).
  std::size_t best = 0;
  for (std::size_t l = 1; l < count.size(); ++l)
    if (l != static_cast<std::size_t>(StepLimit::Membrane) && count[l] > count[best]) best = l;
  if (best == static_cast<std::size_t>(StepLimit::Membrane) || count[best] == 0) return "";
  const StepInfo& held = last_[best];
  warned_ = true;
  const double mean = sum / kWindow, rule_mean = rule / kWindow;
  const double left = c.time.end ? std::max(0.0, *c.time.end - strain) : 0.0;
  const double steps = left / mean;
  // The oldest call of the window is the next slot: kWindow - 1 steps between it and this one.
  const double seconds_per_step =
      std::chrono::duration<double>(when_[i] - when_[(i + 1) % kWindow]).count() / (kWindow - 1);
  return "the last " + std::to_string(kWindow) + " steps averaged dt = " + num(mean) + " strain units, 1/" +
         num(rule_mean / mean) + " of the membrane rule's " + num(rule_mean) +
         " ([time] cfl x Ca_ref x h / a_ref, what the configuration's cfl, Ca and mesh imply); " +
         std::to_string(count[best]) + " of them held by " + step_limit_keys(c, held, h_near) + ". At this rate the " +
         num(left) + " strain units to [time] end take about " + num(steps) + " steps (" +
         duration(steps * seconds_per_step) + " at " + num(seconds_per_step) + " s per step); " +
         step_limit_advice(c, static_cast<StepLimit>(best));
}

}  // namespace capsflow
