// NeighborList: candidate particle pairs and particle–wall pairs within a skin, rebuilt only when
// some particle has moved more than skin/2 since the last build (or particles were added or
// removed). Owns the tangential spring history of each candidate, aligned with the lists, and
// carries it across rebuilds by stable particle id. The contact set derived from it (overlap > 0)
// is exactly the all-pairs contact set: the rebuild rule guarantees no touching pair is missing.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "contact/walls.h"
#include "particles/particle_store.h"
#include "search/pair_search.h"

namespace millsim {

struct NeighborStats {
  std::uint64_t rebuilds = 0;
  std::uint64_t distance_tests = 0;
  SearchStats last_search;
};

class NeighborList {
 public:
  NeighborList() = default;
  NeighborList(double skin_m, std::optional<double> cell_size_m)
      : skin_m_(skin_m), cell_size_m_(cell_size_m) {}

  // Rebuilds when needed (or when `force`); returns true if it did.
  bool update(const ParticleStore& particles, const PeriodicBox& box,
              const std::vector<PlaneWall>& walls, bool force);

  double skin_m() const { return skin_m_; }
  const NeighborStats& stats() const { return stats_; }

  // Particle–particle candidates and their tangential spring displacement (m).
  PairList pairs;
  std::vector<Vec3> pair_history_m;
  // Particle–wall candidates.
  std::vector<std::uint32_t> wall_particle;
  std::vector<std::uint32_t> wall_index;
  std::vector<Vec3> wall_history_m;

 private:
  bool needs_rebuild(const ParticleStore& particles, const PeriodicBox& box) const;
  void rebuild(const ParticleStore& particles, const PeriodicBox& box,
               const std::vector<PlaneWall>& walls);

  double skin_m_ = 0.0;
  std::optional<double> cell_size_m_;
  std::vector<Vec3> reference_position_m_;
  std::vector<ParticleId> reference_id_;
  NeighborStats stats_;
};

}  // namespace millsim
