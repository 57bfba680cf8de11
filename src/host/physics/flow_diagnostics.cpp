// The implementation of flow_diagnostics.hpp: flow rate, relative viscosity, profiles, the step tally.
#include "host/physics/flow_diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/slab_volume.hpp"

namespace capsflow {

FlowDiagnostics flow_diagnostics(const CapsuleState& s, const Config& cfg, const std::vector<double>& interface_velocity,
                                 const std::vector<double>& lambda) {
  // Plane-averaged (k = 0) disturbance of a force F_x at height h between fixed walls (docs/validation.md, VD 5):
  // u'(y) = F_x/(mu A) y (H - h)/H below, F_x/(mu A) h (H - y)/H above. Its flux is F_x h (H - h) / (2 mu A) and
  // the wall shear stress it adds is -F_x h / (A H) (force-free capsules: sum F_x = 0). The density f is linear
  // on each flat element, as the single layer integrates it: int_T f g dA with g = y or y (H - y) is exact with
  // int lambda_i lambda_j lambda_k dA = 2A i!j!k!-multiplicities / 5! (A/10, A/30, A/60).
  FlowDiagnostics d;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  d.flow_rate_ratio = nan;
  d.relative_viscosity = nan;
  if (cfg.flow.type == FlowType::None) return d;
  const double H = cfg.domain.H, A = cfg.domain.Lx * cfg.domain.Lz, mu = cfg.domain.viscosity;
  const double gd = cfg.flow.shear_rate;
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  double m1 = 0.0, m2 = 0.0;  // sum int f_x y dA, sum int f_x y (H - y) dA
  const std::size_t n = s.x.size();
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    const double dl = lambda.empty() ? 0.0 : 1.0 - lambda[static_cast<std::size_t>(k)];
    const bool double_layer = dl != 0.0 && interface_velocity.size() == 3 * n;
    // The node mean p: the interior's flux below is taken about it (translation-invariant when the discrete
    // oint u.n is not exactly zero, as the capsule velocity U of capsule_velocity_moments).
    double px = 0.0;
    if (double_layer) {
      for (int i = 0; i < nv; ++i) px += s.x[o + static_cast<std::size_t>(i)];
      px /= nv;
    }
    double inner = 0.0;  // int_V u_x dV = oint (x - p_x)(u.n) dS of this capsule
    for (int e = 0; e < nt; ++e) {
      const std::size_t v[3] = {o + tri[3 * e], o + tri[3 * e + 1], o + tri[3 * e + 2]};
      const double ax = s.x[v[1]] - s.x[v[0]], ay = s.y[v[1]] - s.y[v[0]], az = s.z[v[1]] - s.z[v[0]];
      const double bx = s.x[v[2]] - s.x[v[0]], by = s.y[v[2]] - s.y[v[0]], bz = s.z[v[2]] - s.z[v[0]];
      const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
      const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
      const double f[3] = {s.fx[v[0]], s.fx[v[1]], s.fx[v[2]]};
      const double y[3] = {s.y[v[0]], s.y[v[1]], s.y[v[2]]};
      double fy = 0.0, fyy = 0.0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          fy += f[i] * y[j] * (i == j ? area / 6.0 : area / 12.0);
          for (int l = 0; l < 3; ++l) {
            const double w = (i == j && j == l) ? area / 10.0 : (i != j && j != l && i != l) ? area / 60.0
                                                                                               : area / 30.0;
            fyy += f[i] * y[j] * y[l] * w;
          }
        }
      m1 += fy;
      m2 += H * fy - fyy;
      // The double layer of (1 - lambda) u is a force dipole mu (1 - lambda) (u n + n u) dS per element (plus mass
      // sources, which drive no plane-averaged x flow; docs/method.md 3.1, 4.5). A dipole D_xy at height h adds D_xy
      // to M_1 and D_xy (H - 2 h) to M_2 (the limit of two opposite forces); u linear on the element, n constant:
      // D_xy = mu (1 - lambda) (n_y int u_x + n_x int u_y), and int u y dA by the same exact weights as above.
      if (double_layer) {
        const double nx = cx / (2.0 * area), ny = cy / (2.0 * area), nz = cz / (2.0 * area);
        double q0 = 0.0, q1 = 0.0;  // int (n_y u_x + n_x u_y) dA and int (n_y u_x + n_x u_y) y dA
        for (int i = 0; i < 3; ++i) {
          const double ux = interface_velocity[v[i]], uy = interface_velocity[n + v[i]];
          const double qi = ny * ux + nx * uy;
          const double un = nx * ux + ny * uy + nz * interface_velocity[2 * n + v[i]];
          q0 += qi * area / 3.0;
          for (int j = 0; j < 3; ++j) {
            const double w = i == j ? area / 6.0 : area / 12.0;
            q1 += qi * y[j] * w;
            inner += un * (s.x[v[j]] - px) * w;
          }
        }
        m1 += mu * dl * q0;
        m2 += mu * dl * (H * q0 - 2.0 * q1);
      }
    }
    // The representation u_inf + S[f] + (1 - lambda) K[u] is u outside a capsule but lambda u inside it (the
    // interface equation is its limit on the surface, (1 + lambda)/2 u), and the moments above give the flux of that
    // field. A cross-section's flux counts the inner fluid's velocity with weight 1: add (1 - lambda) int_V u_x dV / A
    // to Q, i.e. 2 mu (1 - lambda) int_V u_x dV to M_2 (docs/method.md 4.5). The walls lie outside every capsule, so
    // the wall stress (M_1) needs nothing.
    if (double_layer) m2 += 2.0 * mu * dl * inner;
  }
  if (cfg.flow.type == FlowType::Poiseuille) d.flow_rate_ratio = 1.0 + 3.0 * m2 / (mu * A * gd * H * H);
  if (cfg.flow.type == FlowType::Shear) d.relative_viscosity = 1.0 - m1 / (mu * gd * A * H);
  return d;
}

