#pragma once
// The converged reference of the element rules: every order raised well past the defaults (QuadratureOrders), the
// far band by a tensor rule instead of the 7-point one, the near-singular panels halved. `extra` raises every order
// further (a reference for the reference).
#include "kernels/element_quadrature.hpp"

namespace capsflow::test {

inline QuadratureOrders raised_quadrature_orders(int extra = 0) {
  QuadratureOrders q;
  q.singular = 12 + extra;
  q.far_dunavant = false;
  q.regular_far = 12 + extra;
  q.regular_mid = 14 + extra;
  q.regular_near = 18 + extra;
  q.near_angle = 14 + extra;
  q.near_radial = 14 + extra;
  q.near_panel = 1.0;
  return q;
}

}  // namespace capsflow::test
