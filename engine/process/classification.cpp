#include "process/classification.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace millsim {

VortexSample sample_vortex(const GasView& gas, const MillConfig& mill, double radius_m,
                           double z_lo_m, double z_hi_m, int azimuths, int heights) {
  VortexSample v;
  v.radius_m = radius_m;
  for (int h = 0; h < heights; ++h) {
    const double z = z_lo_m + (z_hi_m - z_lo_m) * (h + 0.5) / heights;
    for (int a = 0; a < azimuths; ++a) {
      const double phi = 2.0 * std::numbers::pi * (a + 0.5) / azimuths;
      const Vec3 radial{std::cos(phi), std::sin(phi), 0.0}, tangent{-radial.y, radial.x, 0.0};
      const Vec3 u = gas.velocity_at(mill.axis_point_m + radial * radius_m + Vec3{0.0, 0.0, z});
      v.tangential_m_per_s += dot(u, tangent);
      v.radial_m_per_s += dot(u, radial);
      ++v.points;
    }
  }
  if (v.points > 0) {
    v.tangential_m_per_s /= double(v.points);
    v.radial_m_per_s /= double(v.points);
  }
  return v;
}

double force_balance_cut_size_m(double viscosity_pa_s, double particle_density_kg_per_m3,
                                double gas_density_kg_per_m3, const VortexSample& v) {
  const double ut2 = v.tangential_m_per_s * v.tangential_m_per_s;
  const double drho = particle_density_kg_per_m3 - gas_density_kg_per_m3;
  if (ut2 <= 0.0 || drho <= 0.0) return 0.0;
  return std::sqrt(18.0 * viscosity_pa_s * std::abs(v.radial_m_per_s) * v.radius_m / (drho * ut2));
}

VortexExponent vortex_exponent(const std::vector<VortexSample>& samples, std::size_t first,
                               std::size_t last) {
  VortexExponent e;
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  for (std::size_t k = first; k <= last && k < samples.size(); ++k) {
    const VortexSample& v = samples[k];
    if (!(v.tangential_m_per_s > 0.0) || !(v.radius_m > 0.0)) continue;
    const double x = std::log(v.radius_m), y = std::log(v.tangential_m_per_s);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
    if (e.points == 0) e.from_radius_m = v.radius_m;
    e.to_radius_m = v.radius_m;
    ++e.points;
  }
  const double m = double(e.points), spread = m * sxx - sx * sx;
  if (e.points >= 2 && spread > 0.0) e.n = -(m * sxy - sx * sy) / spread;
  return e;
}

namespace {

// The size where `share` first falls through `level` from the fine end, interpolated in log size.
std::optional<double> falls_through(const std::vector<double>& size_m,
                                    const std::vector<double>& share, double level) {
  for (std::size_t k = 0; k + 1 < size_m.size(); ++k) {
    const double a = share[k], b = share[k + 1];
    if (a >= level && b < level) {
      const double t = (a - level) / (a - b);
      return std::exp(std::log(size_m[k]) + t * std::log(size_m[k + 1] / size_m[k]));
    }
  }
  return std::nullopt;
}

}  // namespace

GradeEfficiency grade_efficiency(const PsdTally& outlet, const PsdTally& retained) {
  GradeEfficiency g;
  for (std::size_t b = 0; b + 1 < outlet.edges_m.size(); ++b) {
    const double out = outlet.mass_kg[b], kept = retained.mass_kg[b];
    if (out + kept <= 0.0) continue;
    g.size_m.push_back(std::sqrt(outlet.edges_m[b] * outlet.edges_m[b + 1]));
    g.outlet_kg.push_back(out);
    g.retained_kg.push_back(kept);
    g.share_to_outlet.push_back(out / (out + kept));
  }
  g.cut_size_m = falls_through(g.size_m, g.share_to_outlet, 0.5);
  for (double t : g.share_to_outlet) g.max_share = std::max(g.max_share, t);
  if (g.max_share > 0.0)
    g.reduced_cut_size_m = falls_through(g.size_m, g.share_to_outlet, 0.5 * g.max_share);
  return g;
}

}  // namespace millsim
