#pragma once
// Per-mode Chebyshev-tau solves of the slit Stokes problem on the device (SlitStokesPlanDevice; the CPU reference is
// SlitStokesPlan::solve_modes, docs/method.md "Global part"), in three target regions:
//   1. the DCT-I along y as an explicit (N+1) x (N+1) matrix product, one thread per (field, degree, mode) (adjacent
//      threads read adjacent modes of a plane: coalesced), the spectra -> Chebyshev coefficients;
//   2. one thread per Fourier mode: the pressure and three velocity tau solves sharing one factorisation, the
//      influence-matrix correction with the cached homogeneous solutions, the k = 0 mode (mode_solve.hpp's flat bodies
//      with DeviceComplex; per-mode scratch from the caller, no allocation inside target regions);
//   3. the inverse DCT-I, one thread per (field, plane, mode), the coefficients -> the spectra.
// The same operations in the same order as the reference per coefficient, apart from FFTW's DCT algorithm.
#include <cstddef>

#include "kernels/backend.hpp"

namespace capsflow {

struct SlitModeGrid {
  int nx = 0, nz = 0, N = 0;  // Fourier points, Chebyshev degree
  double H = 0.0, Lx = 0.0, Lz = 0.0;
};

// Doubles of per-mode scratch (complex work columns and the tau factors) for Chebyshev degree N.
std::size_t slit_mode_scratch_doubles(int N);

// The DCT-I (FFTW's REDFT00) as a matrix, (N+1) x (N+1), row k: D[k (N+1) + j] = w_j cos(pi j k / N) with w_j = 1 at
// j = 0, N and 2 inside (the argument reduced exactly: j k mod 2N). Symmetric up to the weights; the inverse
// transform of the solve uses the same matrix.
void dct1_matrix(int N, double* D);

// Solves every mode of the spectra in place. All arrays must be present on the default device (mapped by the caller
// for the plan's lifetime; the map clauses here then copy nothing):
//   spec:  3 fields x (N+1) planes x nx (nz/2+1) modes, complex interleaved (as doubles);
//   coef:  the same size, work array (the Chebyshev coefficients between the kernels);
//   wspec: 6 wall maps (side * 3 + component) x nx (nz/2+1) modes, complex interleaved;
//   hom_phi, hom_psi: (nx/2+1) (nz/2+1) x (N+1); hom_minv: (nx/2+1) (nz/2+1) x 4 (SlitStokesPlan's cache);
//   dct: dct1_matrix(N).
// scratch: device memory (omp_target_alloc) of chunk * slit_mode_scratch_doubles(N) doubles; the modes are solved in
// launches of at most `chunk` modes.
void slit_solve_modes_device(const SlitModeGrid& g, double* spec, double* coef, const double* wspec,
                             const double* hom_phi, const double* hom_psi, const double* hom_minv, const double* dct,
                             double* scratch, std::size_t chunk);

}  // namespace capsflow
