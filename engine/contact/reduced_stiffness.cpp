#include "contact/reduced_stiffness.h"

#include <cmath>
#include <numbers>

#include "contact/penetration_limit.h"

namespace millsim {

double predicted_penetration_ratio(const PenetrationCase& c, double scale) {
  const MaterialConstants& m = *c.particle;
  const double r = 0.5 * c.diameter_m;
  const double mass = m.density_kg_per_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
  const double compliance = m.normal_compliance / scale;
  double k, m_eff;
  if (c.partner_compliance >= 0.0) {
    k = 4.0 / 3.0 / (compliance + c.partner_compliance) * std::sqrt(r);  // Eq. 5
    m_eff = mass;
  } else {
    k = 4.0 / 3.0 / (2.0 * compliance) * std::sqrt(0.5 * r);
    m_eff = 0.5 * mass;
  }
  return predicted_max_overlap_m(c.damping, m_eff, k, c.impact_speed_m_per_s, c.restitution) /
         c.diameter_m;
}

ThresholdChoice automatic_threshold(const PenetrationCase& c, double d_max, double limit) {
  const double d_min = c.diameter_m;
  auto ratio_at = [&](double d_th) {
    return predicted_penetration_ratio(c, stiffness_scale(d_min, d_th));
  };
  if (ratio_at(d_min) >= limit) return {d_min, ratio_at(d_min), true};
  if (ratio_at(d_max) <= limit) return {d_max, ratio_at(d_max), false};
  double lo = std::log(d_min), hi = std::log(d_max);  // ratio(lo) < limit < ratio(hi)
  for (int iter = 0; iter < 100 && hi - lo > 1e-12; ++iter) {
    const double mid = 0.5 * (lo + hi);
    (ratio_at(std::exp(mid)) <= limit ? lo : hi) = mid;
  }
  const double d_th = std::exp(lo);
  return {d_th, ratio_at(d_th), false};
}

}  // namespace millsim
