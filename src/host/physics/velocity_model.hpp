#pragma once
// The velocity model (UAMMD's Method): node velocities from the force density at the current positions,
//   u = u_inf + S[f]                                             (SingleLayerPlan; viscosity ratio 1 everywhere),
//   ((1 + lambda)/2) u - K~[(1 - lambda) u] = u_inf + S[f]       (a species with lambda != 1: GMRES on the double
//                                                                 layer, docs/method.md 3.1, issue 22),
// then a drop's nodes (law = "surface-tension") keep only their normal motion (u.n) n, and with [capsules]
// velocity_projection each capsule's velocities are projected to zero discrete volume rate (D11).
//
// Owns the single and double layers' plans, the viscosity ratio per capsule, the GMRES vectors, the solve's first
// guesses (the last two answers extrapolated in time) and its record. Takes the state, the workspace and the node
// arrays it writes explicitly; includes nothing of the Simulation.
//
//   VelocityModel model(cfg.domain, cfg.ggem, backend, quadrature_orders(cfg.quadrature));  // plans once
//   model.configure(cfg, placements, state);              // lambda, double layer, drops
//   model.velocities(state, ws, u, w, strain, timings);   // f valid -> u
#include <memory>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/physics/step_records.hpp"
#include "host/solver/double_layer_plan.hpp"
#include "host/solver/gmres.hpp"
#include "host/solver/rigid_preconditioner.hpp"
#include "host/solver/single_layer_plan.hpp"
#include "host/state/capsule_state.hpp"
#include "host/state/step_workspace.hpp"

namespace capsflow {

// [quadrature] as the local sums' element rules (the outer collapsed-Gauss band stays off, as by default).
QuadratureOrders quadrature_orders(const QuadratureOptions& q);
// [flow] type as the kernels' code (kernels/step_update.hpp's imposed_flow_x).
int imposed_flow_code(FlowType t);

class VelocityModel {
 public:
  VelocityModel(const SlitGeometry& domain, const GgemOptions& ggem, Backend backend,
                const QuadratureOrders& orders = {});
  VelocityModel(const VelocityModel&) = delete;
  VelocityModel& operator=(const VelocityModel&) = delete;

  // After the capsules are placed: the viscosity ratio per capsule, the double layer (lambda != 1 somewhere) and
  // whether there are drops. cfg is kept by reference (the caller outlives the model).
  void configure(const Config& cfg, const std::vector<CapsulePlacement>& placements, const CapsuleState& s);

  // u at s's positions from s.f (valid, as the force terms left it). w: scratch node arrays (normals, volume
  // gradients); t: strain (the solve's guess extrapolates in it); timings: the velocity stages' seconds.
  void velocities(CapsuleState& s, StepWorkspace& ws, NodeVectors u, NodeVectors w, double t,
                  SimulationTimings& timings);

  // The fluid velocity at nt points of the slit, after velocities() at s's positions (`capsflow flow`), by the same
  // operator: u = u_inf + S[f], plus K_d[(1 - lambda) u_s] where a viscosity ratio differs from 1 (u_s the interface
  // solve's answer), divided by lambda inside a capsule of ratio lambda (the boundary-integral representation off the
  // membrane, docs/method.md 3.1). target_node[p]: the node point p is, or -1 (nullptr: none); at a node with a
  // double layer the value is the solve's answer u_s there. capsule (nullable): for each point the capsule it lies
  // in, or -1, from the double layer of a constant density (-1 inside, 0 outside). Host backends only.
  void velocities_at(const CapsuleState& s, std::size_t nt, const double* tx, const double* ty, const double* tz,
                     const int* target_node, double* ux, double* uy, double* uz, int* capsule);

  const SingleLayerPlan& single_layer() const { return single_; }
  bool solves_interface_velocity() const { return double_layer_ != nullptr; }
  const GmresResult& last_gmres() const { return last_; }
  // The last solve did not converge although its right-hand side was finite: the solve's failure, not the data's.
  bool solve_failed() const;
  // Why (naming the key: the cap, or the most extreme viscosity ratio).
  std::string solve_failure() const;
  // The last solve's whole answer ([x..., y..., z...]; empty before one) and the viscosity ratio per capsule.
  const std::vector<double>& interface_velocity() const { return guess_; }
  const std::vector<double>& lambda() const { return lambda_; }

  // Snapshot pieces: the guess of the solve at these positions (evaluated: the one it used; otherwise the one it
  // will use at strain t) and the answer before it; restore() makes the next solve start from the stored guess.
  void save(SimulationSnapshot& st, bool evaluated, double t) const;
  void restore(const SimulationSnapshot& st, std::size_t nodes);

 private:
  // Viscosity ratio != 1: u from ((1 + lambda)/2) u - K~[(1 - lambda) u] = u_inf + S[f] (in u on entry).
  void solve_interface_velocity(CapsuleState& s, StepWorkspace& ws, NodeVectors u, double t,
                                SimulationTimings& timings);
  void normal_motion_of_drops(CapsuleState& s, StepWorkspace& ws, NodeVectors u, NodeVectors w);
  void project(CapsuleState& s, StepWorkspace& ws, NodeVectors u, NodeVectors w);
  // The first guess of a solve at strain t into x (3 n): false when there is none (the solve starts from its
  // right-hand side).
  bool first_guess(double t, std::vector<double>& x) const;
  // velocities_at's pieces: the capsule holding each point; the double layer's share, the inside's 1 / lambda.
  void capsule_of_points(DoubleLayerPlan& dl, std::size_t nv, std::size_t nt, const double* tx, const double* ty,
                         const double* tz, const int* target_node, int* capsule);
  void add_double_layer_at(std::size_t nv, std::size_t nt, const double* tx, const double* ty, const double* tz,
                           const int* target_node, const int* capsule, double* ux, double* uy, double* uz);

  const Config* cfg_ = nullptr;
  SingleLayerPlan single_;
  std::unique_ptr<DoubleLayerPlan> double_layer_;  // only with a viscosity ratio != 1
  bool has_drops_ = false;                         // some capsule has law = "surface-tension"
  std::size_t nodes_ = 0;
  std::vector<double> lambda_;                     // viscosity ratio per capsule
  GmresResult last_;
  std::vector<double> dl_q_[3], dl_k_[3], b_, x_;
  // First guesses of the interface solve (docs/method.md 3.1): the last three answers, extrapolated quadratically in
  // time (linearly while there are two).
  std::vector<double> guess_;          // the last solve's answer (blocked x, y, z)
  double guess_time_ = 0.0;            // its strain
  std::vector<double> prev_answer_;    // the answer before it (empty: none yet)
  double prev_answer_time_ = 0.0;
  std::vector<double> prev2_answer_;   // the answer before that (empty: none yet)
  double prev2_answer_time_ = 0.0;
  RigidMotionPreconditioner precond_;  // [gmres] preconditioner = "rigid"
  std::vector<double> y_, my_;         // the preconditioned unknown M^-1 u and M applied to a Krylov vector
  std::vector<double> forced_guess_;   // a restored checkpoint's guess for its first solve (then empty)
  std::vector<double> used_guess_;     // the guess the last solve started from
};

}  // namespace capsflow
