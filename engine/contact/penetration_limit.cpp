#include "contact/penetration_limit.h"

#include <cmath>
#include <map>
#include <mutex>
#include <numbers>

#include "particles/restitution.h"

namespace millsim {

std::uint64_t apply_penetration_limiter(const ContactStepStats& stats,
                                        const MaterialTable& materials, const PeriodicBox& box,
                                        const std::vector<Wall>& walls, const NeighborList& nl,
                                        ParticleStore& p) {
  std::uint64_t events = 0;
  for (std::uint32_t k : stats.pairs_over_limit) {
    const std::uint32_t i = nl.pairs.first[k], j = nl.pairs.second[k];
    const Vec3 d = box.minimum_image(p.position_m[i] - p.position_m[j]);
    const Vec3 n = d * (1.0 / norm(d));
    const double vn = dot(p.motion[i].velocity_m_per_s - p.motion[j].velocity_m_per_s, n);
    if (vn >= 0.0) continue;  // already separating
    const double e = materials.pair(p.material[i], p.material[j]).restitution;
    const double reduced_mass = 1.0 / (p.inv_mass_per_kg[i] + p.inv_mass_per_kg[j]);
    const Vec3 impulse = n * (-(1.0 + e) * vn * reduced_mass);  // (§4, Eq. 8): v_n → −e v_n
    p.motion[i].velocity_m_per_s += impulse * p.inv_mass_per_kg[i];
    p.motion[j].velocity_m_per_s -= impulse * p.inv_mass_per_kg[j];
    ++events;
  }
  for (std::uint32_t k : stats.walls_over_limit) {
    const std::uint32_t i = nl.wall_particle[k];
    const Wall& wall = walls[nl.wall_index[k]];
    Vec3 normal;
    wall_gap_m(wall, p.position_m[i], normal);
    const double vn = dot(p.motion[i].velocity_m_per_s, normal);
    if (vn >= 0.0) continue;
    const double e = materials.wall_pair(wall.pair_table, p.material[i]).restitution;
    p.motion[i].velocity_m_per_s -= normal * ((1.0 + e) * vn);  // (§4, Eq. 8)
    ++events;
  }
  return events;
}

double hertz_max_overlap_m(double m, double k, double v) {
  return std::pow(5.0 * m * v * v / (4.0 * k), 0.4);
}

double eq13_max_overlap_m(double m, double k, double v, double e) {
  const double log_e = std::log(e), pi = std::numbers::pi;
  const double gamma = -log_e / std::sqrt(pi * pi + log_e * log_e);
  return (0.73 + 0.27 * (e - gamma)) * hertz_max_overlap_m(m, k, v);
}

double predicted_max_overlap_m(DampingModel model, double m, double k, double v, double e) {
  if (model == DampingModel::Paper) return eq13_max_overlap_m(m, k, v, e);
  static std::mutex mutex;
  static std::map<double, double> x_max;  // dimensionless max overlap per restitution
  double x;
  {
    std::lock_guard lock(mutex);
    auto it = x_max.find(e);
    if (it == x_max.end())
      it = x_max
               .emplace(e,
                        simulate_dimensionless_impact(damping_ratio_for_restitution(e)).max_overlap)
               .first;
    x = it->second;
  }
  return x * std::pow(m * v * v / k, 0.4);
}

}  // namespace millsim
