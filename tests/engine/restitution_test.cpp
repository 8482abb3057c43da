// The damping calibration against closed forms of the dimensionless Hertz impact
// X'' = −X^{3/2} − α X^{1/4} X', X(0) = 0, X'(0) = 1:
//   α = 0: max overlap (5/4)^{2/5} (Eq. 12), contact time 2·(5/4)^{2/5}·Γ(2/5)Γ(1/2)/(5/2 Γ(9/10)),
//          restitution 1 (energy conservation);
//   α(e) inverts e(α) (round trip), and e(α) falls monotonically.
#include <gtest/gtest.h>

#include <cmath>

#include "particles/restitution.h"

namespace millsim {
namespace {

TEST(Restitution, UndampedImpactMatchesHertzClosedForm) {
  const DimensionlessImpact got = simulate_dimensionless_impact(0.0);
  const double max_overlap = std::pow(1.25, 0.4);
  const double duration =
      2.0 * max_overlap * std::tgamma(0.4) * std::tgamma(0.5) / (2.5 * std::tgamma(0.9));
  EXPECT_NEAR(got.max_overlap, max_overlap, 1e-6);
  EXPECT_NEAR(got.duration, duration, 1e-3);
  EXPECT_NEAR(got.restitution, 1.0, 1e-6);
}

TEST(Restitution, DampingRatioRoundTripsAndIsMonotonic) {
  double previous_alpha = -1.0;
  for (double e : {0.95, 0.8, 0.6, 0.4, 0.2, 0.1}) {
    const double alpha = damping_ratio_for_restitution(e);
    EXPECT_GT(alpha, previous_alpha) << "lower e needs more damping";
    EXPECT_NEAR(simulate_dimensionless_impact(alpha).restitution, e, 1e-6);
    previous_alpha = alpha;
  }
  EXPECT_EQ(damping_ratio_for_restitution(1.0), 0.0);
}

TEST(Restitution, PaperDampingOvershootsWithClippedForce) {
  // Expectation: DESIGN.md errata, "e = 0.5 rebounds at ... 0.58 when the contact force is
  // clipped" for α = 2γ(e), γ = −ln e / √(π² + ln² e).
  const double e = 0.5, gamma = -std::log(e) / std::sqrt(M_PI * M_PI + std::log(e) * std::log(e));
  EXPECT_NEAR(simulate_dimensionless_impact(2.0 * gamma).restitution, 0.58, 0.005);
}

}  // namespace
}  // namespace millsim
