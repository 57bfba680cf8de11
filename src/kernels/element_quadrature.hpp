#pragma once
// Element integrals of the local single-layer potential over flat linear triangles (docs/method_quadrature.md, D4, P6).
//
// Computed quantity, without the 1/(8 pi mu) factor:
//     I(x) = \int_e G(x - y) . f(y) dS_y,   f linear on e from its three nodal values,
// for G = G_l (GGEM local kernel, element_single_layer_add) or the free-space Stokeslet (element_stokeslet_add; tests
// and diagnostics). The result is ADDED to u.
//
// Element classes (h_e = longest edge, d = distance from x to the closest point of the element):
//   singular      x is vertex k of e: Gauss-Legendre in polar coordinates about that vertex in the parametric plane
//                 (docs/method_quadrature.md), n x n; the Jacobian rho cancels the 1/r singularity. Loses accuracy for
//                 vertex angles near 180 degrees (4e-2 at 6x6 on a sliver); singular_method = VertexPolar uses the
//                 near-singular projection rule with the target on the vertex instead (robust, 72-144 evaluations).
//   near-singular d/h_e < near_ratio: split the element at the projection p of x onto its plane into right triangles
//                 (p, foot of the perpendicular on an edge line, edge vertex), signed so that projections outside the
//                 element and targets in the plane work; each right triangle in polar coordinates about p with two
//                 smoothing substitutions that make the integrand analytic with poles at distance pi/2 from the real
//                 axis, uniformly in the height h and the distance to the edge delta:
//                     radial  rho = h sinh(s)          (absorbs the 1/r near-singularity; plain Gauss when h ~ 0)
//                     angle   tan(theta) = sinh(t)     (the position along the edge is delta sinh(t))
//                 Both transformed intervals are cut into panels of length <= near_panel, near_angle x near_radial
//                 Gauss points per panel pair. Alternative (near_method = Subdivision): 4-way subdivision until
//                 d/h_sub >= subdivision_ratio (or max_depth), leaves by the regular rules.
//   regular       Collapsed (Duffy) tensor Gauss-Legendre rule (docs/method_quadrature.md), order chosen by d/h_e, or
//                 the symmetric 16-point degree-8 rule (S16) on symmetric_ratio <= d/h_e < far_ratio, the symmetric
//                 7-point degree-5 rule (Dunavant) beyond far_ratio.
// Default orders and thresholds come from the measurements in tests/test_element_quadrature.cpp, summarised in
// docs/method_quadrature.md; they aim at ~1e-6 relative element error for alpha h_e <~ 1.2 (0.3a elements, alpha = 4).
//
// Conventions: the element vertices are already UNWRAPPED relative to the target (the caller applies minimum images to
// y - x before calling, e.g. v = x + min_image(v_raw - x)); nothing here knows about periodicity.
// v = {x0,y0,z0, x1,y1,z1, x2,y2,z2}, f = {f0x,f0y,f0z, f1x,...}. For a singular element pass singular_vertex = k and
// xt equal to vertex k; -1 means "x is not a vertex of e" and the class is chosen from the geometry (a target that is
// a vertex but passed with -1 still works: it goes through the near-singular path at about 3x the cost). Degenerate
// elements (twice area <= 1e-14 h_e^2) add nothing.
//
// Plain scalar code over raw doubles (no allocation, no exceptions, no virtual calls): callable inside OpenMP target
// regions. The kernel is a template parameter with a member add(rx, ry, rz, fx, fy, fz, ux, uy, uz) that adds G(r).f.
//
// Usage (one target node x, its neighbour elements e, vertices already unwrapped about x):
//     const QuadratureOrders q;                       // or from the configuration (all fields documented below)
//     double u[3] = {0, 0, 0};
//     for (each element e within r_c)  element_single_layer_add(alpha, x, v_e, f_e, vertex_of(x, e) /*or -1*/, q, u);
//     velocity += u / (8 pi mu);
//
// References: Duffy, SIAM J. Numer. Anal. 19 (1982) (collapsed coordinates); Dunavant, IJNME 21 (1985) (7-point
// rule); Johnston & Elliott, IJNME 62 (2005) and Johnston, Johnston & Elliott, IJNME 69 (2007) (sinh transformations
// for nearly singular integrals). Measurements: docs/method_quadrature.md.
#include <cmath>

#include "kernels/device_macros.hpp"
#include "kernels/ggem_kernels.hpp"

// Host builds on x86-64 without the device backend: the collapsed Gauss rule for G_l evaluates two points at a time
// with SSE2 (duffy_add(const LocalKernel&, ...)). Not in offload builds: GCC streams the declare-target code to the
// nvptx compiler, which has no x86 intrinsics.
#if defined(__SSE2__) && !defined(CAPSFLOW_HAVE_OFFLOAD)
#define CAPSFLOW_SSE2_LOCAL_DUFFY 1
#include <emmintrin.h>
#endif

