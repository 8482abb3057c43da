#include "contact/contact_forces.h"

#include "contact/contact_law.h"
#include "contact/curved_contact.h"
#include "geometry/surface.h"

namespace millsim {
namespace {

// The overlap that pushes back in a contact born overlapping (kPairGhost): it remembers its
// birth overlap (`memory`, which follows the overlap down as the partners separate), and only the
// overlap beyond it counts (neighbor_list.h). ≤ 0 when nothing pushes.
inline double ghost_overlap_m(double overlap, double& memory) {
  memory = std::min(memory, overlap);
  return overlap - memory;
}

// The wall's springs at the particle's contact point: R_e from the surface's curvature there.
inline PairSprings wall_springs_at(const ParticleStore& p, std::size_t i, const Wall& wall,
                                   const PairConstants& pc) {
  const double r_e = equivalent_contact_radius_m(
      p.radius_m[i], surface_curvature_per_m(wall.surface, p.position_m[i]));
  return wall_springs(p, i, pc, r_e);
}

// The pair loop's memory pipeline, apart from the physics: a lean pass over a chunk of
// candidates keeps those that touch or touched at the last pass (a few percent). Second partners
// lie behind in memory, mostly still in cache; the few far ones are fetched some candidates
// ahead. Then everything the kept contacts read is fetched, and only they are visited.
template <class Law, bool kPeriodic, class Visit>
void for_each_contact_candidate(const Law& law, const ParticleStore& p, const NeighborList& nl,
                                Visit&& visit) {
  const std::uint32_t* first = nl.pairs.first.data();
  const std::uint32_t* second = nl.pairs.second.data();
  const std::uint32_t* history = nl.pair_history.data();
  const std::uint8_t* touching_flag = nl.pair_touching.data();
  const Vec3* x = p.position_m.data();
  const double* r = p.radius_m.data();
  constexpr std::size_t kChunk = 256, kPrefetchAhead = 64;
  std::uint32_t kept[kChunk];
  for (const NeighborList::PairRange& range : nl.active_ranges())
    for (std::size_t chunk = range.begin; chunk < range.end; chunk += kChunk) {
      const std::size_t chunk_end = std::min(range.end, chunk + kChunk);
      std::size_t n = 0;
      for (std::size_t k = chunk; k < chunk_end; ++k) {
        if (k + kPrefetchAhead < range.end) {
          __builtin_prefetch(&x[second[k + kPrefetchAhead]]);
          __builtin_prefetch(&r[second[k + kPrefetchAhead]]);
        }
        const std::uint32_t i = first[k], j = second[k];
        Vec3 d = x[i] - x[j];
        if constexpr (kPeriodic) d -= nl.pair_shift(k);
        const double rsum = r[i] + r[j];
        kept[n] = std::uint32_t(k - chunk);
        n += (norm2(d) < rsum * rsum) | (touching_flag[k] != kPairApart);
      }
      for (std::size_t h = 0; h < n; ++h) {
        const std::size_t k = chunk + kept[h];
        for (const std::uint32_t a : {first[k], second[k]}) {
          // A 48-byte record may span two cache lines: fetch its first and last byte.
          const char* m = reinterpret_cast<const char*>(&p.motion[a]);
          const char* l = reinterpret_cast<const char*>(&p.load[a]);
          law.prefetch(a);
          __builtin_prefetch(m), __builtin_prefetch(m + sizeof(Motion) - 1);
          __builtin_prefetch(l), __builtin_prefetch(l + sizeof(Load) - 1);
          __builtin_prefetch(&p.material[a]);
        }
        if (history[k] != kNoHistory) __builtin_prefetch(&nl.history_pool[history[k]]);
      }
      for (std::size_t h = 0; h < n; ++h) visit(chunk + kept[h]);
    }
}

template <class Law, bool kPeriodic>
void pair_loop(const Law& law, const MaterialTable& materials, double dt, double limit,
               ParticleStore& p, NeighborList& nl, ContactStepStats& stats) {
  const std::uint32_t* first = nl.pairs.first.data();
  const std::uint32_t* second = nl.pairs.second.data();
  std::uint32_t* history = nl.pair_history.data();
  HistoryPool& pool = nl.history_pool;
  std::uint8_t* touching_flag = nl.pair_touching.data();
  const Vec3* x = p.position_m.data();
  const Motion* motion = p.motion.data();
  const double* r = p.radius_m.data();
  const std::uint16_t* mat = p.material.data();
  Load* load = p.load.data();
  std::uint64_t touching = 0;
  double max_ratio = 0.0;
  std::size_t max_pair = 0;

  // A contact of restitution below 0.05 ends keeping only that share of its normal separation
  // speed (particles/restitution.h): equal and opposite impulses along n, as a force over the
  // step; a frozen partner (no inverse mass) takes none of it.
  const double* inv_mass = p.inv_mass_per_kg.data();
  auto end_of_contact = [&](std::uint32_t i, std::uint32_t j, const Vec3& d, double dist) {
    const double scale = materials.pair(mat[i], mat[j]).separation_scale;
    const double inv_sum = inv_mass[i] + inv_mass[j];
    if (scale >= 1.0 || inv_sum <= 0.0) return;
    const Vec3 n = d * (1.0 / dist);
    const double vn = dot(motion[i].velocity_m_per_s - motion[j].velocity_m_per_s, n);
    if (vn <= 0.0) return;
    const Vec3 force = n * separation_force_n(scale, vn, inv_sum, dt);
    load[i].force_n -= force;
    load[j].force_n += force;
  };

  // The contact law on candidate k, which touches now or touched at the last pass.
  auto visit = [&](std::size_t k) {
    const std::uint32_t i = first[k], j = second[k];
    Vec3 d = x[i] - x[j];
    if constexpr (kPeriodic) d -= nl.pair_shift(k);
    const double dist2 = norm2(d), rsum = r[i] + r[j];
    if (dist2 >= rsum * rsum) {
      if (touching_flag[k]) {  // the contact ended: it forgets its history
        if (touching_flag[k] == kPairTouching) end_of_contact(i, j, d, std::sqrt(dist2));
        touching_flag[k] = kPairApart;
        if (history[k] != kNoHistory) pool.give_back(history[k]), history[k] = kNoHistory;
      }
      return;
    }
    const std::uint8_t before = touching_flag[k];
    const bool ghost = before == kPairGhost;
    const double dist = std::sqrt(dist2);
    if (!ghost) {
      touching_flag[k] = kPairTouching;
      if (history[k] == kNoHistory) history[k] = pool.take({});
    }
    double overlap = rsum - dist;
    if (ghost) overlap = ghost_overlap_m(overlap, pool[history[k]][0]);
    if (overlap <= 0.0) return;
    ++touching;
    const Vec3 n = d * (1.0 / dist);
    const PairConstants& pc = materials.pair(mat[i], mat[j]);
    // Velocity of the contact point of i relative to j; contact point at −r_i n from i, +r_j n
    // from j.
    const Motion &mi = motion[i], &mj = motion[j];
    const Vec3 v_rel =
        mi.velocity_m_per_s - mj.velocity_m_per_s -
        cross(mi.angular_velocity_rad_per_s * r[i] + mj.angular_velocity_rad_per_s * r[j], n);
    if (before == kPairApart && stats.record_impacts) {
      const double vn = dot(v_rel, n);
      if (vn < 0.0) stats.impacts.push_back({i, j, false, -vn, norm(v_rel - n * vn)});
    }
    const ContactResponse c =
        contact_response(law(i, j, pc), pc, overlap, n, v_rel,
                         mi.angular_velocity_rad_per_s - mj.angular_velocity_rad_per_s,
                         r[i] * r[j] / rsum, dt, ghost ? nullptr : &pool[history[k]]);
    const Vec3 force = n * c.normal_force_n + c.tangential_force_n;
    Load &li = load[i], &lj = load[j];
    li.force_n += force;
    lj.force_n -= force;
    const Vec3 n_cross_ft = cross(n, c.tangential_force_n);
    li.torque_n_m -= n_cross_ft * (r[i] - 0.5 * overlap) + c.rolling_torque_n_m;
    lj.torque_n_m -= n_cross_ft * (r[j] - 0.5 * overlap) - c.rolling_torque_n_m;
    const double ratio = overlap / (2.0 * std::min(r[i], r[j]));
    if (ratio > limit) stats.pairs_over_limit.push_back(std::uint32_t(k));
    if (ratio > max_ratio) max_ratio = ratio, max_pair = k;
  };
  for_each_contact_candidate<Law, kPeriodic>(law, p, nl, visit);
  stats.touching_pairs = touching;
  if (max_ratio > stats.max_overlap_ratio) {
    stats.max_overlap_ratio = max_ratio;
    const std::uint32_t i = first[max_pair], j = second[max_pair];
    const bool i_smaller = r[i] <= r[j];
    stats.max_overlap_particle = p.id[i_smaller ? i : j];
    stats.max_overlap_partner = p.id[i_smaller ? j : i];
    stats.max_overlap_wall = -1;
  }
}

template <class Law>
void pair_loop_any_box(const Law& law, const MaterialTable& materials, const PeriodicBox& box,
                       double dt, double limit, ParticleStore& p, NeighborList& nl,
                       ContactStepStats& stats) {
  if (box.any_periodic())
    pair_loop<Law, true>(law, materials, dt, limit, p, nl, stats);
  else
    pair_loop<Law, false>(law, materials, dt, limit, p, nl, stats);
}

}  // namespace

void compute_pair_forces(ContactModel model, const MaterialTable& materials, const PeriodicBox& box,
                         double dt, double limit, ParticleStore& p, NeighborList& nl,
                         ContactStepStats& stats) {
  switch (model) {
    case ContactModel::SeriesSprings:
      return pair_loop_any_box(SeriesSprings(p), materials, box, dt, limit, p, nl, stats);
    case ContactModel::PaperSprings:
      return pair_loop_any_box(PaperSprings(p), materials, box, dt, limit, p, nl, stats);
    case ContactModel::EquivalentProperties:
      return pair_loop_any_box(EquivalentProperties(p), materials, box, dt, limit, p, nl, stats);
  }
}

void compute_wall_forces(const MaterialTable& materials, const std::vector<Wall>& walls, double dt,
                         double limit, ParticleStore& p, NeighborList& nl,
                         ContactStepStats& stats) {
  std::uint64_t touching = 0;
  for (std::size_t k = 0; k < nl.wall_particle.size(); ++k) {
    const std::uint32_t i = nl.wall_particle[k];
    const Wall& wall = walls[nl.wall_index[k]];
    const double r = p.radius_m[i];
    Vec3 n;
    double overlap = r - wall_gap_m(wall, p.position_m[i], n);
    const PairConstants& pc = materials.wall_pair(wall.pair_table, p.material[i]);
    if (overlap <= 0.0) {
      // Restitution below 0.05: the particle leaves with that share of its normal speed.
      const double vn = dot(p.motion[i].velocity_m_per_s, n);
      if (nl.wall_touching[k] == kPairTouching && pc.separation_scale < 1.0 && vn > 0.0 &&
          p.inv_mass_per_kg[i] > 0.0)
        p.load[i].force_n -=
            n * separation_force_n(pc.separation_scale, vn, p.inv_mass_per_kg[i], dt);
      nl.wall_history_m[k] = {};
      nl.wall_touching[k] = kPairApart;
      continue;
    }
    const bool onset = nl.wall_touching[k] == kPairApart;
    const bool ghost = nl.wall_touching[k] == kPairGhost;
    if (ghost) {  // born deep in the wall: overlap memory, as for particle pairs
      overlap = ghost_overlap_m(overlap, nl.wall_history_m[k][0]);
      if (overlap <= 0.0) continue;
    } else {
      nl.wall_touching[k] = kPairTouching;
    }
    ++touching;
    const Motion& m = p.motion[i];
    const Vec3 v_rel = m.velocity_m_per_s - cross(m.angular_velocity_rad_per_s * r, n);
    if (onset && stats.record_impacts) {
      const double vn = dot(v_rel, n);
      if (vn < 0.0) stats.impacts.push_back({i, nl.wall_index[k], true, -vn, norm(v_rel - n * vn)});
    }
    const ContactResponse c = contact_response(wall_springs_at(p, i, wall, pc), pc, overlap, n,
                                               v_rel, m.angular_velocity_rad_per_s, r, dt,
                                               ghost ? nullptr : &nl.wall_history_m[k]);
    p.load[i].force_n += n * c.normal_force_n + c.tangential_force_n;
    p.load[i].torque_n_m -=
        cross(n, c.tangential_force_n) * (r - 0.5 * overlap) + c.rolling_torque_n_m;
    const double ratio = overlap / (2.0 * r);
    if (ratio > limit) stats.walls_over_limit.push_back(std::uint32_t(k));
    if (ratio > stats.max_overlap_ratio) {
      stats.max_overlap_ratio = ratio;
      stats.max_overlap_particle = p.id[i];
      stats.max_overlap_partner = 0;
      stats.max_overlap_wall = int(nl.wall_index[k]);
    }
  }
  stats.touching_walls = touching;
}

double contact_elastic_energy_j(ContactModel model, const MaterialTable& materials,
                                const PeriodicBox& box, const std::vector<Wall>& walls,
                                const ParticleStore& p, const NeighborList& nl) {
  const SeriesSprings series_law(p);
  const PaperSprings paper_law(p);
  const EquivalentProperties equivalent_law(p);
  double energy = 0.0;
  for (std::size_t k = 0; k < nl.pairs.size(); ++k) {
    const std::uint32_t i = nl.pairs.first[k], j = nl.pairs.second[k];
    const double dist = norm(box.minimum_image(p.position_m[i] - p.position_m[j]));
    const bool ghost = nl.pair_touching[k] == kPairGhost;
    const Vec3 history = nl.pair_history_m(k);
    const double overlap = p.radius_m[i] + p.radius_m[j] - dist - (ghost ? history[0] : 0.0);
    if (overlap <= 0.0) continue;
    const PairConstants& pc = materials.pair(p.material[i], p.material[j]);
    const PairSprings s = model == ContactModel::SeriesSprings  ? series_law(i, j, pc)
                          : model == ContactModel::PaperSprings ? paper_law(i, j, pc)
                                                                : equivalent_law(i, j, pc);
    energy += contact_elastic_energy_j(s, overlap, ghost ? nullptr : &history);
  }
  for (std::size_t k = 0; k < nl.wall_particle.size(); ++k) {
    const std::uint32_t i = nl.wall_particle[k];
    const Wall& wall = walls[nl.wall_index[k]];
    const bool ghost = nl.wall_touching[k] == kPairGhost;
    const double overlap =
        p.radius_m[i] - wall_gap_m(wall, p.position_m[i]) - (ghost ? nl.wall_history_m[k][0] : 0.0);
    if (overlap <= 0.0) continue;
    const PairConstants& pc = materials.wall_pair(wall.pair_table, p.material[i]);
    energy += contact_elastic_energy_j(wall_springs_at(p, i, wall, pc), overlap,
                                       ghost ? nullptr : &nl.wall_history_m[k]);
  }
  return energy;
}

}  // namespace millsim
