// Validation of a viscosity ratio other than 1 (issue 22, label 'validation'; docs/validation.md section 11):
//   drops in simple shear (law "surface-tension"), lambda 0.1, 1, 5 at Ca 0.05, mesh level 3, against Taylor's
//     D = Ca (19 lambda + 16)/(16 lambda + 16) (no O(Ca^2) term in simple shear) within 3 %, and the inclination
//     against Chaffey & Brenner's pi/4 - Ca (19 lambda + 16)(2 lambda + 3)/(80 (lambda + 1)) within 1.5 degrees;
//   neo-Hookean capsules (unstressed spheres) in simple shear, lambda 0.2, 1, 5 at Ca 0.05 and 0.01, level 2, against
//     the small-deformation theory: D = (25/12) Ca independent of lambda (Barthes-Biesel & Rallison 1981), lambda
//     entering D only at O(Ca^2) relative (Regazzi & Leonetti 2026): D(lambda)/D(1) within 1 % at Ca 0.01 and
//     its deviation second order in Ca; at Ca 0.05 and lambda 5 (expansion parameter 0.28) the published trend
//     (Foessel et al. 2011: a more viscous interior deforms less); inclinations at Ca 0.01 against first order;
//   a pair collision at lambda 5 beside lambda 1 (KG's protocol, Ca 0.2 both): runs and reports the final offsets.
// The box: H = 12, Lx = Lz = 10, alpha = 2 (drops and capsules pinned at the centre; walls 5.5 radii away).
// About 8 minutes with ctest -j 2 (2026-12-04, beside three nice'd runs; the drops' case is the longest, 8 minutes).
// Run: ctest --preset validation -R ViscosityRatioValidation, or the binary.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "support/capsule_runs.hpp"