std::vector<double> species_profile(const CapsuleState& s, const Config& cfg, int bins) {
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule();
  const int nt = s.triangles_per_capsule();
  const std::size_t nb = static_cast<std::size_t>(bins);
  std::vector<double> out(cfg.species.size() * nb, 0.0);
  for (int k = 0; k < nc; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double* row = out.data() + static_cast<std::size_t>(s.species_of(k)) * nb;
    capsule_slab_volumes(nv, nt, s.mesh().tri.data(), &s.x[o], &s.y[o], &s.z[o], cfg.domain.H, bins, row);
  }
  return out;
}

void RecordTally::count(const StepInfo& info, const GmresResult* solve) {
  max_ratio = std::max(max_ratio, info.ratio);
  ++limits[static_cast<std::size_t>(info.limit)];
  // The solve at x^n counts with the step it served, not when it ran: a checkpoint of an evaluated state leaves it
  // out, and the continued run, which solves x^n again, counts it once (restarts keep the GMRES record's bits).
  if (solve) gmres.add(*solve);
}

void RecordTally::save(SimulationSnapshot& st) const {
  st.max_step_ratio_since_record = max_ratio;
  st.gmres_steps_since_record = gmres.steps;
  st.gmres_iterations_since_record = gmres.iterations;
  st.gmres_max_iterations_since_record = gmres.max_iterations;
  st.gmres_max_residual_since_record = gmres.max_residual;
  st.step_limits_since_record.assign(limits.begin(), limits.end());
}

void RecordTally::restore(const SimulationSnapshot& st) {
  max_ratio = st.max_step_ratio_since_record;
  gmres.steps = st.gmres_steps_since_record;
  gmres.iterations = st.gmres_iterations_since_record;
  gmres.max_iterations = st.gmres_max_iterations_since_record;
  gmres.max_residual = st.gmres_max_residual_since_record;
  if (st.step_limits_since_record.size() == limits.size())
    for (std::size_t i = 0; i < limits.size(); ++i) limits[i] = st.step_limits_since_record[i];
}

}  // namespace capsflow