namespace capsflow {

// Near-singular treatment (QuadratureOrders::near_method).
enum class NearSingularMethod : int {
  Projection = 0,   // split at the projection of x, polar with sinh substitutions (default: accurate for any gap)
  Subdivision = 1,  // adaptive 4-way subdivision; for comparison: measured up to 40x the evaluations of Projection and
                    // less accurate (to 8e-5 for targets in the plane, limited by max_depth)
};

// Which near-singular rules an element integral is compiled with. Any: the run-time choice (QuadratureOrders::
// near_method), as every host path does. A device region inlines every rule it may call, and the subdivision rule's
// explicit stack (3.3 KB a thread) made most of the local sums' 4.7 KB frame, so each device entry makes one region per
// rule and picks it on the host (docs/device.md, "What the device compilers make of the kernels"); the rule that runs
// is the same, so are the bits.
enum class NearRules : int { Any, Projection, Subdivision };

// Singular treatment (QuadratureOrders::singular_method).
enum class SingularMethod : int {
  Parametric = 0,   // docs/method_quadrature.md: polar about the vertex in the parametric (xi, eta) plane (D4 default)
  VertexPolar = 1,  // polar about the vertex in the element plane, split at the foot of the perpendicular on the
                    // opposite edge, angle mapped by tan(theta) = sinh(t): robust for vertex angles near 180 degrees
};

// All orders and thresholds of the element integrals (D4). Plain struct: copy it into target regions by value.
struct QuadratureOrders {
  int singular = 6;            // singular elements: n x n polar Gauss rule about the vertex (D4; ~2e-6, 8: ~2e-8)
  SingularMethod singular_method = SingularMethod::Parametric;  // see docs/method_quadrature.md: distorted elements
  double far_ratio = 2.5;      // d/h_e >= far_ratio: far rule
  bool far_dunavant = true;    // far rule: 7-point degree-5 symmetric rule if true, else regular_far x regular_far
  double symmetric_ratio = 1.5;  // symmetric_ratio <= d/h_e < far_ratio: 16-point degree-8 symmetric rule (S16, from
                                 // 1.5: 2.1e-7 of |I_S| there, docs/method_quadrature.md); >= far_ratio: off
  int regular_far = 6;         // collapsed Gauss order for d/h_e >= far_ratio when far_dunavant is false
  double mid_ratio = 0.75;     // mid_ratio <= d/h_e < outer_ratio: regular_mid
  int regular_mid = 7;         // collapsed Gauss order, 0.75 <= d/h_e < 1.5
  double outer_ratio = 1.5;    // outer_ratio <= d/h_e < symmetric_ratio: regular_outer (screened: judged on |I_S|);
                               // off by default (outer_ratio = symmetric_ratio: S16 from 1.5)
  int regular_outer = 5;       // collapsed Gauss order on the outer band when it is switched on
  int regular_near = 10;       // collapsed Gauss order, near_ratio <= d/h_e < mid_ratio
  double near_ratio = 0.5;     // d/h_e < near_ratio: near-singular treatment
  NearSingularMethod near_method = NearSingularMethod::Projection;
  int near_angle = 8;          // Projection: Gauss points per angular panel (in t, tan(theta) = sinh t)
  int near_radial = 8;         // Projection: Gauss points per radial panel (in s, rho = h sinh s)
  double near_panel = 2.0;     // Projection: longest panel in the transformed variables s and t
  double subdivision_ratio = 1.0;  // Subdivision: refine a sub-element while d/h_sub < subdivision_ratio
  int max_depth = 12;          // Subdivision: deepest refinement level (clamped to kMaxSubdivisionDepth)
  // Degree of the host AVX-512 evaluator's polynomials of G_l and W_l (local_single_layer.cpp): 17, the whole table
  // (~1e-15), or 9 (its first ten coefficients: 4e-7 of the Stokeslet; [ggem] tolerance's choice). The AVX2, scalar
  // and device evaluators use the 144-interval table whatever it is.
  int kernel_degree = 17;
};

CAPSFLOW_DEVICE_BEGIN

constexpr int kMaxGaussOrder = 20;
constexpr int kMaxSubdivisionDepth = 20;

// Gauss-Legendre nodes and weights on [-1, 1] for n = 1..kMaxGaussOrder, order n at offset n(n-1)/2, nodes ascending.
// Generated in long double by Newton iteration on the Legendre recurrence (checked in the tests against an independent
// computation and against exact moments).
inline constexpr double kGaussLegendreNodes[210] = {
    // n = 1
    0.0,
    // n = 2
    -0.57735026918962576, 0.57735026918962576,
    // n = 3
    -0.77459666924148338, 0.0, 0.77459666924148338,
    // n = 4
    -0.86113631159405258, -0.33998104358485626, 0.33998104358485626, 0.86113631159405258,
    // n = 5
    -0.90617984593866399, -0.53846931010568309, 0.0, 0.53846931010568309,
    0.90617984593866399,
    // n = 6
    -0.93246951420315203, -0.66120938646626451, -0.23861918608319691, 0.23861918608319691,
    0.66120938646626451, 0.93246951420315203,
    // n = 7
    -0.94910791234275852, -0.74153118559939444, -0.40584515137739717, 0.0,
    0.40584515137739717, 0.74153118559939444, 0.94910791234275852,
    // n = 8
    -0.96028985649753623, -0.79666647741362674, -0.52553240991632899, -0.1834346424956498,
    0.1834346424956498, 0.52553240991632899, 0.79666647741362674, 0.96028985649753623,
    // n = 9
    -0.96816023950762609, -0.83603110732663579, -0.6133714327005904, -0.32425342340380893,
    0.0, 0.32425342340380893, 0.6133714327005904, 0.83603110732663579,
    0.96816023950762609,
    // n = 10
    -0.97390652851717172, -0.86506336668898451, -0.67940956829902441, -0.43339539412924719,
    -0.14887433898163121, 0.14887433898163121, 0.43339539412924719, 0.67940956829902441,
    0.86506336668898451, 0.97390652851717172,
    // n = 11
    -0.97822865814605699, -0.8870625997680953, -0.73015200557404932, -0.51909612920681182,
    -0.26954315595234497, 0.0, 0.26954315595234497, 0.51909612920681182,
    0.73015200557404932, 0.8870625997680953, 0.97822865814605699,
    // n = 12
    -0.98156063424671925, -0.90411725637047486, -0.76990267419430469, -0.58731795428661745,
    -0.36783149899818019, -0.12523340851146892, 0.12523340851146892, 0.36783149899818019,
    0.58731795428661745, 0.76990267419430469, 0.90411725637047486, 0.98156063424671925,
    // n = 13
    -0.98418305471858815, -0.91759839922297797, -0.80157809073330991, -0.64234933944034022,
    -0.44849275103644685, -0.23045831595513479, 0.0, 0.23045831595513479,
    0.44849275103644685, 0.64234933944034022, 0.80157809073330991, 0.91759839922297797,
    0.98418305471858815,
    // n = 14
    -0.98628380869681234, -0.92843488366357352, -0.82720131506976499, -0.68729290481168547,
    -0.51524863635815409, -0.31911236892788976, -0.10805494870734366, 0.10805494870734366,
    0.31911236892788976, 0.51524863635815409, 0.68729290481168547, 0.82720131506976499,
    0.92843488366357352, 0.98628380869681234,
    // n = 15
    -0.98799251802048543, -0.9372733924007059, -0.84820658341042722, -0.72441773136017005,
    -0.57097217260853885, -0.39415134707756337, -0.20119409399743452, 0.0,
    0.20119409399743452, 0.39415134707756337, 0.57097217260853885, 0.72441773136017005,
    0.84820658341042722, 0.9372733924007059, 0.98799251802048543,
    // n = 16
    -0.98940093499164993, -0.94457502307323258, -0.86563120238783174, -0.75540440835500303,
    -0.61787624440264375, -0.45801677765722739, -0.28160355077925891, -0.09501250983763744,
    0.09501250983763744, 0.28160355077925891, 0.45801677765722739, 0.61787624440264375,
    0.75540440835500303, 0.86563120238783174, 0.94457502307323258, 0.98940093499164993,
    // n = 17
    -0.99057547531441734, -0.95067552176876776, -0.8802391537269859, -0.78151400389680141,
    -0.65767115921669077, -0.51269053708647697, -0.35123176345387632, -0.17848418149584786,
    0.0, 0.17848418149584786, 0.35123176345387632, 0.51269053708647697,
    0.65767115921669077, 0.78151400389680141, 0.8802391537269859, 0.95067552176876776,
    0.99057547531441734,
    // n = 18
    -0.99156516842093095, -0.95582394957139776, -0.89260246649755574, -0.80370495897252312,
    -0.69168704306035321, -0.55977083107394753, -0.41175116146284265, -0.25188622569150551,
    -0.084775013041735301, 0.084775013041735301, 0.25188622569150551, 0.41175116146284265,
    0.55977083107394753, 0.69168704306035321, 0.80370495897252312, 0.89260246649755574,
    0.95582394957139776, 0.99156516842093095,
    // n = 19
    -0.9924068438435844, -0.96020815213483003, -0.9031559036148179, -0.82271465653714282,
    -0.72096617733522938, -0.60054530466168102, -0.46457074137596095, -0.31656409996362983,
    -0.16035864564022538, 0.0, 0.16035864564022538, 0.31656409996362983,
    0.46457074137596095, 0.60054530466168102, 0.72096617733522938, 0.82271465653714282,
    0.9031559036148179, 0.96020815213483003, 0.9924068438435844,
    // n = 20
    -0.99312859918509492, -0.96397192727791379, -0.91223442825132591, -0.83911697182221882,
    -0.74633190646015079, -0.63605368072651503, -0.5108670019508271, -0.37370608871541956,
    -0.22778585114164508, -0.076526521133497334, 0.076526521133497334, 0.22778585114164508,
    0.37370608871541956, 0.5108670019508271, 0.63605368072651503, 0.74633190646015079,
    0.83911697182221882, 0.91223442825132591, 0.96397192727791379, 0.99312859918509492,
};

inline constexpr double kGaussLegendreWeights[210] = {
    // n = 1
    2.0,
    // n = 2
    1, 1,
    // n = 3
    0.55555555555555556, 0.88888888888888889, 0.55555555555555556,
    // n = 4
    0.34785484513745386, 0.65214515486254614, 0.65214515486254614, 0.34785484513745386,
    // n = 5
    0.23692688505618909, 0.47862867049936647, 0.56888888888888889, 0.47862867049936647,
    0.23692688505618909,
    // n = 6
    0.17132449237917034, 0.36076157304813861, 0.46791393457269105, 0.46791393457269105,
    0.36076157304813861, 0.17132449237917034,
    // n = 7
    0.12948496616886969, 0.27970539148927667, 0.38183005050511894, 0.41795918367346939,
    0.38183005050511894, 0.27970539148927667, 0.12948496616886969,
    // n = 8
    0.10122853629037626, 0.22238103445337447, 0.31370664587788729, 0.36268378337836198,
    0.36268378337836198, 0.31370664587788729, 0.22238103445337447, 0.10122853629037626,
    // n = 9
    0.081274388361574412, 0.1806481606948574, 0.26061069640293546, 0.31234707704000284,
    0.33023935500125976, 0.31234707704000284, 0.26061069640293546, 0.1806481606948574,
    0.081274388361574412,
    // n = 10
    0.066671344308688138, 0.14945134915058059, 0.21908636251598204, 0.26926671930999636,
    0.29552422471475287, 0.29552422471475287, 0.26926671930999636, 0.21908636251598204,
    0.14945134915058059, 0.066671344308688138,
    // n = 11
    0.055668567116173667, 0.12558036946490462, 0.18629021092773425, 0.23319376459199048,
    0.26280454451024666, 0.27292508677790063, 0.26280454451024666, 0.23319376459199048,
    0.18629021092773425, 0.12558036946490462, 0.055668567116173667,
    // n = 12
    0.047175336386511827, 0.10693932599531843, 0.16007832854334623, 0.20316742672306592,
    0.23349253653835481, 0.24914704581340278, 0.24914704581340278, 0.23349253653835481,
    0.20316742672306592, 0.16007832854334623, 0.10693932599531843, 0.047175336386511827,
    // n = 13
    0.04048400476531588, 0.092121499837728448, 0.13887351021978724, 0.17814598076194574,
    0.2078160475368885, 0.22628318026289724, 0.23255155323087391, 0.22628318026289724,
    0.2078160475368885, 0.17814598076194574, 0.13887351021978724, 0.092121499837728448,
    0.04048400476531588,
    // n = 14
    0.035119460331751863, 0.08015808715976021, 0.12151857068790318, 0.15720316715819353,
    0.18553839747793781, 0.2051984637212956, 0.21526385346315779, 0.21526385346315779,
    0.2051984637212956, 0.18553839747793781, 0.15720316715819353, 0.12151857068790318,
    0.08015808715976021, 0.035119460331751863,
    // n = 15
    0.030753241996117268, 0.070366047488108125, 0.10715922046717194, 0.13957067792615431,
    0.16626920581699393, 0.18616100001556221, 0.19843148532711158, 0.20257824192556127,
    0.19843148532711158, 0.18616100001556221, 0.16626920581699393, 0.13957067792615431,
    0.10715922046717194, 0.070366047488108125, 0.030753241996117268,
    // n = 16
    0.027152459411754095, 0.062253523938647893, 0.095158511682492785, 0.12462897125553387,
    0.14959598881657673, 0.16915651939500254, 0.18260341504492359, 0.1894506104550685,
    0.1894506104550685, 0.18260341504492359, 0.16915651939500254, 0.14959598881657673,
    0.12462897125553387, 0.095158511682492785, 0.062253523938647893, 0.027152459411754095,
    // n = 17
    0.024148302868547932, 0.055459529373987201, 0.085036148317179181, 0.11188384719340397,
    0.13513636846852547, 0.15404576107681029, 0.16800410215645004, 0.17656270536699265,
    0.17944647035620653, 0.17656270536699265, 0.16800410215645004, 0.15404576107681029,
    0.13513636846852547, 0.11188384719340397, 0.085036148317179181, 0.055459529373987201,
    0.024148302868547932,
    // n = 18
    0.02161601352648331, 0.049714548894969796, 0.076425730254889057, 0.10094204410628717,
    0.12255520671147846, 0.14064291467065065, 0.15468467512626524, 0.16427648374583272,
    0.16914238296314359, 0.16914238296314359, 0.16427648374583272, 0.15468467512626524,
    0.14064291467065065, 0.12255520671147846, 0.10094204410628717, 0.076425730254889057,
    0.049714548894969796, 0.02161601352648331,
    // n = 19
    0.019461788229726477, 0.0448142267656996, 0.069044542737641227, 0.091490021622449999,
    0.11156664554733399, 0.12875396253933623, 0.14260670217360661, 0.15276604206585967,
    0.15896884339395435, 0.1610544498487837, 0.15896884339395435, 0.15276604206585967,
    0.14260670217360661, 0.12875396253933623, 0.11156664554733399, 0.091490021622449999,
    0.069044542737641227, 0.0448142267656996, 0.019461788229726477,
    // n = 20
    0.017614007139152118, 0.040601429800386941, 0.062672048334109064, 0.083276741576704749,
    0.10193011981724044, 0.11819453196151842, 0.13168863844917663, 0.14209610931838205,
    0.14917298647260375, 0.15275338713072585, 0.15275338713072585, 0.14917298647260375,
    0.14209610931838205, 0.13168863844917663, 0.11819453196151842, 0.10193011981724044,
    0.083276741576704749, 0.062672048334109064, 0.040601429800386941, 0.017614007139152118,
};

// Symmetric 7-point degree-5 rule on the triangle (Dunavant 1985): barycentric (a, b, b) and permutations; weights
// sum to 1 (multiply by the area).
constexpr double kDunavant7A1 = 0.79742698535308732;  // (9 + 2 sqrt 15)/21
constexpr double kDunavant7B1 = 0.10128650732345634;  // (6 - sqrt 15)/21
constexpr double kDunavant7A2 = 0.059715871789769820; // (9 - 2 sqrt 15)/21
constexpr double kDunavant7B2 = 0.47014206410511509;  // (6 + sqrt 15)/21
constexpr double kDunavant7W0 = 0.225;
constexpr double kDunavant7W1 = 0.12593918054482715;  // (155 - sqrt 15)/1200
constexpr double kDunavant7W2 = 0.13239415278850618;  // (155 + sqrt 15)/1200

inline int gauss_clamp_order(int n) { return n < 1 ? 1 : (n > kMaxGaussOrder ? kMaxGaussOrder : n); }
inline double gauss_node(int n, int i) { return kGaussLegendreNodes[n * (n - 1) / 2 + i]; }
inline double gauss_weight(int n, int i) { return kGaussLegendreWeights[n * (n - 1) / 2 + i]; }

// Kernels usable as the template parameter of the element integrals.
struct LocalKernel {  // G_l, GGEM local part (tabulated smooth part: ggem_local_add_tabulated)
  double alpha;
  void add(double rx, double ry, double rz, double fx, double fy, double fz, double& ux, double& uy,
           double& uz) const {
    ggem_local_add_tabulated(alpha, rx, ry, rz, fx, fy, fz, ux, uy, uz);
  }
};
struct StokesletKernel {  // free-space Stokeslet (I + rr/r^2)/r
  void add(double rx, double ry, double rz, double fx, double fy, double fz, double& ux, double& uy,
           double& uz) const {
    stokeslet_add(rx, ry, rz, fx, fy, fz, ux, uy, uz);
  }
};

namespace quad_detail {

inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline void sub3(const double* a, const double* b, double* c) {
  c[0] = a[0] - b[0];
  c[1] = a[1] - b[1];
  c[2] = a[2] - b[2];
}
inline void cross3(const double* a, const double* b, double* c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
inline double norm3(const double* a) { return std::sqrt(dot3(a, a)); }

// Adds w * G(xt - y) . f at the point y = sum l_i v_i with f = sum l_i f_i.
template <class Kernel>
inline void add_point(const Kernel& kernel, const double* xt, const double* v, const double* f, double l0, double l1,
                      double l2, double w, double* u) {
  const double y0 = l0 * v[0] + l1 * v[3] + l2 * v[6];
  const double y1 = l0 * v[1] + l1 * v[4] + l2 * v[7];
  const double y2 = l0 * v[2] + l1 * v[5] + l2 * v[8];
  const double g0 = w * (l0 * f[0] + l1 * f[3] + l2 * f[6]);
  const double g1 = w * (l0 * f[1] + l1 * f[4] + l2 * f[7]);
  const double g2 = w * (l0 * f[2] + l1 * f[5] + l2 * f[8]);
  kernel.add(xt[0] - y0, xt[1] - y1, xt[2] - y2, g0, g1, g2, u[0], u[1], u[2]);
}

// Twice the area |(v1 - v0) x (v2 - v0)|.
inline double twice_area(const double* v) {
  double e1[3], e2[3], c[3];
  sub3(v + 3, v, e1);
  sub3(v + 6, v, e2);
  cross3(e1, e2, c);
  return norm3(c);
}

// Longest edge.
inline double longest_edge(const double* v) {
  double e[3], m = 0.0;
  for (int i = 0; i < 3; ++i) {
    sub3(v + 3 * ((i + 1) % 3), v + 3 * i, e);
    const double l = dot3(e, e);
    m = l > m ? l : m;
  }
  return std::sqrt(m);
}

// Distance from p to the closest point of triangle v (Ericson, Real-Time Collision Detection, 5.1.5).
inline double point_triangle_distance(const double* p, const double* v) {
  const double* a = v;
  const double* b = v + 3;
  const double* c = v + 6;
  double ab[3], ac[3], ap[3], q[3];
  sub3(b, a, ab);
  sub3(c, a, ac);
  sub3(p, a, ap);
  const double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  double s = 0.0, t = 0.0;  // closest point a + s ab + t ac
  if (d1 <= 0.0 && d2 <= 0.0) {
    s = 0.0, t = 0.0;
  } else {
    double bp[3], cp[3];
    sub3(p, b, bp);
    sub3(p, c, cp);
    const double d3 = dot3(ab, bp), d4 = dot3(ac, bp), d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d3 >= 0.0 && d4 <= d3) {
      s = 1.0, t = 0.0;
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
      s = d1 / (d1 - d3), t = 0.0;
    } else if (d6 >= 0.0 && d5 <= d6) {
      s = 0.0, t = 1.0;
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
      s = 0.0, t = d2 / (d2 - d6);
    } else if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
      const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
      s = 1.0 - w, t = w;
    } else {
      const double den = 1.0 / (va + vb + vc);
      s = vb * den, t = vc * den;
    }
  }
  for (int k = 0; k < 3; ++k) q[k] = p[k] - (a[k] + s * ab[k] + t * ac[k]);
  return norm3(q);
}

// Collapsed (Duffy) tensor Gauss rule, docs/method_quadrature.md: n x n points.
template <class Kernel>
inline void duffy_add(const Kernel& kernel, const double* xt, const double* v, const double* f, int n, double* u) {
  n = gauss_clamp_order(n);
  const double jac = twice_area(v);
  // y = v0 + eta (v1 - v0) + xi (v2 - v0), f(y) likewise: per point only the xi terms are new.
  const double* gn = kGaussLegendreNodes + n * (n - 1) / 2;
  const double* gw = kGaussLegendreWeights + n * (n - 1) / 2;
  const double e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]}, e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  const double d1[3] = {f[3] - f[0], f[4] - f[1], f[5] - f[2]}, d2[3] = {f[6] - f[0], f[7] - f[1], f[8] - f[2]};
  const double x0[3] = {xt[0] - v[0], xt[1] - v[1], xt[2] - v[2]};
  double acc[3] = {0.0, 0.0, 0.0};
  for (int ia = 0; ia < n; ++ia) {
    const double eta = 0.5 * (1.0 + gn[ia]);
    const double wa = gw[ia] * 0.25 * (1.0 - eta) * jac;
    const double ra[3] = {x0[0] - eta * e1[0], x0[1] - eta * e1[1], x0[2] - eta * e1[2]};
    const double fa[3] = {f[0] + eta * d1[0], f[1] + eta * d1[1], f[2] + eta * d1[2]};
    for (int ib = 0; ib < n; ++ib) {
      const double xi = 0.5 * (1.0 + gn[ib]) * (1.0 - eta);
      const double w = wa * gw[ib];
      kernel.add(ra[0] - xi * e2[0], ra[1] - xi * e2[1], ra[2] - xi * e2[2], w * (fa[0] + xi * d2[0]),
                 w * (fa[1] + xi * d2[1]), w * (fa[2] + xi * d2[2]), acc[0], acc[1], acc[2]);
    }
  }
  u[0] += acc[0];
  u[1] += acc[1];
  u[2] += acc[2];
}

