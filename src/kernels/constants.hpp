#pragma once
// The numbers and the periodic minimum image that every kernel (and, through them, the host) shares: one home each
// (architecture review R5). Plain scalar code: these run inside OpenMP target regions. The host wings that may
// include only base (analysis) reach pi through host/base/math_constants.hpp, which includes this file.
#include <cmath>

#include "kernels/device_macros.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN

constexpr double kPi = 3.14159265358979323846;
constexpr double kSqrtPi = 1.77245385090551602730;

// Minimum-image displacement d - L round(d / L) in a periodic direction of length L, rounding ties to even
// (std::nearbyint): the form of the cell searches, the contact directions and the point-force local sum.
inline double min_image(double d, double L) { return d - L * std::nearbyint(d / L); }

// The same displacement without a libm call (std::nearbyint is not inlined on baseline x86-64), for the hot
// element traversals of the local single and double layers, which hand in 1 / L. It rounds half away from zero and
// scales by inv_L, so it can differ from min_image only within an ulp of |d| = L / 2, far outside the traversals'
// reach (cutoff + element radius < L / 2). Kept apart so neither caller's bits change.
inline double min_image_fast(double d, double L, double inv_L) {
  const double s = d * inv_L;
  return d - L * static_cast<double>(static_cast<long long>(s + std::copysign(0.5, s)));
}

CAPSFLOW_DEVICE_END

}  // namespace capsflow
