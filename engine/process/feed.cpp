#include "process/feed.h"

#include <algorithm>

#include "particles/particle_sources.h"

namespace millsim {
namespace {

constexpr int kPlacementAttempts = 64;

struct Sphere {
  Vec3 x;
  double r;
};

}  // namespace

Feeder::Feeder(const FeedConfig& config, double density, std::uint64_t seed)
    : config_(config), density_(density), rng_(seed) {
  next_diameter_m_ = sample_diameter(config_.sizes, rng_);
}

std::vector<ParticleSpec> Feeder::take_due(double t, const ParticleStore& p,
                                           const PeriodicBox& box) {
  std::vector<ParticleSpec> out;
  // The part of [last call, t] during which the feed was on.
  const double on_s = std::min(t, config_.end_s) - std::max(accrued_until_s_, config_.start_s);
  if (on_s > 0.0) accrued_kg_ += config_.mass_rate_kg_per_s * on_s;
  accrued_until_s_ = t;
  if (accrued_kg_ < sphere_mass_kg(density_, next_diameter_m_)) return out;

  // Occupants that could touch a new particle: centres within the region grown by the largest
  // radius present plus the largest feed radius (bounded by the next diameter and the sizes).
  double reach = 0.0;
  for (double r : p.radius_m) reach = std::max(reach, r);
  const double max_new_r =
      0.5 * std::max(next_diameter_m_, config_.sizes.kind == SizeDistributionKind::Fixed
                                           ? config_.sizes.diameter_m
                                           : config_.sizes.max_m);
  reach += max_new_r;
  std::vector<Sphere> near;
  for (std::size_t i = 0; i < p.size(); ++i) {
    Vec3 x = p.position_m[i];
    box.wrap(x);
    bool inside = true;
    for (int a = 0; a < 3 && inside; ++a)
      inside = x[a] > config_.region_min_m[a] - reach && x[a] < config_.region_max_m[a] + reach;
    if (inside) near.push_back({x, p.radius_m[i]});
  }

  while (accrued_kg_ >= sphere_mass_kg(density_, next_diameter_m_)) {
    const double r = 0.5 * next_diameter_m_;
    bool placed = false;
    Vec3 x;
    for (int attempt = 0; attempt < kPlacementAttempts && !placed; ++attempt) {
      for (int a = 0; a < 3; ++a) {
        const double lo = config_.region_min_m[a] + r, hi = config_.region_max_m[a] - r;
        x[a] = hi > lo ? lo + (hi - lo) * uniform01(rng_)
                       : 0.5 * (config_.region_min_m[a] + config_.region_max_m[a]);
      }
      placed = std::none_of(near.begin(), near.end(), [&](const Sphere& s) {
        return norm2(box.minimum_image(x - s.x)) < (r + s.r) * (r + s.r);
      });
    }
    if (!placed) {
      ++stats_.blocked_steps;
      break;
    }
    ParticleSpec spec;
    spec.position_m = x;
    spec.diameter_m = next_diameter_m_;
    spec.velocity_m_per_s = config_.velocity_m_per_s;
    if (config_.velocity_spread_m_per_s > 0.0)
      for (int a = 0; a < 3; ++a)
        spec.velocity_m_per_s[a] += gaussian(rng_, 0.0, config_.velocity_spread_m_per_s);
    out.push_back(spec);
    near.push_back({x, r});
    accrued_kg_ -= sphere_mass_kg(density_, next_diameter_m_);
    ++stats_.inserted;
    stats_.inserted_mass_kg += sphere_mass_kg(density_, next_diameter_m_);
    next_diameter_m_ = sample_diameter(config_.sizes, rng_);
  }
  return out;
}

std::vector<double> declared_feed_kg_per_s(const std::vector<FeedConfig>& feeds,
                                           const std::vector<double>& edges, double from_s,
                                           double to_s) {
  std::vector<double> rate(edges.size() + 1, 0.0);
  if (!(to_s > from_s)) return rate;
  for (const FeedConfig& feed : feeds) {
    const double on_s = std::min(to_s, feed.end_s) - std::max(from_s, feed.start_s);
    if (!(on_s > 0.0)) continue;
    const double mean_kg_per_s = feed.mass_rate_kg_per_s * on_s / (to_s - from_s);
    double below_previous = 0.0;
    for (std::size_t slot = 0; slot < rate.size(); ++slot) {
      const double below = slot < edges.size() ? mass_share_below(feed.sizes, edges[slot]) : 1.0;
      rate[slot] += mean_kg_per_s * (below - below_previous);
      below_previous = below;
    }
  }
  return rate;
}

}  // namespace millsim
