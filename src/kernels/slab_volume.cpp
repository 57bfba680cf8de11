// The implementation of slab_volume.hpp: the exact volume of a capsule below a plane, and per-slab volumes.
#include "kernels/slab_volume.hpp"

namespace capsflow {

void capsules_volume_below(int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                           const double* z, double c, double* below) {
  for (long k = 0; k < ncap; ++k) below[k] = capsule_volume_below(ntri, tri, x + k * nv, y + k * nv, z + k * nv, c);
}

void species_slab_volumes(int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                          const double* z, const int* slot, double H, int nbins, double* out) {
  for (long k = 0; k < ncap; ++k)
    capsule_slab_volumes(nv, ntri, tri, x + k * nv, y + k * nv, z + k * nv, H, nbins,
                         out + static_cast<long>(slot[k]) * nbins);
}

}  // namespace capsflow
