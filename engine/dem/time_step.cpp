#include "dem/time_step.h"

#include <cmath>
#include <numbers>

namespace millsim {

double rayleigh_time_s(double r, double E, double nu, double rho) {
  const double shear_modulus = E / (2.0 * (1.0 + nu));
  return std::numbers::pi * r * std::sqrt(rho / shear_modulus) / (0.1631 * nu + 0.8766);
}

double hertz_contact_time_s(double m_eff, double k, double v) {
  // t_c = 2 (δ_max / v) ∫₀¹ dx / √(1 − x^{5/2}), δ_max = (5 m* v² / (4 k))^{2/5} (Eq. 12);
  // the integral is Γ(2/5) Γ(1/2) / (5/2 Γ(9/10)) = 1.4716.
  const double integral = std::tgamma(0.4) * std::tgamma(0.5) / (2.5 * std::tgamma(0.9));
  const double max_overlap = std::pow(5.0 * m_eff * v * v / (4.0 * k), 0.4);
  return 2.0 * integral * max_overlap / v;
}

}  // namespace millsim