#ifdef CAPSFLOW_SSE2_LOCAL_DUFFY
// The same rule for G_l with ggem_local_add_tabulated inlined, two points of a row (fixed eta) per SSE2 operation.
// Every point gets the same operations in the same order as the scalar kernel (no FMA in baseline x86-64), so each
// point's term is bitwise the scalar one; only the summation order differs (two lanes, then the odd point). A pair
// with a point outside the table (alpha r >= 6, or coincident) goes through kernel.add point by point.
inline void duffy_add(const LocalKernel& kernel, const double* xt, const double* v, const double* f, int n, double* u) {
  n = gauss_clamp_order(n);
  const double jac = twice_area(v);
  const double* gn = kGaussLegendreNodes + n * (n - 1) / 2;
  const double* gw = kGaussLegendreWeights + n * (n - 1) / 2;
  const double e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]}, e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  const double d1[3] = {f[3] - f[0], f[4] - f[1], f[5] - f[2]}, d2[3] = {f[6] - f[0], f[7] - f[1], f[8] - f[2]};
  const double x0[3] = {xt[0] - v[0], xt[1] - v[1], xt[2] - v[2]};
  const double alpha = kernel.alpha, a2 = alpha * alpha;
  const __m128d one = _mm_set1_pd(1.0), two = _mm_set1_pd(2.0), half = _mm_set1_pd(0.5);
  const __m128d valpha = _mm_set1_pd(alpha), va2 = _mm_set1_pd(a2), va3 = _mm_set1_pd(alpha * a2);
  const __m128d invw = _mm_set1_pd(kGgemTabInvWidth), tmax = _mm_set1_pd(kGgemTabTMax);
  const __m128d tlo = _mm_set1_pd(kCoincidentAlphaR * kCoincidentAlphaR);
  const __m128d tsplit = _mm_set1_pd(kGgemTabDirectFrom / kGgemTabInvWidth);  // i < kGgemTabDirectFrom <=> t < this
  const __m128d e2x = _mm_set1_pd(e2[0]), e2y = _mm_set1_pd(e2[1]), e2z = _mm_set1_pd(e2[2]);
  const __m128d d2x = _mm_set1_pd(d2[0]), d2y = _mm_set1_pd(d2[1]), d2z = _mm_set1_pd(d2[2]);
  __m128d sx = _mm_setzero_pd(), sy = _mm_setzero_pd(), sz = _mm_setzero_pd();
  double tail[3] = {0.0, 0.0, 0.0};
  for (int ia = 0; ia < n; ++ia) {
    const double eta = 0.5 * (1.0 + gn[ia]);
    const double wa = gw[ia] * 0.25 * (1.0 - eta) * jac;
    const double ra[3] = {x0[0] - eta * e1[0], x0[1] - eta * e1[1], x0[2] - eta * e1[2]};
    const double fa[3] = {f[0] + eta * d1[0], f[1] + eta * d1[1], f[2] + eta * d1[2]};
    const double len = 1.0 - eta;
    const __m128d vlen = _mm_set1_pd(len), vwa = _mm_set1_pd(wa);
    const __m128d ra0 = _mm_set1_pd(ra[0]), ra1 = _mm_set1_pd(ra[1]), ra2 = _mm_set1_pd(ra[2]);
    const __m128d fa0 = _mm_set1_pd(fa[0]), fa1 = _mm_set1_pd(fa[1]), fa2 = _mm_set1_pd(fa[2]);
    int ib = 0;
    for (; ib + 1 < n; ib += 2) {
      const __m128d xi = _mm_mul_pd(_mm_mul_pd(half, _mm_add_pd(one, _mm_loadu_pd(gn + ib))), vlen);
      const __m128d w = _mm_mul_pd(vwa, _mm_loadu_pd(gw + ib));
      const __m128d rx = _mm_sub_pd(ra0, _mm_mul_pd(xi, e2x)), ry = _mm_sub_pd(ra1, _mm_mul_pd(xi, e2y)),
                    rz = _mm_sub_pd(ra2, _mm_mul_pd(xi, e2z));
      const __m128d gx = _mm_mul_pd(w, _mm_add_pd(fa0, _mm_mul_pd(xi, d2x))),
                    gy = _mm_mul_pd(w, _mm_add_pd(fa1, _mm_mul_pd(xi, d2y))),
                    gz = _mm_mul_pd(w, _mm_add_pd(fa2, _mm_mul_pd(xi, d2z)));
      const __m128d r2 =
          _mm_add_pd(_mm_add_pd(_mm_mul_pd(rx, rx), _mm_mul_pd(ry, ry)), _mm_mul_pd(rz, rz));
      const __m128d t = _mm_mul_pd(va2, r2);
      if (_mm_movemask_pd(_mm_and_pd(_mm_cmpge_pd(t, tlo), _mm_cmplt_pd(t, tmax))) != 3) {
        double b_rx[2], b_ry[2], b_rz[2], b_gx[2], b_gy[2], b_gz[2];
        _mm_storeu_pd(b_rx, rx), _mm_storeu_pd(b_ry, ry), _mm_storeu_pd(b_rz, rz);
        _mm_storeu_pd(b_gx, gx), _mm_storeu_pd(b_gy, gy), _mm_storeu_pd(b_gz, gz);
        for (int l = 0; l < 2; ++l)
          kernel.add(b_rx[l], b_ry[l], b_rz[l], b_gx[l], b_gy[l], b_gz[l], tail[0], tail[1], tail[2]);
        continue;
      }
      const __m128d tw = _mm_mul_pd(t, invw);
      const __m128i iv = _mm_cvttpd_epi32(tw);
      const int o0 = _mm_cvtsi128_si32(iv) * kGgemTabStride;
      const int o1 = _mm_cvtsi128_si32(_mm_srli_si128(iv, 4)) * kGgemTabStride;
      const __m128d uu = _mm_sub_pd(_mm_mul_pd(two, _mm_sub_pd(tw, _mm_cvtepi32_pd(iv))), one);
      const double* A0 = kGgemTabA + o0;
      const double* A1 = kGgemTabA + o1;
      const double* B0 = kGgemTabB + o0;
      const double* B1 = kGgemTabB + o1;
      __m128d cp[9], cq[9];
      for (int k = 0; k < 9; ++k) {
        cp[k] = _mm_set_pd(A1[k], A0[k]);
        cq[k] = _mm_set_pd(B1[k], B0[k]);
      }
      const __m128d u2 = _mm_mul_pd(uu, uu), u4 = _mm_mul_pd(u2, u2), u8 = _mm_mul_pd(u4, u4);
      // Same association as ggem_local_tab: (c0 + c1 u) + u2 (c2 + c3 u) + u4 ((c4 + c5 u) + u2 (c6 + c7 u)) + u8 c8.
      auto estrin = [&](const __m128d* c) {
        const __m128d p01 = _mm_add_pd(c[0], _mm_mul_pd(c[1], uu)), p23 = _mm_add_pd(c[2], _mm_mul_pd(c[3], uu));
        const __m128d p45 = _mm_add_pd(c[4], _mm_mul_pd(c[5], uu)), p67 = _mm_add_pd(c[6], _mm_mul_pd(c[7], uu));
        return _mm_add_pd(_mm_add_pd(_mm_add_pd(p01, _mm_mul_pd(u2, p23)),
                                     _mm_mul_pd(u4, _mm_add_pd(p45, _mm_mul_pd(u2, p67)))),
                          _mm_mul_pd(u8, c[8]));
      };
      const __m128d p = estrin(cp), q = estrin(cq);
      const __m128d inv_r = _mm_div_pd(one, _mm_sqrt_pd(r2));
      const __m128d s1 = _mm_and_pd(_mm_cmplt_pd(t, tsplit), inv_r);
      const __m128d a = _mm_sub_pd(s1, _mm_mul_pd(valpha, p));
      const __m128d rf = _mm_add_pd(_mm_add_pd(_mm_mul_pd(rx, gx), _mm_mul_pd(ry, gy)), _mm_mul_pd(rz, gz));
      const __m128d b = _mm_mul_pd(_mm_sub_pd(_mm_mul_pd(_mm_mul_pd(s1, inv_r), inv_r), _mm_mul_pd(va3, q)), rf);
      sx = _mm_add_pd(sx, _mm_add_pd(_mm_mul_pd(a, gx), _mm_mul_pd(b, rx)));
      sy = _mm_add_pd(sy, _mm_add_pd(_mm_mul_pd(a, gy), _mm_mul_pd(b, ry)));
      sz = _mm_add_pd(sz, _mm_add_pd(_mm_mul_pd(a, gz), _mm_mul_pd(b, rz)));
    }
    if (ib < n) {
      const double xi = 0.5 * (1.0 + gn[ib]) * len;
      const double w = wa * gw[ib];
      kernel.add(ra[0] - xi * e2[0], ra[1] - xi * e2[1], ra[2] - xi * e2[2], w * (fa[0] + xi * d2[0]),
                 w * (fa[1] + xi * d2[1]), w * (fa[2] + xi * d2[2]), tail[0], tail[1], tail[2]);
    }
  }
  double lx[2], ly[2], lz[2];
  _mm_storeu_pd(lx, sx), _mm_storeu_pd(ly, sy), _mm_storeu_pd(lz, sz);
  u[0] += (lx[0] + lx[1]) + tail[0];
  u[1] += (ly[0] + ly[1]) + tail[1];
  u[2] += (lz[0] + lz[1]) + tail[2];
}
#endif

