// The published fixed-bed drag laws as tests use them for expected pressure gradients,
// written from the papers (not from the engine's gas/drag.cpp).
#pragma once

#include <cmath>

namespace millsim::test {

// Koch & Hill (2001), as CFDEM uses it: −dp/dz = 18 μ φ F U / d² through a fixed bed of solid
// fraction φ at superficial speed U, F = F0(φ) + ½ F3(φ) Re, Re = ρ d U / μ.
inline double koch_hill_gradient(double phi, double U, double d, double rho, double mu) {
  const double eps = 1 - phi;
  const double f0 =
      phi >= 0.4 ? 10 * phi / (eps * eps * eps)
                 : (1 + 3 * std::sqrt(phi / 2) + 135.0 / 64 * phi * std::log(phi) + 16.14 * phi) /
                       (1 + 0.681 * phi - 8.48 * phi * phi + 8.16 * phi * phi * phi);
  const double f3 = 0.0673 + 0.212 * phi + 0.0232 / std::pow(eps, 5);
  return 18 * mu * phi * (f0 + 0.5 * f3 * rho * d * U / mu) * U / (d * d);
}

// The superficial speed at which Koch–Hill gives the gradient G (the positive root of its
// quadratic in U).
inline double koch_hill_speed(double phi, double gradient_pa_per_m, double d, double rho,
                              double mu) {
  if (phi <= 0.0) return 0.0;  // no bed: no drag (the caller handles an open channel)
  const double slope = koch_hill_gradient(phi, 1.0, d, 0.0, mu);  // the U-linear part at U = 1
  const double eps = 1 - phi;
  const double f3 = 0.0673 + 0.212 * phi + 0.0232 / std::pow(eps, 5);
  const double curvature = 9 * phi * f3 * rho / d;  // the U² part
  if (curvature == 0.0) return gradient_pa_per_m / slope;
  return (-slope + std::sqrt(slope * slope + 4 * curvature * gradient_pa_per_m)) / (2 * curvature);
}

}  // namespace millsim::test
