// Damping that reproduces a requested coefficient of restitution for the Hertz contact.
//
// The normal force is F = k δ^{3/2} + α √(m* k) δ^{1/4} (−v_n), clipped at zero so a contact
// never pulls. Scaling δ by (m* v²/k)^{2/5} and t by δ/v removes m*, k and v entirely:
//   X'' = −X^{3/2} − α X^{1/4} X',  X(0) = 0, X'(0) = 1,
// so the restitution depends on α alone. DESIGN.md (errata) shows the paper's γ(e) does not
// give back e once the force is clipped, so α(e) is found here by integrating that
// dimensionless equation and bisecting. Results are memoised per e.
//
// Below kLowestDampedRestitution the damping needed grows without bound (α(0.05) = 4.35,
// α(0.01) ≈ 11, e(α = 40) ≈ 8e-4 with a contact 25 times longer; α → ∞ as e → 0), and the
// explicit step cannot hold it (a damped contact needs ω dt below about 2.4/α). So a lower
// restitution keeps the damper of 0.05, and what remains of the rebound is taken out when the
// contact ends: the pair's normal separation speed is scaled by e / 0.05 with equal and opposite
// impulses (contact/contact_forces.cpp). That is exact restitution for a binary impact at any
// e in [0, 0.05], conserves momentum and can only remove energy.
#pragma once

namespace millsim {

inline constexpr double kLowestDampedRestitution = 0.05;

struct DimensionlessImpact {
  double restitution;  // −X'(end) / X'(0)
  double max_overlap;  // max X, in units of (m* v²/k)^{2/5}
  double duration;     // contact time, in units of (m* v²/k)^{2/5} / v
};

// Integrates the clipped dimensionless Hertz impact with damping ratio alpha (RK4).
DimensionlessImpact simulate_dimensionless_impact(double alpha);

// The α that gives restitution e, for e in [0.05, 1]; α(1) = 0. Below 0.05 it is α(0.05).
double damping_ratio_for_restitution(double restitution);

// The share of a contact's normal separation speed it keeps when it ends: e / 0.05 below 0.05,
// else 1 (the damper alone gives e).
inline double separation_scale(double restitution) {
  return restitution < kLowestDampedRestitution ? restitution / kLowestDampedRestitution : 1.0;
}

}  // namespace millsim