// Symmetric 7-point degree-5 rule.
template <class Kernel>
inline void dunavant7_add(const Kernel& kernel, const double* xt, const double* v, const double* f, double* u) {
  const double area = 0.5 * twice_area(v);
  const double third = 1.0 / 3.0;
  add_point(kernel, xt, v, f, third, third, third, kDunavant7W0 * area, u);
  const double w1 = kDunavant7W1 * area, w2 = kDunavant7W2 * area;
  add_point(kernel, xt, v, f, kDunavant7A1, kDunavant7B1, kDunavant7B1, w1, u);
  add_point(kernel, xt, v, f, kDunavant7B1, kDunavant7A1, kDunavant7B1, w1, u);
  add_point(kernel, xt, v, f, kDunavant7B1, kDunavant7B1, kDunavant7A1, w1, u);
  add_point(kernel, xt, v, f, kDunavant7A2, kDunavant7B2, kDunavant7B2, w2, u);
  add_point(kernel, xt, v, f, kDunavant7B2, kDunavant7A2, kDunavant7B2, w2, u);
  add_point(kernel, xt, v, f, kDunavant7B2, kDunavant7B2, kDunavant7A2, w2, u);
}

// Fully symmetric 16-point degree-8 rule: barycentric (l0, l1, l2) and weight per unit area. Derived by solving its
// moment equations (centroid, three (a, a, 1 - 2a) orbits, one (a, b, c) orbit; tools/gen_symmetric_triangle_rule.py,
// which also checks every monomial of degree <= 8 to 1e-39): 16 evaluations where the 5x5 collapsed rule of the same
// degree needs 25.
inline constexpr double kSym16[16][4] = {
    {0.33333333333333333, 0.33333333333333333, 0.33333333333333333, 0.14431560767778717},
    {0.050547228317030975, 0.050547228317030975, 0.89890554336593805, 0.03245849762319808},
    {0.050547228317030975, 0.89890554336593805, 0.050547228317030975, 0.03245849762319808},
    {0.89890554336593805, 0.050547228317030975, 0.050547228317030975, 0.03245849762319808},
    {0.45929258829272316, 0.45929258829272316, 0.081414823414553688, 0.095091634267284625},
    {0.45929258829272316, 0.081414823414553688, 0.45929258829272316, 0.095091634267284625},
    {0.081414823414553688, 0.45929258829272316, 0.45929258829272316, 0.095091634267284625},
    {0.17056930775176021, 0.17056930775176021, 0.65886138449647959, 0.10321737053471825},
    {0.17056930775176021, 0.65886138449647959, 0.17056930775176021, 0.10321737053471825},
    {0.65886138449647959, 0.17056930775176021, 0.17056930775176021, 0.10321737053471825},
    {0.0083947774099576053, 0.26311282963463811, 0.72849239295540428, 0.027230314174434994},
    {0.26311282963463811, 0.0083947774099576053, 0.72849239295540428, 0.027230314174434994},
    {0.0083947774099576053, 0.72849239295540428, 0.26311282963463811, 0.027230314174434994},
    {0.72849239295540428, 0.0083947774099576053, 0.26311282963463811, 0.027230314174434994},
    {0.26311282963463811, 0.72849239295540428, 0.0083947774099576053, 0.027230314174434994},
    {0.72849239295540428, 0.26311282963463811, 0.0083947774099576053, 0.027230314174434994},
};

