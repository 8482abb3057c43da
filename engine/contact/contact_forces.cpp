#include "contact/contact_forces.h"

#include "contact/contact_law.h"

namespace millsim {
namespace {

// Tangential spring, friction and torques of one contact; returns the tangential force on the
// first body. `n` points from the second body to the first; v_t is the tangential slip velocity.
inline Vec3 tangential_force(const PairSprings& s, double sqrt_overlap, double normal_force,
                             double friction, const Vec3& n, const Vec3& v_t, double dt,
                             Vec3& history) {
  // Keep the stored displacement in the current tangent plane, with its length (rotation).
  const double len2 = norm2(history);
  if (len2 > 0.0) {
    history -= n * dot(history, n);
    const double new_len2 = norm2(history);
    if (new_len2 > 0.0) history *= std::sqrt(len2 / new_len2);
  }
  history += v_t * dt;
  const double kt = s.tangential_stiffness * sqrt_overlap;
  const double etat = s.tangential_damping * std::sqrt(sqrt_overlap);
  const double ft_max = friction * normal_force;
  const Vec3 spring = -(history * kt);
  const double spring2 = norm2(spring);
  if (spring2 > ft_max * ft_max) {
    // Gross sliding: the spring alone has reached μ F_n. It is held there (the slip it stores
    // stays what μ F_n stretches it to, opposite the slip) and the force is μ F_n, with no
    // damping: a sliding contact dissipates through friction alone (LIGGGHTS's history model).
    // Folding the damper into the stored spring instead, as LAMMPS's rescaling does, leaves the
    // spring pointing along the slip early in a contact, where damping exceeds μ F_n, and the
    // sliding force then falls short of μ F_n (a gross-sliding impact's tangential impulse came
    // out at 0.78–0.88 μ J_n; tests/physics/oblique_impact_test.cpp).
    const double scale = ft_max / std::sqrt(spring2);
    history *= scale;
    return spring * scale;
  }
  // Sticking: spring and damper, with the total never beyond Coulomb's limit (early in a contact
  // the damper can exceed it before the spring has built up); the spring is left as it is.
  Vec3 ft = spring - v_t * etat;
  const double ft2 = norm2(ft);
  if (ft2 > ft_max * ft_max) ft *= ft_max / std::sqrt(ft2);
  return ft;
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
    const double dist = std::sqrt(dist2);
    double overlap = rsum - dist;
    const bool ghost = before == kPairGhost;
    if (ghost) {
      // Born overlapping: only overlap beyond the remembered birth overlap (history[k][0], which
      // follows the overlap down as the pair separates) pushes back (neighbor_list.h).
      double& memory = pool[history[k]][0];
      memory = std::min(memory, overlap);
      overlap -= memory;
      if (overlap <= 0.0) return;
    } else {
      touching_flag[k] = kPairTouching;
      if (history[k] == kNoHistory) history[k] = pool.take({});
    }
    ++touching;
    const Vec3 n = d * (1.0 / dist);
    const double sqrt_overlap = std::sqrt(overlap);
    const PairConstants& pc = materials.pair(mat[i], mat[j]);
    const PairSprings s = law(i, j, pc);

    // Velocity of the contact point of i relative to j; contact point at −r_i n from i, +r_j n
    // from j.
    const Motion &mi = motion[i], &mj = motion[j];
    const Vec3 v_rel =
        mi.velocity_m_per_s - mj.velocity_m_per_s -
        cross(mi.angular_velocity_rad_per_s * r[i] + mj.angular_velocity_rad_per_s * r[j], n);
    const double vn = dot(v_rel, n);
    const Vec3 v_t = v_rel - n * vn;
    if (before == kPairApart && vn < 0.0 && stats.record_impacts)
      stats.impacts.push_back({i, j, false, -vn, norm(v_t)});
    const double fn = hertz_normal_force_n(s, overlap, sqrt_overlap, vn);
    const Vec3 ft =
        ghost ? Vec3{}
              : tangential_force(s, sqrt_overlap, fn, pc.friction, n, v_t, dt, pool[history[k]]);
    const Vec3 force = n * fn + ft;
    Load &li = load[i], &lj = load[j];
    li.force_n += force;
    lj.force_n -= force;
    const Vec3 n_cross_ft = cross(n, ft);
    li.torque_n_m -= n_cross_ft * (r[i] - 0.5 * overlap);
    lj.torque_n_m -= n_cross_ft * (r[j] - 0.5 * overlap);
    if (pc.rolling_friction > 0.0) {
      // Constant directional torque (Zhou et al. 1999): −μ_r R* F_n ω_rel/|ω_rel|.
      const Vec3 w_rel = mi.angular_velocity_rad_per_s - mj.angular_velocity_rad_per_s;
      const double w_len = norm(w_rel);
      if (w_len > 0.0) {
        const Vec3 t = w_rel * (pc.rolling_friction * (r[i] * r[j] / rsum) * fn / w_len);
        li.torque_n_m -= t;
        lj.torque_n_m += t;
      }
    }
    const double ratio = overlap / (2.0 * std::min(r[i], r[j]));
    if (ratio > limit) stats.pairs_over_limit.push_back(std::uint32_t(k));
    if (ratio > max_ratio) max_ratio = ratio, max_pair = k;
  };
  // A lean pass over a chunk of candidates keeps those that touch or touched at the last pass (a
  // few percent). Second partners lie behind in memory, mostly still in cache; the few far ones
  // are fetched some candidates ahead. Then everything the kept contacts read is fetched, and
  // only they go through the contact law.
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
          const char* m = reinterpret_cast<const char*>(&motion[a]);
          const char* l = reinterpret_cast<const char*>(&load[a]);
          law.prefetch(a);
          __builtin_prefetch(m), __builtin_prefetch(m + sizeof(Motion) - 1);
          __builtin_prefetch(l), __builtin_prefetch(l + sizeof(Load) - 1);
          __builtin_prefetch(&mat[a]);
        }
        if (history[k] != kNoHistory) __builtin_prefetch(&pool[history[k]]);
      }
      for (std::size_t h = 0; h < n; ++h) visit(chunk + kept[h]);
    }
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
    if (overlap <= 0.0) {
      // Restitution below 0.05: the particle leaves with that share of its normal speed.
      const double scale = materials.wall_pair(wall.pair_table, p.material[i]).separation_scale;
      const double vn = dot(p.motion[i].velocity_m_per_s, n);
      if (nl.wall_touching[k] == kPairTouching && scale < 1.0 && vn > 0.0 &&
          p.inv_mass_per_kg[i] > 0.0)
        p.load[i].force_n -= n * separation_force_n(scale, vn, p.inv_mass_per_kg[i], dt);
      nl.wall_history_m[k] = {};
      nl.wall_touching[k] = kPairApart;
      continue;
    }
    const bool onset = nl.wall_touching[k] == kPairApart;
    const bool ghost = nl.wall_touching[k] == kPairGhost;
    if (ghost) {  // born deep in the wall: overlap memory, as for particle pairs
      double& memory = nl.wall_history_m[k][0];
      memory = std::min(memory, overlap);
      overlap -= memory;
      if (overlap <= 0.0) continue;
    } else {
      nl.wall_touching[k] = kPairTouching;
    }
    ++touching;
    const PairConstants& pc = materials.wall_pair(wall.pair_table, p.material[i]);
    const PairSprings s = wall_springs(p, i, pc);
    const double sqrt_overlap = std::sqrt(overlap);
    const Vec3 v_rel =
        p.motion[i].velocity_m_per_s - cross(p.motion[i].angular_velocity_rad_per_s * r, n);
    const double vn = dot(v_rel, n);
    const Vec3 v_t = v_rel - n * vn;
    if (onset && vn < 0.0 && stats.record_impacts)
      stats.impacts.push_back({i, nl.wall_index[k], true, -vn, norm(v_t)});
    const double fn = hertz_normal_force_n(s, overlap, sqrt_overlap, vn);
    const Vec3 ft = ghost ? Vec3{}
                          : tangential_force(s, sqrt_overlap, fn, pc.friction, n, v_t, dt,
                                             nl.wall_history_m[k]);
    p.load[i].force_n += n * fn + ft;
    p.load[i].torque_n_m -= cross(n, ft) * (r - 0.5 * overlap);
    if (pc.rolling_friction > 0.0) {
      const Vec3& w = p.motion[i].angular_velocity_rad_per_s;
      const double w_len = norm(w);
      if (w_len > 0.0) p.load[i].torque_n_m -= w * (pc.rolling_friction * r * fn / w_len);
    }
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
    const double overlap =
        p.radius_m[i] + p.radius_m[j] - dist - (ghost ? nl.pair_history_m(k)[0] : 0.0);
    if (overlap <= 0.0) continue;
    const PairConstants& pc = materials.pair(p.material[i], p.material[j]);
    const PairSprings s = model == ContactModel::SeriesSprings  ? series_law(i, j, pc)
                          : model == ContactModel::PaperSprings ? paper_law(i, j, pc)
                                                                : equivalent_law(i, j, pc);
    energy += 0.4 * s.normal_stiffness * overlap * overlap * std::sqrt(overlap);
    if (!ghost)
      energy += 0.5 * s.tangential_stiffness * std::sqrt(overlap) * norm2(nl.pair_history_m(k));
  }
  for (std::size_t k = 0; k < nl.wall_particle.size(); ++k) {
    const std::uint32_t i = nl.wall_particle[k];
    const Wall& wall = walls[nl.wall_index[k]];
    const bool ghost = nl.wall_touching[k] == kPairGhost;
    const double overlap =
        p.radius_m[i] - wall_gap_m(wall, p.position_m[i]) - (ghost ? nl.wall_history_m[k][0] : 0.0);
    if (overlap <= 0.0) continue;
    const PairSprings s = wall_springs(p, i, materials.wall_pair(wall.pair_table, p.material[i]));
    energy += 0.4 * s.normal_stiffness * overlap * overlap * std::sqrt(overlap);
    if (!ghost)
      energy += 0.5 * s.tangential_stiffness * std::sqrt(overlap) * norm2(nl.wall_history_m[k]);
  }
  return energy;
}

}  // namespace millsim
