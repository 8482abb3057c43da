#include "comminution/strength.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace millsim {
namespace {

// The capacity CDF F(e): probability that the capacity is at most e (J/kg above W_min).
double capacity_cdf(const StrengthConfig& s, double d, double e) {
  if (e <= 0.0) return 0.0;
  if (s.model == StrengthModel::VogelPeukert) return -std::expm1(-s.f_mat_kg_per_j_m * d * e);
  const double median =
      s.median_energy_j_per_kg * std::pow(d / s.reference_diameter_m, -s.size_exponent);
  return -std::expm1(-std::numbers::ln2 * std::pow(e / median, s.weibull_modulus));
}

}  // namespace

double threshold_energy_j_per_kg(const StrengthConfig& s, double d) {
  return s.model == StrengthModel::VogelPeukert ? s.x_w_min_j_m_per_kg / d : 0.0;
}

double capacity_from_uniform_j_per_kg(const StrengthConfig& s, double d, double u) {
  const double minus_log = -std::log(std::max(u, 1e-300));
  if (s.model == StrengthModel::VogelPeukert) return minus_log / (s.f_mat_kg_per_j_m * d);
  const double median =
      s.median_energy_j_per_kg * std::pow(d / s.reference_diameter_m, -s.size_exponent);
  return median * std::pow(minus_log / std::numbers::ln2, 1.0 / s.weibull_modulus);
}

double selection_probability(const StrengthConfig& s, double d, double w, int impacts,
                             double fatigue_factor) {
  const double excess = w - threshold_energy_j_per_kg(s, d);
  if (excess <= 0.0) return 0.0;
  // The k-th impact breaks when excess >= capacity − (k−1) factor excess.
  return capacity_cdf(s, d, excess * (1.0 + double(impacts - 1) * fatigue_factor));
}

bool apply_impact(const MaterialBreakageConfig& b, double d, double w, double& remaining) {
  const double excess = w - threshold_energy_j_per_kg(b.strength, d);
  if (excess <= 0.0) return false;
  if (excess >= remaining) return true;
  if (b.fatigue) remaining -= b.fatigue_factor * excess;
  return false;
}

double equivalent_speed_pair(ImpactEquivalence model, double m_i, double r_i, double c_i,
                             double m_j, double r_j, double c_j, double v) {
  if (model == ImpactEquivalence::Energy) return v * m_j / (m_i + m_j);
  const double reduced_mass_ratio = m_j / (m_i + m_j);    // m*/m_i
  const double reduced_radius_ratio = r_j / (r_i + r_j);  // R*/R_i
  const double stiffness_ratio = c_i / (c_i + c_j);       // E*_pair / E*_rigid wall
  return v * std::sqrt(reduced_mass_ratio * std::cbrt(stiffness_ratio * stiffness_ratio) *
                       std::cbrt(reduced_radius_ratio));
}

double equivalent_speed_wall(ImpactEquivalence model, double c_i, double c_wall, double v) {
  if (model == ImpactEquivalence::Energy) return v;
  const double stiffness_ratio = c_i / (c_i + c_wall);
  return v * std::sqrt(std::cbrt(stiffness_ratio * stiffness_ratio));
}

}  // namespace millsim