template <class Kernel>
inline void symmetric16_add(const Kernel& kernel, const double* xt, const double* v, const double* f, double* u) {
  const double area = 0.5 * twice_area(v);
  for (int k = 0; k < 16; ++k)
    add_point(kernel, xt, v, f, kSym16[k][0], kSym16[k][1], kSym16[k][2], kSym16[k][3] * area, u);
}

// Regular rule chosen by ratio = d/h_e (no near-singular check).
template <class Kernel>
inline void regular_add(const Kernel& kernel, const double* xt, const double* v, const double* f, double ratio,
                        const QuadratureOrders& q, double* u) {
  if (ratio >= q.far_ratio) {
    if (q.far_dunavant)
      dunavant7_add(kernel, xt, v, f, u);
    else
      duffy_add(kernel, xt, v, f, q.regular_far, u);
  } else if (ratio >= q.symmetric_ratio) {
    symmetric16_add(kernel, xt, v, f, u);
  } else if (ratio >= q.outer_ratio) {
    duffy_add(kernel, xt, v, f, q.regular_outer, u);
  } else if (ratio >= q.mid_ratio) {
    duffy_add(kernel, xt, v, f, q.regular_mid, u);
  } else {
    duffy_add(kernel, xt, v, f, q.regular_near, u);
  }
}

