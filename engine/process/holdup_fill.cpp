#include "process/holdup_fill.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <unordered_map>

#include "process/mass_flows.h"

namespace millsim {
namespace {

// The particles held and the copies placed so far, hashed by cells of the largest diameter, so
// that an overlap is looked for in the 27 cells around a candidate only.
class OccupiedSpace {
 public:
  explicit OccupiedSpace(double cell_m) : cell_m_(cell_m) {}

  void add(const Vec3& x, double r) {
    centres_.push_back(x), radii_.push_back(r);
    cells_[key(cell_of(x))].push_back(std::uint32_t(centres_.size() - 1));
  }

  bool overlaps(const Vec3& x, double r) const {
    const std::array<std::int64_t, 3> c = cell_of(x);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == cells_.end()) continue;
          for (std::uint32_t k : it->second) {
            const double reach = r + radii_[k];
            if (norm2(centres_[k] - x) < reach * reach) return true;
          }
        }
    return false;
  }

 private:
  std::array<std::int64_t, 3> cell_of(const Vec3& x) const {
    return {std::int64_t(std::floor(x.x / cell_m_)), std::int64_t(std::floor(x.y / cell_m_)),
            std::int64_t(std::floor(x.z / cell_m_))};
  }
  static std::uint64_t key(const std::array<std::int64_t, 3>& c) {
    // 21 bits a coordinate: cells of a mill's largest particle span far fewer than 2^21.
    const auto bits = [](std::int64_t v) { return std::uint64_t(v) & ((1u << 21) - 1); };
    return bits(c[0]) | bits(c[1]) << 21 | bits(c[2]) << 42;
  }

  double cell_m_;
  std::vector<Vec3> centres_;
  std::vector<double> radii_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

}  // namespace

CopyPlan plan_copies(const ParticleStore& particles, const std::vector<double>& edges_m,
                     const std::vector<double>& deficit_kg, const Vec3& axis_point_m,
                     const std::function<bool(const Vec3&, double)>& clear_of_walls, Rng& rng) {
  const int slots = int(edges_m.size()) + 1;
  CopyPlan plan;
  plan.added_kg.assign(std::size_t(slots), 0.0);
  std::vector<std::vector<std::uint32_t>> held(static_cast<std::size_t>(slots));
  double largest_r = 0.0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    held[std::size_t(psd_slot(edges_m, 2.0 * particles.radius_m[i]))].push_back(std::uint32_t(i));
    largest_r = std::max(largest_r, particles.radius_m[i]);
  }
  OccupiedSpace space(std::max(2.0 * largest_r, 1e-12));
  for (std::size_t i = 0; i < particles.size(); ++i)
    space.add(particles.position_m[i], particles.radius_m[i]);

  for (int slot = slots - 1; slot >= 0; --slot) {  // coarsest first
    const double deficit = slot < int(deficit_kg.size()) ? deficit_kg[std::size_t(slot)] : 0.0;
    if (!(deficit > 0.0)) continue;
    const std::vector<std::uint32_t>& sources = held[std::size_t(slot)];
    if (sources.empty()) {
      plan.without_source.push_back(slot);
      continue;
    }
    double& added = plan.added_kg[std::size_t(slot)];
    int failed = 0;
    // The next copy's source is drawn first: add it while it brings the slot closer to its target.
    std::uint32_t source =
        sources[std::size_t(uniform01(rng) * double(sources.size())) % sources.size()];
    while (added + 0.5 * particles.mass_kg[source] < deficit) {
      const double angle = 2.0 * std::numbers::pi * uniform01(rng);
      const double r = particles.radius_m[source];
      const Vec3 x =
          axis_point_m + turned_about_z(particles.position_m[source] - axis_point_m, angle);
      if (clear_of_walls(x, r) && !space.overlaps(x, r)) {
        const Motion& m = particles.motion[source];
        plan.copies.push_back({source, x, turned_about_z(m.velocity_m_per_s, angle),
                               turned_about_z(m.angular_velocity_rad_per_s, angle)});
        space.add(x, r);
        added += particles.mass_kg[source];
        failed = 0;
      } else {
        ++plan.rejected_draws;
        if (++failed >= kMaxDrawsPerCopy) {
          plan.out_of_room.push_back(slot);
          break;
        }
      }
      source = sources[std::size_t(uniform01(rng) * double(sources.size())) % sources.size()];
    }
  }
  return plan;
}

RemovalPlan plan_removals(const ParticleStore& particles, const std::vector<double>& edges_m,
                          const std::vector<double>& excess_kg, Rng& rng) {
  const int slots = int(edges_m.size()) + 1;
  RemovalPlan plan;
  plan.removed_kg.assign(std::size_t(slots), 0.0);
  std::vector<std::vector<std::uint32_t>> held(static_cast<std::size_t>(slots));
  for (std::size_t i = 0; i < particles.size(); ++i)
    held[std::size_t(psd_slot(edges_m, 2.0 * particles.radius_m[i]))].push_back(std::uint32_t(i));
  for (int slot = 0; slot < slots; ++slot) {
    const double excess = slot < int(excess_kg.size()) ? excess_kg[std::size_t(slot)] : 0.0;
    std::vector<std::uint32_t>& pool = held[std::size_t(slot)];
    double& removed = plan.removed_kg[std::size_t(slot)];
    // Drawn without replacement: a partial Fisher–Yates shuffle of the slot's particles.
    for (std::size_t k = 0; excess > 0.0 && k < pool.size(); ++k) {
      const std::size_t pick = k + std::size_t(uniform01(rng) * double(pool.size() - k));
      std::swap(pool[k], pool[std::min(pick, pool.size() - 1)]);
      const double m = particles.mass_kg[pool[k]];
      if (!(removed + 0.5 * m < excess)) break;
      removed += m;
      plan.particles.push_back(pool[k]);
    }
  }
  std::sort(plan.particles.begin(), plan.particles.end(), std::greater<>());
  return plan;
}

std::vector<double> relaxed_target_kg(const std::vector<double>& held_kg,
                                      const std::vector<double>& projected_kg, double omega) {
  std::vector<double> target(projected_kg.size(), 0.0);
  for (std::size_t c = 0; c < target.size(); ++c) {
    const double from = c < held_kg.size() ? held_kg[c] : 0.0, to = projected_kg[c];
    if (omega >= 1.0)
      target[c] = to;
    else if (from > 0.0 && to > 0.0)
      target[c] = std::exp((1.0 - omega) * std::log(from) + omega * std::log(to));
    else
      target[c] = (1.0 - omega) * from + omega * to;
  }
  return target;
}

}  // namespace millsim