namespace capsflow::test {
namespace {

// Steady when D moved by less than rtol |D| over the last `window` strain units.
bool steady(const Series& s, double window, double rtol) {
  if (s.t.size() < 3 || s.t.back() < window) return false;
  const double t1 = s.t.back() - window;
  std::size_t i = s.t.size() - 1;
  while (i > 0 && s.t[i] > t1) --i;
  const double d0 = s.D[0][i], d1 = s.D[0].back();
  return std::abs(d1 - d0) < rtol * std::abs(d1);
}

RunSpec centred(int level, double ca, const std::string& keys) {
  RunSpec r;
  r.H = 12.0;
  r.Lx = r.Lz = 10.0;
  r.alpha = 2.0;
  r.level = level;
  r.inflation = 0.0;
  r.species = {{"a", ca}};
  r.species_keys = {keys};
  r.capsules = {{"a", 5.0, 6.0, 5.0, true}};
  return r;
}

TEST(ViscosityRatioValidation, DropsInShearFollowTaylor) {
  const double ca = 0.05;
  std::printf("  lambda   D          Taylor D   rel. err   angle (deg)  Chaffey-Brenner   strain  steps\n");
  for (double lambda : {0.1, 1.0, 5.0}) {
    const RunSpec r = centred(3, ca, "law = \"surface-tension\"\nviscosity_ratio = " + std::to_string(lambda) + "\n");
    const Series s = run_series(r, 6.0, 5, [](const Series& x) { return steady(x, 1.0, 1e-3); });
    ASSERT_TRUE(s.stop.empty()) << s.stop;
    const double D = s.D[0].back(), angle = s.incl[0].back() * 180.0 / kPi;
    const double taylor = ca * (19.0 * lambda + 16.0) / (16.0 * lambda + 16.0);
    const double cb = 45.0 - ca * (19.0 * lambda + 16.0) * (2.0 * lambda + 3.0) / (80.0 * (lambda + 1.0)) * 180.0 / kPi;
    std::printf("  %-6.1f   %.5f    %.5f    %+.2f %%    %6.2f       %6.2f           %.2f    %ld\n", lambda, D, taylor,
                100.0 * (D / taylor - 1.0), angle, cb, s.t.back(), s.steps);
    EXPECT_NEAR(D / taylor, 1.0, 0.03) << lambda;
    EXPECT_NEAR(angle, cb, 1.5) << lambda;
  }
}

// Capsules: D at lambda 0.2, 1, 5 for Ca 0.05 and 0.01. First-order theory (Barthes-Biesel & Rallison 1981) has
// D = (25/12) Ca at every lambda; Regazzi & Leonetti (arXiv:2602.15626, 2026; abstract: "the deformation does no
// longer depend on lambda at the upper order") keep D free of lambda at the next order too, so D(lambda)/D(1) - 1 is
// O(Ca^2) relative: from Ca 0.05 to 0.01 it must shrink by far more than the factor 5 of a first-order term
// (measured: 18 at lambda 5). D(lambda)/D(1) also takes out the level-2 mesh's own
// -1.25 % (equal at both Ca). The inclination against the first-order pi/4 - Ca (276 + 209 lambda)/240 (derived for
// this page, docs/validation.md 11; not a published capsule formula) at Ca 0.01.
TEST(ViscosityRatioValidation, CapsulesInShearAgainstSmallDeformationTheory) {
  const double lambdas[3] = {0.2, 1.0, 5.0};
  double D[2][3], incl[2][3];
  std::printf("  Ca     lambda   D          (25/12) Ca   rel. err   D / D(lambda 1)   angle (deg)   strain  steps\n");
  for (int ic = 0; ic < 2; ++ic) {
    const double ca = ic == 0 ? 0.05 : 0.01, theory = 25.0 / 12.0 * ca;
    for (int l = 0; l < 3; ++l) {
      const RunSpec r = centred(2, ca, "viscosity_ratio = " + std::to_string(lambdas[l]) + "\n");
      // Steady over a window of 20 Ca strain units (a few membrane relaxation times, which scale with
      // Ca (1 + lambda)), after at least 50 Ca.
      const double window = 20.0 * ca;
      const Series s =
          run_series(r, 8.0, 5, [&](const Series& x) { return x.t.back() >= 50.0 * ca && steady(x, window, 1e-3); });
      ASSERT_TRUE(s.stop.empty()) << s.stop;
      D[ic][l] = s.D[0].back();
      incl[ic][l] = s.incl[0].back();
      std::printf("  %.2f   %-6.1f   %.5f    %.5f      %+.2f %%                      %6.2f        %.2f    %ld\n", ca,
                  lambdas[l], D[ic][l], theory, 100.0 * (D[ic][l] / theory - 1.0), incl[ic][l] * 180.0 / kPi,
                  s.t.back(), s.steps);
      std::fflush(stdout);
      EXPECT_NEAR(D[ic][l] / theory, 1.0, l == 2 && ic == 0 ? 0.15 : 0.05) << ca << " " << lambdas[l];
    }
  }
  for (int l : {0, 2}) {
    const double r05 = D[0][l] / D[0][1] - 1.0, r01 = D[1][l] / D[1][1] - 1.0;
    std::printf("  lambda %.1f: D / D(lambda 1) - 1 = %+.3f %% (Ca 0.05), %+.3f %% (Ca 0.01)\n", lambdas[l], 100.0 * r05,
                100.0 * r01);
    EXPECT_LT(std::abs(r01), 0.01) << lambdas[l];
    // At Ca 0.05 lambda changes D (+1.27 % at 0.2, -9.87 % at 5: docs/validation.md 11), and the change shrinks
    // faster than Ca toward 0.01 (second order: 25x; a first-order term would shrink 5x). Always asserted: a lambda
    // the solver ignored gives r05 = r01 = 0.
    EXPECT_GT(std::abs(r05), 0.005) << "lambda " << lambdas[l] << " leaves D unchanged at Ca 0.05";
    EXPECT_GT(std::abs(r05), 10.0 * std::abs(r01)) << "second order in Ca, lambda " << lambdas[l];
  }
  // Ca 0.05: at lambda 5 the published trend (a more viscous interior deforms less; Foessel et al. 2011).
  EXPECT_LT(D[0][2], D[0][1]);
  for (int l = 0; l < 3; ++l) {
    const double want = kPi / 4.0 - 0.01 * (276.0 + 209.0 * lambdas[l]) / 240.0;
    std::printf("  Ca 0.01, lambda %.1f: inclination %.2f deg, first order %.2f deg\n", lambdas[l],
                incl[1][l] * 180.0 / kPi, want * 180.0 / kPi);
    EXPECT_NEAR(incl[1][l] * 180.0 / kPi, want * 180.0 / kPi, 0.5) << lambdas[l];
  }
}

TEST(ViscosityRatioValidation, PairCollisionAtLambdaFiveBesideLambdaOne) {
  double dy[2];
  for (int i = 0; i < 2; ++i) {
    const double lambda = i == 0 ? 1.0 : 5.0;
    const PairResult p = pair_run(0.2, 0.2, 2, 20.0, 24.0, 12.0, 1.0, 2.5, 0.5, "", 0.5,
                                  "viscosity_ratio = " + std::to_string(lambda) + "\n");
    ASSERT_TRUE(p.s.stop.empty()) << p.s.stop;
    dy[i] = p.dy_final;
    std::printf("  lambda %.0f: final offset dy = %.4f (top %+.4f, bottom %+.4f) after %.2f strain, %ld steps\n", lambda,
                p.dy_final, p.dy_top, p.dy_bottom, p.s.t.back(), p.s.steps);
    EXPECT_GT(p.dy_final, 0.5) << lambda;  // the collision separates the pair
  }
  std::printf("  offset ratio lambda 5 / lambda 1: %.3f\n", dy[1] / dy[0]);
}

}  // namespace
}  // namespace capsflow::test