// Polar rule about vertex k in the parametric plane, docs/method_quadrature.md: n (angle) x n (radius) points.
template <class Kernel>
inline void singular_add(const Kernel& kernel, const double* xt, const double* v, const double* f, int k, int n,
                         double* u) {
  n = gauss_clamp_order(n);
  // Cyclic re-ordering: local vertex 1 (barycentric l0) is vertex k.
  double w9[9], f9[9];
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) {
      w9[3 * i + c] = v[3 * ((k + i) % 3) + c];
      f9[3 * i + c] = f[3 * ((k + i) % 3) + c];
    }
  const double jac = twice_area(w9);
  const double quarter_pi = 0.25 * kPi;
  for (int ip = 0; ip < n; ++ip) {
    const double phi = quarter_pi * (1.0 + gauss_node(n, ip));
    const double sp = std::sin(phi), cp = std::cos(phi);
    const double rho_max = 1.0 / (sp + cp);
    const double wp = gauss_weight(n, ip) * quarter_pi * 0.5 * rho_max * jac;
    for (int ir = 0; ir < n; ++ir) {
      const double rho = 0.5 * rho_max * (1.0 + gauss_node(n, ir));
      const double xi = rho * sp, eta = rho * cp;
      add_point(kernel, xt, w9, f9, 1.0 - xi - eta, eta, xi, wp * gauss_weight(n, ir) * rho, u);
    }
  }
}

