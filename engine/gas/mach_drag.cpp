#include "gas/mach_drag.h"

#include <cmath>

#include "gas/drag.h"

namespace millsim {
namespace {

constexpr double kSqrtPi = 1.7724538509055159;
constexpr double kNexusReynolds = 45.0;

// 24/Re (1 + 0.15 Re^0.687): Schiller & Naumann's standard drag, both regimes' viscous part.
double standard_viscous_cd(double reynolds) {
  return 24.0 / reynolds * (1.0 + 0.15 * std::pow(reynolds, 0.687));
}

double compression_cd(double reynolds, double mach) {
  const double c_m = loth_c_m(mach);
  return standard_viscous_cd(reynolds) * loth_h_m(mach) +
         0.42 * c_m /
             (1.0 + 42500.0 / std::pow(reynolds, 1.16 * c_m) +
              loth_g_m(mach) / std::sqrt(reynolds));
}

// C_D,fm,Re: the free-molecular drag carried down to Re = 45, where it meets J_M.
double free_molecular_cd_at_reynolds(double reynolds, double mach, double gamma) {
  const double fm = free_molecular_sphere_cd(mach * std::sqrt(0.5 * gamma));
  return fm / (1.0 + (fm / loth_j_m(mach) - 1.0) * std::sqrt(reynolds / kNexusReynolds));
}

}  // namespace

double loth_c_m(double m) {
  return m <= 1.5 ? 1.65 + 0.65 * std::tanh(4.0 * m - 3.4) : 2.18 - 0.13 * std::tanh(0.9 * m - 2.7);
}

double loth_g_m(double m) {
  return m < 0.8 ? 166.0 * m * m * m + 3.29 * m * m - 10.9 * m + 20.0 : 5.0 + 40.0 / (m * m * m);
}

double loth_h_m(double m) {
  return m < 1.0 ? 0.0239 * m * m * m + 0.212 * m * m - 0.074 * m + 1.0
                 : 0.93 + 1.0 / (3.5 + m * m * m * m * m);
}

double loth_j_m(double m) {
  return m < 1.0 ? 2.26 - 0.1 / m + 0.14 / (m * m * m)
                 : 1.6 + 0.25 / m + 0.11 / (m * m) + 0.44 / (m * m * m);
}

double free_molecular_sphere_cd(double s) {
  // Below s = 1e-3 the terms in 1/s³ cancel to 9 digits: Epstein's limit (diffuse reflection),
  // C_D = (16 / (3√π) + 2√π / 3) / s, to O(s) (the next term is 1e-6 of it there).
  if (s < 1e-3) return (16.0 / (3.0 * kSqrtPi) + 2.0 * kSqrtPi / 3.0) / s;
  const double s2 = s * s, s4 = s2 * s2;
  return (1.0 + 2.0 * s2) * std::exp(-s2) / (s2 * s * kSqrtPi) +
         (4.0 * s4 + 4.0 * s2 - 1.0) * std::erf(s) / (2.0 * s4) + 2.0 * kSqrtPi / (3.0 * s);
}

double loth_drag_coefficient(double reynolds, double mach, double knudsen, double gamma) {
  if (reynolds > kNexusReynolds) return compression_cd(reynolds, mach);
  const double continuum =
      standard_viscous_cd(reynolds) / cunningham_correction(1.0, knudsen);  // Kn = λ/d
  if (!(mach > 0.0)) return continuum;
  const double m4 = mach * mach * mach * mach;
  return (continuum + m4 * free_molecular_cd_at_reynolds(reynolds, mach, gamma)) / (1.0 + m4);
}

double loth_mach_factor(double reynolds, double mach, double knudsen, double gamma) {
  if (!(mach > 0.0) || !(reynolds > 0.0)) return 1.0;
  return loth_drag_coefficient(reynolds, mach, knudsen, gamma) /
         loth_drag_coefficient(reynolds, 0.0, knudsen, gamma);
}

}  // namespace millsim
