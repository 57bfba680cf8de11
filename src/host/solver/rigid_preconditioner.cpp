// The implementation of rigid_preconditioner.hpp: the rigid-motion preconditioner of the interface-velocity equation.
#include "host/solver/rigid_preconditioner.hpp"

#include <cmath>
#include <stdexcept>

namespace capsflow {

void RigidMotionPreconditioner::set_geometry(int ncap, int nv, const double* x, const double* y, const double* z,
                                             const std::vector<double>& lambda) {
  if (ncap < 0 || nv < 1 || lambda.size() != static_cast<std::size_t>(ncap))
    throw std::invalid_argument("RigidMotionPreconditioner: one viscosity ratio per capsule");
  ncap_ = ncap;
  nv_ = nv;
  const std::size_t L = 3 * static_cast<std::size_t>(nv);
  basis_.assign(static_cast<std::size_t>(ncap) * 6 * L, 0.0);
  rest_.assign(static_cast<std::size_t>(ncap), 1.0);
  for (int k = 0; k < ncap; ++k) {
    rest_[k] = 2.0 / (1.0 + lambda[k]);
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double cx = 0.0, cy = 0.0, cz = 0.0;
    for (int a = 0; a < nv; ++a) {
      cx += x[o + a];
      cy += y[o + a];
      cz += z[o + a];
    }
    cx /= nv;
    cy /= nv;
    cz /= nv;
    double* q = &basis_[static_cast<std::size_t>(k) * 6 * L];
    // Translations e_c, then rotations e_c x (r - centroid): orthogonal to the translations (the centroid is the
    // nodes' mean), orthogonalized among themselves (twice: modified Gram-Schmidt loses little on 3 vectors, but
    // repeating costs nothing here).
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < nv; ++a) q[c * L + c * nv + a] = 1.0;
    for (int a = 0; a < nv; ++a) {
      const double rx = x[o + a] - cx, ry = y[o + a] - cy, rz = z[o + a] - cz;
      q[3 * L + 1 * nv + a] = -rz;  // e_x x r = (0, -rz, ry)
      q[3 * L + 2 * nv + a] = ry;
      q[4 * L + 0 * nv + a] = rz;  // e_y x r = (rz, 0, -rx)
      q[4 * L + 2 * nv + a] = -rx;
      q[5 * L + 0 * nv + a] = -ry;  // e_z x r = (-ry, rx, 0)
      q[5 * L + 1 * nv + a] = rx;
    }
    for (int j = 0; j < 6; ++j) {
      double* v = q + j * L;
      for (int pass = 0; pass < 2; ++pass)
        for (int i = 0; i < j; ++i) {
          const double* u = q + i * L;
          double d = 0.0;
          for (std::size_t t = 0; t < L; ++t) d += u[t] * v[t];
          for (std::size_t t = 0; t < L; ++t) v[t] -= d * u[t];
        }
      double nn = 0.0;
      for (std::size_t t = 0; t < L; ++t) nn += v[t] * v[t];
      nn = std::sqrt(nn);
      if (!(nn > 0.0)) throw std::invalid_argument("RigidMotionPreconditioner: a capsule with no extent");
      for (std::size_t t = 0; t < L; ++t) v[t] /= nn;
    }
  }
}

void RigidMotionPreconditioner::apply(const double* in, double* out, bool inverse) const {
  const std::size_t n = static_cast<std::size_t>(ncap_) * nv_, L = 3 * static_cast<std::size_t>(nv_);
  for (int k = 0; k < ncap_; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv_;
    const double* q = &basis_[static_cast<std::size_t>(k) * 6 * L];
    // M = r (I - P) + P, M^-1 = (1/r)(I - P) + P, P the projector on the capsule's rigid motions.
    const double r = inverse ? 1.0 / rest_[k] : rest_[k];
    double d[6];
    for (int j = 0; j < 6; ++j) {
      double s = 0.0;
      for (int c = 0; c < 3; ++c)
        for (int a = 0; a < nv_; ++a) s += q[j * L + c * nv_ + a] * in[c * n + o + a];
      d[j] = s;
    }
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < nv_; ++a) {
        double p = 0.0;
        for (int j = 0; j < 6; ++j) p += d[j] * q[j * L + c * nv_ + a];
        const double v = in[c * n + o + a];
        out[c * n + o + a] = r * (v - p) + p;
      }
  }
}

}  // namespace capsflow
