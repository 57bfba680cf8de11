#pragma once
// A right preconditioner for the interface-velocity equation A u = ((1 + lambda)/2) u - (1 - lambda) K~[u] = b of a
// viscosity ratio other than 1 (docs/method.md 3.1). On a closed surface a rigid motion U + Omega x r is an
// eigenfunction of the double layer with eigenvalue -1/2, so A maps it to itself (eigenvalue 1), while A's other
// modes gather around (1 + lambda)/2 (the straining modes of a sphere at (2 lambda + 3)/5, for instance): at
// lambda 5 the spectrum spans [1, ~5] and GMRES gains only ~2.5x per application. M scales each capsule's rigid
// motions by 1 and the rest by 2/(1 + lambda), so that A M has its spectrum around 1 (docs/performance.md 15).
// GMRES then solves A M y = b, u = M y: the residual it tests is still |b - A u|, so the answer's tolerance, and
// the equation, are unchanged; only the applications needed fall.
#include <cstddef>
#include <vector>

namespace capsflow {

class RigidMotionPreconditioner {
 public:
  // Capsule k owns nodes [k nv, (k + 1) nv) of x, y, z; lambda[k] its viscosity ratio. The rigid motions about the
  // capsule's node centroid, orthonormal in the Euclidean product of the 3 nv components.
  void set_geometry(int ncap, int nv, const double* x, const double* y, const double* z,
                    const std::vector<double>& lambda);
  // out = M in, or M^-1 in (inverse); vectors blocked [x..., y..., z...] of 3 ncap nv values; in != out.
  void apply(const double* in, double* out, bool inverse) const;
  std::size_t size() const { return 3 * static_cast<std::size_t>(ncap_) * nv_; }

 private:
  int ncap_ = 0, nv_ = 0;
  std::vector<double> basis_;  // per capsule 6 unit vectors of 3 nv values ([x..., y..., z...] of its nodes)
  std::vector<double> rest_;   // per capsule: M's factor off the rigid motions, 2/(1 + lambda)
};

}  // namespace capsflow