// Number of panels of length <= panel covering [0, len].
inline int panel_count(double len, double panel) {
  const double m = std::ceil(len / (panel > 0.1 ? panel : 0.1));
  return m < 1.0 ? 1 : (m > 64.0 ? 64 : static_cast<int>(m));
}

// Geometry shared by the right triangles of one near-singular element.
struct PlaneFrame {
  double p[3];     // projection of the target onto the element plane
  double h;        // unsigned height of the target above the plane
  double lp[3];    // barycentric coordinates of p
  double g[9];     // gradients of the barycentric coordinates (in-plane vectors)
  double scale;    // element size (longest edge)
};

// sinh s and cosh s (s >= 0) from one expm1 instead of two libm calls: e - 1/e = m + m/(1 + m) with m = e^s - 1 has
// no cancellation for small s.
inline void sinh_cosh(double s, double& sh, double& ch) {
  const double m = std::expm1(s), e = 1.0 + m, ie = 1.0 / e;
  sh = 0.5 * (m + m * ie);
  ch = 0.5 * (e + ie);
}

// Right triangle (p, F, V), right angle at F, delta = |F - p| > 0, ell = |V - F| > 0, in polar coordinates about p
// with rho = h sinh s and tan(theta) = sinh t. sign = +-1 (orientation of the piece in the signed decomposition).
template <class Kernel>
inline void right_triangle_add(const Kernel& kernel, const double* xt, const double* f, const PlaneFrame& fr,
                               const double* e1, const double* e2, double delta, double ell, double sign,
                               const QuadratureOrders& q, double* u) {
  const int na = gauss_clamp_order(q.near_angle), nr = gauss_clamp_order(q.near_radial);
  const double t_max = std::asinh(ell / delta);
  const int mt = panel_count(t_max, q.near_panel);
  const double dt = t_max / mt;
  // Below this height the integrand rho G(rho) is smooth in rho: plain Gauss in rho.
  const bool in_plane = fr.h < 1e-9 * fr.scale;
  for (int pt = 0; pt < mt; ++pt) {
    for (int ia = 0; ia < na; ++ia) {
      const double t = dt * (pt + 0.5 * (1.0 + gauss_node(na, ia)));
      const double ch = std::cosh(t);
      const double cth = 1.0 / ch, sth = std::tanh(t);
      const double wt = sign * 0.5 * dt * gauss_weight(na, ia) * cth;  // d theta = dt / cosh t
      double dir[3];
      for (int c = 0; c < 3; ++c) dir[c] = cth * e1[c] + sth * e2[c];
      double dl[3];  // d(barycentric)/d rho along dir
      for (int i = 0; i < 3; ++i) dl[i] = dot3(fr.g + 3 * i, dir);
      const double R = delta * ch;
      if (in_plane) {
        for (int ir = 0; ir < nr; ++ir) {
          const double rho = 0.5 * R * (1.0 + gauss_node(nr, ir));
          const double w = wt * 0.5 * R * gauss_weight(nr, ir) * rho;
          const double y[3] = {fr.p[0] + rho * dir[0], fr.p[1] + rho * dir[1], fr.p[2] + rho * dir[2]};
          double fy[3];
          for (int c = 0; c < 3; ++c)
            fy[c] = w * ((fr.lp[0] + rho * dl[0]) * f[c] + (fr.lp[1] + rho * dl[1]) * f[3 + c] +
                         (fr.lp[2] + rho * dl[2]) * f[6 + c]);
          kernel.add(xt[0] - y[0], xt[1] - y[1], xt[2] - y[2], fy[0], fy[1], fy[2], u[0], u[1], u[2]);
        }
        continue;
      }
      const double s_max = std::asinh(R / fr.h);
      const int ms = panel_count(s_max, q.near_panel);
      const double ds = s_max / ms;
      for (int ps = 0; ps < ms; ++ps) {
        for (int ir = 0; ir < nr; ++ir) {
          const double s = ds * (ps + 0.5 * (1.0 + gauss_node(nr, ir)));
          double shs, chs;
          sinh_cosh(s, shs, chs);
          const double rho = fr.h * shs;
          const double w = wt * 0.5 * ds * gauss_weight(nr, ir) * fr.h * fr.h * shs * chs;  // rho d rho
          const double y[3] = {fr.p[0] + rho * dir[0], fr.p[1] + rho * dir[1], fr.p[2] + rho * dir[2]};
          double fy[3];
          for (int c = 0; c < 3; ++c)
            fy[c] = w * ((fr.lp[0] + rho * dl[0]) * f[c] + (fr.lp[1] + rho * dl[1]) * f[3 + c] +
                         (fr.lp[2] + rho * dl[2]) * f[6 + c]);
          kernel.add(xt[0] - y[0], xt[1] - y[1], xt[2] - y[2], fy[0], fy[1], fy[2], u[0], u[1], u[2]);
        }
      }
    }
  }
}

// Near-singular element by the projection split (see the header comment).
template <class Kernel>
inline void near_projection_add(const Kernel& kernel, const double* xt, const double* v, const double* f,
                                const QuadratureOrders& q, double* u) {
  PlaneFrame fr;
  double e1[3], e2[3], n[3];
  sub3(v + 3, v, e1);
  sub3(v + 6, v, e2);
  cross3(e1, e2, n);
  const double a2 = norm3(n);
  for (int c = 0; c < 3; ++c) n[c] /= a2;
  double xa[3];
  sub3(xt, v, xa);
  const double hs = dot3(xa, n);
  fr.h = std::fabs(hs);
  fr.scale = longest_edge(v);
  for (int c = 0; c < 3; ++c) fr.p[c] = xt[c] - hs * n[c];
  for (int i = 0; i < 3; ++i) {
    const double* va = v + 3 * ((i + 1) % 3);
    const double* vb = v + 3 * ((i + 2) % 3);
    double ea[3], eb[3], c3[3], ed[3];
    sub3(va, fr.p, ea);
    sub3(vb, fr.p, eb);
    cross3(ea, eb, c3);
    fr.lp[i] = dot3(c3, n) / a2;
    sub3(vb, va, ed);
    cross3(n, ed, fr.g + 3 * i);
    for (int c = 0; c < 3; ++c) fr.g[3 * i + c] /= a2;
  }
  const double tiny = 1e-12 * fr.scale;
  for (int i = 0; i < 3; ++i) {
    const double* va = v + 3 * i;
    const double* vb = v + 3 * ((i + 1) % 3);
    double ed[3], pa[3], ea[3], eb[3], c3[3];
    sub3(vb, va, ed);
    sub3(va, fr.p, ea);
    sub3(vb, fr.p, eb);
    cross3(ea, eb, c3);
    const double orient = dot3(c3, n);  // signed twice-area of (p, va, vb)
    const double len2 = dot3(ed, ed);
    sub3(fr.p, va, pa);
    const double tpar = dot3(pa, ed) / len2;
    double foot[3], pf[3];
    for (int c = 0; c < 3; ++c) foot[c] = va[c] + tpar * ed[c];
    sub3(foot, fr.p, pf);
    const double delta = norm3(pf);
    if (delta <= tiny || std::fabs(orient) <= 1e-14 * a2) continue;  // p on this edge's line: zero-area piece
    const double sgn = orient > 0.0 ? 1.0 : -1.0;
    double u1[3];
    for (int c = 0; c < 3; ++c) u1[c] = pf[c] / delta;
    const double len = std::sqrt(len2);
    // Piece (p, va, F): signed area tpar * orient; piece (p, F, vb): (1 - tpar) * orient.
    const double ell_a = std::fabs(tpar) * len, ell_b = std::fabs(1.0 - tpar) * len;
    if (ell_a > tiny) {
      double u2[3];
      for (int c = 0; c < 3; ++c) u2[c] = (va[c] - foot[c]) / ell_a;
      right_triangle_add(kernel, xt, f, fr, u1, u2, delta, ell_a, tpar > 0.0 ? sgn : -sgn, q, u);
    }
    if (ell_b > tiny) {
      double u2[3];
      for (int c = 0; c < 3; ++c) u2[c] = (vb[c] - foot[c]) / ell_b;
      right_triangle_add(kernel, xt, f, fr, u1, u2, delta, ell_b, tpar < 1.0 ? sgn : -sgn, q, u);
    }
  }
}

