#include "search/neighbor_list.h"

#include <algorithm>

namespace millsim {
namespace {

struct KeyedHistory {
  std::uint64_t a, b;  // stable ids (particle ids, or particle id and wall index)
  Vec3 history;
  bool operator<(const KeyedHistory& o) const { return a != o.a ? a < o.a : b < o.b; }
};

const Vec3* lookup(const std::vector<KeyedHistory>& table, std::uint64_t a, std::uint64_t b) {
  auto it = std::lower_bound(table.begin(), table.end(), KeyedHistory{a, b, {}});
  return it != table.end() && it->a == a && it->b == b ? &it->history : nullptr;
}

}  // namespace

bool NeighborList::needs_rebuild(const ParticleStore& p, const PeriodicBox& box) const {
  if (reference_id_.size() != p.size()) return true;
  if (!std::equal(reference_id_.begin(), reference_id_.end(), p.id.begin())) return true;
  const double limit2 = 0.25 * skin_m_ * skin_m_;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (norm2(box.minimum_image(p.position_m[i] - reference_position_m_[i])) > limit2) return true;
  return false;
}

bool NeighborList::update(const ParticleStore& p, const PeriodicBox& box,
                          const std::vector<PlaneWall>& walls, bool force) {
  if (!force && !needs_rebuild(p, box)) return false;
  rebuild(p, box, walls);
  return true;
}

void NeighborList::rebuild(const ParticleStore& p, const PeriodicBox& box,
                           const std::vector<PlaneWall>& walls) {
  // Keep the history of pairs that have any (touching ones), keyed by stable ids.
  std::vector<KeyedHistory> old_pairs, old_walls;
  for (std::size_t k = 0; k < pairs.size(); ++k)
    if (norm2(pair_history_m[k]) > 0.0) {
      std::uint64_t a = reference_id_[pairs.first[k]], b = reference_id_[pairs.second[k]];
      old_pairs.push_back({std::min(a, b), std::max(a, b), pair_history_m[k]});
    }
  for (std::size_t k = 0; k < wall_particle.size(); ++k)
    if (norm2(wall_history_m[k]) > 0.0)
      old_walls.push_back({reference_id_[wall_particle[k]], wall_index[k], wall_history_m[k]});
  std::sort(old_pairs.begin(), old_pairs.end());
  std::sort(old_walls.begin(), old_walls.end());

  find_pairs_grid(p.position_m, p.radius_m, box, skin_m_, cell_size_m_, pairs, stats_.last_search);
  stats_.distance_tests += stats_.last_search.distance_tests;
  stats_.last_search.distance_tests = 0;
  pair_history_m.assign(pairs.size(), Vec3{});
  if (!old_pairs.empty())
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const std::uint64_t a = p.id[pairs.first[k]], b = p.id[pairs.second[k]];
      if (const Vec3* h = lookup(old_pairs, std::min(a, b), std::max(a, b))) pair_history_m[k] = *h;
    }

  wall_particle.clear(), wall_index.clear();
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t w = 0; w < walls.size(); ++w)
      if (wall_distance_m(walls[w], p.position_m[i]) < p.radius_m[i] + skin_m_)
        wall_particle.push_back(std::uint32_t(i)), wall_index.push_back(std::uint32_t(w));
  wall_history_m.assign(wall_particle.size(), Vec3{});
  if (!old_walls.empty())
    for (std::size_t k = 0; k < wall_particle.size(); ++k)
      if (const Vec3* h = lookup(old_walls, p.id[wall_particle[k]], wall_index[k]))
        wall_history_m[k] = *h;

  reference_position_m_ = p.position_m;
  reference_id_ = p.id;
  ++stats_.rebuilds;
}

}  // namespace millsim
