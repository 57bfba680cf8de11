#pragma once
// The slit and its GGEM grid as values (docs/method.md §1; decision D9): the geometry (H, Lx, Lz, mu), the options of
// [ggem], and the grid they resolve to. Only values and their checks live here, so the configuration, both global
// solve plans and the velocity operator can depend on them without depending on each other (the plans used to
// include ggem_solver.hpp for these two types: a dependency from a lower floor back up to its client).
#include <string>

namespace capsflow {

struct SlitGeometry {
  double H = 0.0;          // wall-to-wall distance (walls at y = 0 and y = H)
  double Lx = 0.0;         // period in x
  double Lz = 0.0;         // period in z
  double viscosity = 1.0;  // mu
};

struct GgemOptions {
  double alpha = 4.0;      // splitting parameter (1/length)
  double alpha_hm = 0.5;   // alpha * h_m: grid spacing h_m = alpha_hm / alpha in x and z
  int nx = 0;              // Fourier points in x (0: from h_m, rounded up to a fast FFT size)
  int nz = 0;              // Fourier points in z (0: likewise)
  int ny = 0;              // Chebyshev degree N (N + 1 Gauss-Lobatto points); 0: from chebyshev_rule
  double cutoff = 0.0;     // local cutoff r_c of the G_l sum (0: default_cutoff(alpha)); not the clouds' truncation
  // How N follows when ny = 0 (decision D9): "midchannel" (default) N >= pi alpha H, so the mid-channel
  // spacing is at most h_m; "mean" N >= H / h_m, equal mean spacing in all directions (the paper's choice).
  std::string chebyshev_rule = "midchannel";
  // [ggem] tolerance (0: not given). The accuracy asked of the splitting against the exact slit Green's function;
  // alpha_hm and cutoff not given explicitly follow from it (ggem_alpha_hm_for / ggem_cutoff_alpha_for), and the
  // Chebyshev degree follows alpha_hm. Kept for the record: the resolved alpha_hm and cutoff are what a run uses.
  double tolerance = 0.0;
};

// The local cutoff when none is given: 3.5 / alpha, where G_l is 2e-5 of the Stokeslet; the sum over the sources
// beyond it moves the velocity by < 1e-6 of its scale (docs/method.md, figures in docs/performance.md section 6).
inline double default_cutoff(double alpha) { return 3.5 / alpha; }
// The smallest [ggem] cutoff accepted, in units of 1 / alpha (erfc(2) ~ 0.005 of the kernel left out at it).
inline constexpr double kMinCutoffAlpha = 2.0;

// [ggem] tolerance -> parameters (docs/method.md "GGEM's accuracy"; the fits in docs/performance.md section 13).
// The largest error of a point force's velocity against the exact slit Green's function is, measured over forces
// parallel and normal to the walls at 0.4 to 2 from a wall and targets 0.3 to 3.6 away, at most
//   E_grid(alpha h_m)    ~ 0.12 exp(-1.15 / (alpha h_m)^2)   (sampling the Gaussian clouds; the Chebyshev degree follows h_m)
//   E_cut(alpha r_c)     ~ 6.2 exp(-0.91 (alpha r_c)^2)      (the screened kernel left out beyond r_c)
// and the tolerance is split evenly between the two. alpha itself is not changed: it is the fastest of 3, 4 and 5
// on set A and a larger alpha raises the surface quadrature error of the split (section 13).
inline constexpr double kMinGgemTolerance = 1e-4;  // below it the clouds' truncation and the Chebyshev rule leave ~2e-5
inline constexpr double kMaxGgemTolerance = 2e-2;
double ggem_alpha_hm_for(double tolerance);     // alpha h_m meeting E_grid <= tolerance / 2
double ggem_cutoff_alpha_for(double tolerance); // alpha r_c meeting E_cut <= tolerance / 2
// o with its tolerance set and the alpha_hm and cutoff (at o.alpha) that the tolerance picks: what [ggem] tolerance
// makes of the options when neither key is given (the configuration reader, the benchmark and the test use it).
GgemOptions with_ggem_tolerance(GgemOptions o, double tolerance);

// The truncation radius of the Gaussian clouds (spreading), independent of the local cutoff: 4 / alpha, where the
// cloud is 6e-7 of its peak. Truncating the clouds at 3.5 / alpha costs accuracy (docs/performance.md section 6).
inline double default_spread_cutoff(double alpha) { return 4.0 / alpha; }

// The grid a GgemOptions resolves to for a geometry.
struct GgemGrid {
  int nx = 0, nz = 0;  // Fourier points
  int ny = 0;          // Chebyshev degree N; points j = 0..N at y_j = (H/2)(1 - cos(pi j / N)) (y_0 = 0)
  double hx = 0.0, hz = 0.0;
  double alpha = 0.0;
  double cutoff = 0.0;         // local cutoff r_c (the G_l sums, cell lists, box checks)
  double spread_cutoff = 0.0;  // truncation radius of the Gaussian clouds (default_spread_cutoff(alpha))
};

// Resolves and validates (throws InputError naming the [domain]/[ggem] key and what was expected).
GgemGrid resolve_ggem_grid(const SlitGeometry& geo, const GgemOptions& opt);

// The most grid points along one direction (nx, nz, or the Chebyshev N). Far beyond any grid that fits in memory
// (the memory check refuses those), low enough that the sizes and their products stay exact in int / size_t.
inline constexpr double kMaxGridPointsPerDirection = 1 << 20;

// Empty when the grid that `geo` and `opt` ask for has at most kMaxGridPointsPerDirection points along each
// direction; otherwise "<key>: <why>, expected ..." naming the key to change ("[ggem] alpha", "[domain] Lx", ...).
// resolve_ggem_grid throws it as an InputError; parse_config prefixes the file name.
std::string ggem_grid_size_error(const SlitGeometry& geo, const GgemOptions& opt);

}  // namespace capsflow