// Near-singular element by adaptive 4-way subdivision (explicit stack: no recursion on the device).
template <class Kernel>
inline void near_subdivision_add(const Kernel& kernel, const double* xt, const double* v, const double* f,
                                 const QuadratureOrders& q, double* u) {
  const int max_depth = q.max_depth < 0 ? 0 : (q.max_depth > kMaxSubdivisionDepth ? kMaxSubdivisionDepth : q.max_depth);
  // Sub-triangles as barycentric coordinates (l0, l1) of their three corners plus the depth.
  constexpr int kStack = 3 * kMaxSubdivisionDepth + 4;
  double stack[kStack][6];
  int depth[kStack];
  int top = 0;
  stack[0][0] = 1.0, stack[0][1] = 0.0, stack[0][2] = 0.0, stack[0][3] = 1.0, stack[0][4] = 0.0, stack[0][5] = 0.0;
  depth[0] = 0;
  top = 1;
  while (top > 0) {
    --top;
    double b[6];
    for (int k = 0; k < 6; ++k) b[k] = stack[top][k];
    const int lev = depth[top];
    double sv[9], sf[9];
    for (int i = 0; i < 3; ++i) {
      const double l0 = b[2 * i], l1 = b[2 * i + 1], l2 = 1.0 - l0 - l1;
      for (int c = 0; c < 3; ++c) {
        sv[3 * i + c] = l0 * v[c] + l1 * v[3 + c] + l2 * v[6 + c];
        sf[3 * i + c] = l0 * f[c] + l1 * f[3 + c] + l2 * f[6 + c];
      }
    }
    const double hs = longest_edge(sv);
    const double ratio = point_triangle_distance(xt, sv) / hs;
    if (ratio >= q.subdivision_ratio || lev >= max_depth) {
      regular_add(kernel, xt, sv, sf, ratio, q, u);
      continue;
    }
    // Children: three corners and the middle triangle.
    const double m01[2] = {0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3])};
    const double m12[2] = {0.5 * (b[2] + b[4]), 0.5 * (b[3] + b[5])};
    const double m20[2] = {0.5 * (b[4] + b[0]), 0.5 * (b[5] + b[1])};
    const double kids[4][6] = {{b[0], b[1], m01[0], m01[1], m20[0], m20[1]},
                               {m01[0], m01[1], b[2], b[3], m12[0], m12[1]},
                               {m20[0], m20[1], m12[0], m12[1], b[4], b[5]},
                               {m01[0], m01[1], m12[0], m12[1], m20[0], m20[1]}};
    for (int c = 0; c < 4; ++c) {
      for (int k = 0; k < 6; ++k) stack[top][k] = kids[c][k];
      depth[top] = lev + 1;
      ++top;
    }
  }
}

}  // namespace quad_detail

// Adds \int_e G(xt - y) . f(y) dS_y to u for any kernel (see the header comment for the arguments); kNear: the
// near-singular rules compiled in (Any: q.near_method's, chosen at run time).
template <NearRules kNear = NearRules::Any, class Kernel>
inline void element_integral_add(const Kernel& kernel, const double* xt, const double* v, const double* f,
                                 int singular_vertex, const QuadratureOrders& q, double* u) {
  const double h_e = quad_detail::longest_edge(v);
  if (!(quad_detail::twice_area(v) > 1e-14 * h_e * h_e)) return;  // degenerate (zero-area) element: contributes 0
  if (singular_vertex >= 0 && singular_vertex < 3) {
    if (q.singular_method == SingularMethod::VertexPolar) {
      // The projection rule with the target in the plane on a vertex: the two edges through the vertex give
      // zero-area pieces, the opposite edge two right triangles, q.singular points per panel in angle and radius.
      QuadratureOrders qs = q;
      qs.near_angle = q.singular;
      qs.near_radial = q.singular;
      quad_detail::near_projection_add(kernel, xt, v, f, qs, u);
    } else {
      using quad_detail::singular_add;  // unqualified: a kernel's namespace may provide its own (host batching)
      singular_add(kernel, xt, v, f, singular_vertex, q.singular, u);
    }
    return;
  }
  const double ratio = quad_detail::point_triangle_distance(xt, v) / h_e;
  if (ratio < q.near_ratio) {
    if constexpr (kNear == NearRules::Any) {
      if (q.near_method == NearSingularMethod::Subdivision)
        quad_detail::near_subdivision_add(kernel, xt, v, f, q, u);
      else
        quad_detail::near_projection_add(kernel, xt, v, f, q, u);
    } else if constexpr (kNear == NearRules::Subdivision) {
      quad_detail::near_subdivision_add(kernel, xt, v, f, q, u);
    } else {
      quad_detail::near_projection_add(kernel, xt, v, f, q, u);
    }
    return;
  }
  quad_detail::regular_add(kernel, xt, v, f, ratio, q, u);
}

// GGEM local single layer: u += \int_e G_l(xt - y) . f(y) dS_y (no 1/(8 pi mu)); alpha is the GGEM splitting parameter.
inline void element_single_layer_add(double alpha, const double* xt, const double* v, const double* f,
                                     int singular_vertex, const QuadratureOrders& q, double* u) {
  element_integral_add(LocalKernel{alpha}, xt, v, f, singular_vertex, q, u);
}

// Free-space Stokeslet single layer with the same rules (tests, diagnostics): u += \int_e S(xt - y) . f(y) dS_y.
inline void element_stokeslet_add(const double* xt, const double* v, const double* f, int singular_vertex,
                                  const QuadratureOrders& q, double* u) {
  element_integral_add(StokesletKernel{}, xt, v, f, singular_vertex, q, u);
}

CAPSFLOW_DEVICE_END

}  // namespace capsflow
