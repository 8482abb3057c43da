// Feed inlet: inserts particles drawn from a size distribution into a region at a mass rate.
// Mass accrues at the rate while the feed is on; whenever it covers the next drawn particle, the
// particle is placed at a random position in the region that overlaps nothing (the region's
// current occupants are gathered once per insertion pass). A particle that finds no free place
// waits for the next step: the accrued mass is kept, and the blocked steps are counted.
#pragma once

#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "dem/box.h"
#include "particles/particle_store.h"
#include "scene/scene_config.h"

namespace millsim {

struct FeedStats {
  std::uint64_t inserted = 0;
  double inserted_mass_kg = 0.0;
  std::uint64_t blocked_steps = 0;
};

class Feeder {
 public:
  Feeder(const FeedConfig& config, double density_kg_per_m3, std::uint64_t seed);

  // Particles to insert at `time_s`, for the mass accrued since the last call.
  std::vector<ParticleSpec> take_due(double time_s, const ParticleStore& particles,
                                     const PeriodicBox& box);

  const FeedConfig& config() const { return config_; }
  const FeedStats& stats() const { return stats_; }
  double accrued_mass_kg() const { return accrued_kg_; }
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, rng_, accrued_kg_, accrued_until_s_, next_diameter_m_, stats_);
  }

 private:
  FeedConfig config_;
  double density_ = 0.0;
  Rng rng_;
  double accrued_kg_ = 0.0;
  double accrued_until_s_ = 0.0;
  double next_diameter_m_ = 0.0;
  FeedStats stats_;
};

// The mass rate the feeds deliver into each PSD slot of `edges_m` (the slots of
// process/mass_flows.h: below the first edge, each class, at or above the last), on average over
// [from_s, to_s]: each feed's rate times the share of the span it is on, times the mass share of
// its size distribution in the slot (mass_share_below). It is what the particles a window saw
// inserted sample: a feeder inserts a drawn particle once its accrued mass covers it, so over a
// long span it delivers its rate in mass with each size's share of it.
std::vector<double> declared_feed_kg_per_s(const std::vector<FeedConfig>& feeds,
                                           const std::vector<double>& edges_m, double from_s,
                                           double to_s);

}  // namespace millsim
