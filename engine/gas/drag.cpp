#include "gas/drag.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace millsim {

double schiller_naumann_cd(double re) {
  return re < 1000.0 ? 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687)) : 0.44;
}

namespace {

constexpr double kPi = std::numbers::pi;

// β = ⅛ π d² ρ C_d(Re) |s| written so it stays finite at s = 0: the Stokes part 3π μ d times
// the Schiller–Naumann correction, or the Newton regime above Re = 1000.
double schiller_naumann_beta(double d, double re, double slip, double rho, double mu) {
  if (re < 1000.0) return 3.0 * kPi * mu * d * (1.0 + 0.15 * std::pow(re, 0.687));
  return 0.125 * kPi * d * d * rho * 0.44 * slip;
}

double di_felice_beta(const DragInput& in) {
  const double eps = in.volume_fraction, d = in.diameter_m, rho = in.density_kg_per_m3;
  const double mu = in.viscosity_pa_s, s = in.slip_speed_m_per_s;
  const double re = eps * particle_reynolds(in);
  const double lg = std::log10(std::max(re, 1e-12));
  const double chi = 3.7 - 0.65 * std::exp(-0.5 * (1.5 - lg) * (1.5 - lg));
  // C_d |s| = (0.63 + 4.8/√Re)² |s| = 0.3969 |s| + 6.048 √(|s| μ/(ρ d ε)) + 23.04 μ/(ρ d ε)
  const double a = mu / (rho * d * eps);
  const double cd_slip = 0.3969 * s + 6.048 * std::sqrt(s * a) + 23.04 * a;
  return 0.125 * kPi * d * d * rho * std::pow(eps, 2.0 - chi) * cd_slip;
}

double gidaspow_beta(const DragInput& in) {
  const double eps = in.volume_fraction, d = in.diameter_m, rho = in.density_kg_per_m3;
  const double mu = in.viscosity_pa_s, s = in.slip_speed_m_per_s;
  const double volume = kPi * d * d * d / 6.0;
  if (eps < 0.8)  // Ergun: V_p (150 (1−ε) μ / (ε d²) + 1.75 ρ |s| / d)
    return volume * (150.0 * (1.0 - eps) * mu / (eps * d * d) + 1.75 * rho * s / d);
  // Wen & Yu: β = ⅛ π d² ρ C_d(Re_s) |s| ε^(−1.65), Re_s = ε Re. Below Re_s = 1000 the
  // Schiller–Naumann β at Re_s carries a 1/ε of its own (3π μ d (1 + 0.15 Re_s^0.687) / ε).
  const double re = eps * particle_reynolds(in);
  return schiller_naumann_beta(d, re, s, rho, mu) * std::pow(eps, re < 1000.0 ? -2.65 : -1.65);
}

double koch_hill_beta(const DragInput& in) {
  const double eps = in.volume_fraction, phi = 1.0 - eps;
  const double re = eps * particle_reynolds(in);
  double f0 = 1.0;
  if (phi >= 0.4)
    f0 = 10.0 * phi / (eps * eps * eps);
  else if (phi > 0.0)
    f0 = (1.0 + 3.0 * std::sqrt(0.5 * phi) + 135.0 / 64.0 * phi * std::log(phi) + 16.14 * phi) /
         (1.0 + 0.681 * phi - 8.48 * phi * phi + 8.16 * phi * phi * phi);
  const double f3 = 0.0673 + 0.212 * phi + 0.0232 / std::pow(eps, 5.0);
  return 3.0 * kPi * in.viscosity_pa_s * in.diameter_m * eps * eps * (f0 + 0.5 * f3 * re);
}

double beetstra_beta(const DragInput& in) {
  const double eps = in.volume_fraction, phi = 1.0 - eps;
  const double re = eps * particle_reynolds(in);
  double f = 10.0 * phi / (eps * eps) + eps * eps * (1.0 + 1.5 * std::sqrt(phi));
  if (re > 0.0)  // the inertial term, which vanishes as Re → 0
    f += 0.413 * re / (24.0 * eps * eps) *
         (1.0 / eps + 3.0 * eps * phi + 8.4 * std::pow(re, -0.343)) /
         (1.0 + std::pow(10.0, 3.0 * phi) * std::pow(re, -0.5 * (1.0 + 4.0 * phi)));
  return 3.0 * kPi * in.viscosity_pa_s * in.diameter_m * eps * f;
}

}  // namespace

double drag_coefficient_kg_per_s(DragLaw law, const DragInput& in) {
  switch (law) {
    case DragLaw::SchillerNaumann:
      return schiller_naumann_beta(in.diameter_m, particle_reynolds(in), in.slip_speed_m_per_s,
                                   in.density_kg_per_m3, in.viscosity_pa_s);
    case DragLaw::DiFelice:
      return di_felice_beta(in);
    case DragLaw::Gidaspow:
      return gidaspow_beta(in);
    case DragLaw::KochHill:
      return koch_hill_beta(in);
    case DragLaw::Beetstra:
      return beetstra_beta(in);
  }
  return 0.0;
}

double cunningham_correction(double diameter_m, double mean_free_path_m) {
  if (!(mean_free_path_m > 0.0) || !(diameter_m > 0.0)) return 1.0;
  const double knudsen = 2.0 * mean_free_path_m / diameter_m;
  return 1.0 + knudsen * (1.257 + 0.400 * std::exp(-1.10 / knudsen));
}

Vec3 saffman_lift_n(double d, const Vec3& slip, const Vec3& vorticity, double rho, double mu) {
  const double w = norm(vorticity);
  if (w <= 0.0) return {};
  return cross(slip, vorticity) * (1.615 * d * d * std::sqrt(rho * mu / w));
}

}  // namespace millsim
