// Damping that reproduces a requested coefficient of restitution for the Hertz contact.
//
// The normal force is F = k δ^{3/2} + α √(m* k) δ^{1/4} (−v_n), clipped at zero so a contact
// never pulls. Scaling δ by (m* v²/k)^{2/5} and t by δ/v removes m*, k and v entirely:
//   X'' = −X^{3/2} − α X^{1/4} X',  X(0) = 0, X'(0) = 1,
// so the restitution depends on α alone. DESIGN.md (errata) shows the paper's γ(e) does not
// give back e once the force is clipped, so α(e) is found here by integrating that
// dimensionless equation and bisecting. Results are memoised per e.
#pragma once

namespace millsim {

struct DimensionlessImpact {
  double restitution;  // −X'(end) / X'(0)
  double max_overlap;  // max X, in units of (m* v²/k)^{2/5}
  double duration;     // contact time, in units of (m* v²/k)^{2/5} / v
};

// Integrates the clipped dimensionless Hertz impact with damping ratio alpha (RK4).
DimensionlessImpact simulate_dimensionless_impact(double alpha);

// The α that gives restitution e, for e in [0.05, 1]; α(1) = 0.
double damping_ratio_for_restitution(double restitution);

}  // namespace millsim
