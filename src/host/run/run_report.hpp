#pragma once
// What `capsflow run` tells its user: the header line, progress lines with the time remaining, the end-of-run
// summary (timings, contact events, volumes, flow diagnostics, per-species positions).
// Nothing here changes the run; the driver hands it what to say.
#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/run/run_layout.hpp"
#include "host/physics/simulation.hpp"
#include "host/solver/gmres.hpp"

namespace capsflow {

std::string duration_text(double seconds);

void print_run_header(std::ostream& log, const Simulation& sim, const RunPaths& paths, bool restart, double end);

// Progress lines at most every `every_seconds` (<= 0: none): strain, step, dt, contacts, s/step, ETA.
class ProgressLine {
 public:
  ProgressLine(double every_seconds, double t_start, double end);
  void step(std::ostream& log, const Simulation& sim, const StepInfo& info, std::int64_t steps_here);

 private:
  double every_, t_start_, end_;
  std::chrono::steady_clock::time_point start_, last_;
  long contacts_since_ = 0;
};

// Figures of this process's part of the run, accumulated by the driver.
struct RunTally {
  SimulationTimings timings;      // summed over steps
  double io_seconds = 0.0;
  double loop_seconds = 0.0;
  std::int64_t steps = 0;
  std::int64_t capped_steps = 0;  // steps limited by [time] max_step_ratio
  double t_start = 0.0;           // strain at the start of this process
  long events_start = 0;          // contact events before this process
  double flow_sum = 0.0;          // sum of the records' flow diagnostic (flow_rate_ratio or relative_viscosity)
  std::int64_t flow_records = 0;
  std::array<std::int64_t, kStepLimitCount> limits{};  // steps of this part by what set their size (StepLimit)
  double contact_dy = 0.0;        // sum of |dy| of this part's contact events (both capsules of a pair)
  // The interface-velocity solves of this part (viscosity ratio != 1): steps, operator applications, the largest
  // count and final residual.
  GmresTally gmres;
};

void print_run_summary(std::ostream& log, const Simulation& sim, const RunTally& tally, const RunPaths& paths,
                       const std::string& stop_message, double wall_seconds);

}  // namespace capsflow
