#include "comminution/breakage.h"

#include <algorithm>
#include <cmath>

#include "comminution/fragment_spawn.h"
#include "comminution/strength.h"
#include "contact/reduced_stiffness.h"

namespace millsim {

Breakage::Breakage(const SceneConfig& scene, const MaterialTable& materials,
                   std::optional<double> reduced_threshold_m, std::uint64_t seed,
                   std::vector<double> psd_edges_m)
    : materials_(&materials),
      equivalence_(scene.breakage ? scene.breakage->equivalence : ImpactEquivalence::Energy),
      placement_attempts_(scene.breakage ? scene.breakage->placement_attempts : 16),
      dust_threshold_m_(scene.dust ? scene.dust->threshold_diameter_m : 0.0),
      reduced_threshold_m_(reduced_threshold_m),
      rng_(seed),
      dust_(std::move(psd_edges_m)) {
  for (const MaterialConfig& m : scene.materials) {
    if (m.breakage)
      material_.push_back(Material{*m.breakage, FragmentSizeSampler(m.breakage->fragments)});
    else
      material_.emplace_back();
  }
  pools_.resize(material_.size());
}

void Breakage::draw_strength(ParticleStore& p, std::size_t slot) {
  const auto& m = material_[p.material[slot]];
  if (!m) return;
  // u in (0, 1]: 1 − uniform01 never returns 0.
  p.remaining_capacity_j_per_kg[slot] = capacity_from_uniform_j_per_kg(
      m->config.strength, 2.0 * p.radius_m[slot], 1.0 - uniform01(rng_));
}

double Breakage::impact_energy_j_per_kg(const Impact& impact, bool on_partner,
                                        const std::vector<Wall>& walls,
                                        const ParticleStore& p) const {
  const std::uint32_t i = on_partner ? impact.partner : impact.particle;
  const double c_i = materials_->material(p.material[i]).normal_compliance;
  double u;
  if (impact.with_wall) {
    const Wall& wall = walls[impact.partner];
    const double c_wall =
        materials_->wall_pair(wall.pair_table, p.material[i]).wall_normal_compliance;
    u = equivalent_speed_wall(equivalence_, c_i, c_wall, impact.speed_m_per_s);
  } else {
    const std::uint32_t j = on_partner ? impact.particle : impact.partner;
    u = equivalent_speed_pair(equivalence_, p.mass_kg[i], p.radius_m[i], c_i, p.mass_kg[j],
                              p.radius_m[j], materials_->material(p.material[j]).normal_compliance,
                              impact.speed_m_per_s);
  }
  return 0.5 * u * u;
}

bool Breakage::may_break(const std::vector<Impact>& impacts,
                         const std::vector<CrushedParticle>& crushed,
                         const std::vector<Wall>& walls, const ParticleStore& p) const {
  for (const CrushedParticle& c : crushed)
    if (material_[p.material[c.slot]]) return true;
  for (const Impact& impact : impacts)
    for (int side = 0; side < (impact.with_wall ? 1 : 2); ++side) {
      const std::uint32_t slot = side ? impact.partner : impact.particle;
      const auto& m = material_[p.material[slot]];
      if (m && impact_energy_j_per_kg(impact, side == 1, walls, p) >
                   threshold_energy_j_per_kg(m->config.strength, 2.0 * p.radius_m[slot]))
        return true;
    }
  return false;
}

std::uint64_t Breakage::process(const std::vector<Impact>& impacts,
                                const std::vector<CrushedParticle>& crushed, double dt_s,
                                double time_s, const std::vector<Wall>& walls,
                                const PeriodicBox& box, ParticleStore& p, ParticleId& next_id,
                                std::vector<Newborn>& newborn, const ParticleHook& before_removal,
                                const ParticleHook& after_addition) {
  std::vector<std::uint32_t> broken;
  std::vector<double> breaking_energy;  // per broken slot: its impact's, 0 when crushed
  std::vector<std::uint8_t> by_wall;    // per broken slot: its impact was on a wall
  for (const CrushedParticle& c : crushed)
    if (material_[p.material[c.slot]] &&
        std::find(broken.begin(), broken.end(), c.slot) == broken.end())
      broken.push_back(c.slot), breaking_energy.push_back(0.0), by_wall.push_back(c.against_wall),
          ++stats_.crush_events;
  for (const Impact& impact : impacts) {
    for (int side = 0; side < (impact.with_wall ? 1 : 2); ++side) {
      const std::uint32_t slot = side ? impact.partner : impact.particle;
      const auto& m = material_[p.material[slot]];
      if (!m || std::find(broken.begin(), broken.end(), slot) != broken.end()) continue;
      const double d = 2.0 * p.radius_m[slot];
      const double w = impact_energy_j_per_kg(impact, side == 1, walls, p);
      if (w <= threshold_energy_j_per_kg(m->config.strength, d)) continue;
      ++stats_.impacts;
      if (apply_impact(m->config, d, w, p.remaining_capacity_j_per_kg[slot]))
        broken.push_back(slot), breaking_energy.push_back(w), by_wall.push_back(impact.with_wall);
      else
        ++stats_.fatigue_impacts;
    }
  }
  if (broken.empty()) return 0;
  // A particle breaks at the onset of its impact, one step into the contact. Its fragments leave
  // the impact as it would have: the normal approach is turned into the rebound the pair's (or
  // wall's) restitution gives. Without this the fragments would carry on into the wall or the
  // partner at the full approach speed and break again next step, a cascade of spurious
  // generations within one impact.
  for (const Impact& impact : impacts) {
    const bool breaks_here =
        std::find(broken.begin(), broken.end(), impact.particle) != broken.end() ||
        (!impact.with_wall &&
         std::find(broken.begin(), broken.end(), impact.partner) != broken.end());
    if (breaks_here) complete_impact(impact, walls, box, p);
  }
  for (std::size_t k = 0; k < broken.size(); ++k) {
    BreakageEvent event;
    event.time_s = time_s;
    event.specific_energy_j_per_kg = breaking_energy[k];
    event.crushed = breaking_energy[k] == 0.0;
    event.by_wall = by_wall[k];
    break_particle(broken[k], dt_s, event, p, next_id, newborn, after_addition);
  }
  // Remove the parents from the highest slot down: each swap then moves in a particle that is
  // not a parent still to be removed.
  std::sort(broken.begin(), broken.end(), std::greater<>());
  for (std::uint32_t slot : broken) {
    before_removal(p, slot);
    p.remove_swap(slot);
  }
  return broken.size();
}

void Breakage::complete_impact(const Impact& impact, const std::vector<Wall>& walls,
                               const PeriodicBox& box, ParticleStore& p) {
  const std::uint32_t i = impact.particle;
  Vec3& vi = p.motion[i].velocity_m_per_s;
  if (impact.with_wall) {
    const Wall& wall = walls[impact.partner];
    Vec3 n;
    wall_gap_m(wall, p.position_m[i], n);
    const double vn = dot(vi, n);
    if (vn >= 0.0) return;
    const double e = materials_->wall_pair(wall.pair_table, p.material[i]).restitution;
    vi -= n * ((1.0 + e) * vn);
    stats_.completed_impacts += 1;
    return;
  }
  const std::uint32_t j = impact.partner;
  Vec3& vj = p.motion[j].velocity_m_per_s;
  const Vec3 d = box.minimum_image(p.position_m[i] - p.position_m[j]);
  const double dist = norm(d);
  if (dist <= 0.0) return;
  const Vec3 n = d * (1.0 / dist);
  const double vn = dot(vi - vj, n);
  if (vn >= 0.0) return;
  const double e = materials_->pair(p.material[i], p.material[j]).restitution;
  // From the inverse masses: a frozen partner (inverse mass 0) acts as a wall.
  const double reduced_mass = 1.0 / (p.inv_mass_per_kg[i] + p.inv_mass_per_kg[j]);
  const Vec3 impulse = n * (-(1.0 + e) * vn * reduced_mass);
  vi += impulse * p.inv_mass_per_kg[i];
  vj -= impulse * p.inv_mass_per_kg[j];
  stats_.completed_impacts += 1;
}

void Breakage::add_dust(const Vec3& x, double d, double mass, double number) {
  dust_.add(d, mass, number);
  if (flows_)
    flows_->moved(flows_parent_slot_, MassFlows::dust(psd_slot(dust_.edges_m, d), flows_->slots)) +=
        mass;
  if (record_dust_) fresh_dust_.push_back({x, d, mass, number});
}

std::uint64_t Breakage::spread_below_threshold(const FragmentSizeSampler& sampler, const Vec3& x,
                                               double parent_d, double density, double mass) {
  // By the size classes of the dust table below the threshold, each class's share from B, at the
  // class's geometric centre; the share below the first edge goes to the underflow.
  const double top = dust_threshold_m_ / parent_d;
  const double total = sampler.drawn_cumulative(top);
  if (mass <= 0.0) return 0;
  if (total <= 0.0) {  // rounding left over where B has no mass: at the threshold
    add_dust(x, dust_threshold_m_ * (1.0 - 1e-12), mass, 0.0);
    return 0;
  }
  double count = 0.0, lower_ratio = 0.0, lower_b = 0.0;
  const auto add_share = [&](double upper_ratio, double representative_d) {
    const double upper_b = sampler.drawn_cumulative(upper_ratio);
    const double share_mass = mass * (upper_b - lower_b) / total;
    if (share_mass > 0.0) {
      const double number = share_mass / sphere_mass_kg(density, representative_d);
      add_dust(x, representative_d, share_mass, number);
      count += number;
    }
    lower_ratio = upper_ratio;
    lower_b = upper_b;
  };
  const std::vector<double>& edges = dust_.edges_m;
  const double smallest = std::max(sampler.min_ratio(), 1e-5) * parent_d;
  if (smallest < edges.front()) {
    const double upper_d = std::min(edges.front(), top * parent_d);
    add_share(upper_d / parent_d, std::sqrt(smallest * upper_d));
  }
  for (std::size_t k = 0; k + 1 < edges.size() && lower_ratio < top; ++k) {
    if (edges[k + 1] / parent_d <= lower_ratio) continue;
    const double lo_d = std::max(edges[k], lower_ratio * parent_d);
    const double hi_d = std::min(edges[k + 1], top * parent_d);
    if (hi_d <= lo_d) continue;
    add_share(hi_d / parent_d, std::sqrt(lo_d * hi_d));
  }
  if (lower_ratio < top)
    add_share(top, std::sqrt(std::max(edges.back(), lower_ratio * parent_d) * top * parent_d));
  return std::uint64_t(std::llround(count));
}

void Breakage::break_particle(std::size_t slot, double dt_s, BreakageEvent event, ParticleStore& p,
                              ParticleId& next_id, std::vector<Newborn>& newborn,
                              const ParticleHook& after_addition) {
  const int material = p.material[slot];
  const Material& m = *material_[std::size_t(material)];
  const double density = materials_->material(material).density_kg_per_m3;
  const double parent_d = 2.0 * p.radius_m[slot];
  const Vec3 x = p.position_m[slot], v = p.motion[slot].velocity_m_per_s;
  const Vec3 w = p.motion[slot].angular_velocity_rad_per_s;
  const Vec3 force = p.load[slot].force_n, torque = p.load[slot].torque_n_m;
  const double parent_mass = p.mass_kg[slot];
  const ParticleId parent_id = p.id[slot];
  const std::uint64_t family = ++stats_.events;
  if (flows_) {
    flows_parent_slot_ = psd_slot(dust_.edges_m, parent_d);
    flows_->events[std::size_t(flows_parent_slot_)] += 1.0;
    if (event.by_wall) flows_->wall_events[std::size_t(flows_parent_slot_)] += 1.0;
  }
  stats_.broken_mass_kg += parent_mass;
  const int parent_generation = p.generation[slot];
  if (stats_.events_by_generation.size() <= std::size_t(parent_generation))
    stats_.events_by_generation.resize(std::size_t(parent_generation) + 1, 0);
  ++stats_.events_by_generation[std::size_t(parent_generation)];
  const int generation = std::min(parent_generation + 1, 255);
  stats_.max_generation = std::max(stats_.max_generation, generation);

  // Fragments below the dust threshold are never created: a last fragment below it goes to the
  // dust table as it is, and the breakage function's share below it is spread there by B.
  const FragmentDraw draw =
      m.sampler.draw(parent_d, dust_threshold_m_ / parent_d, pools_[std::size_t(material)], rng_);
  std::vector<double> kept_d;
  double kept_mass = 0.0, dust_fragment_mass = 0.0;
  for (double ratio : draw.ratios) {
    const double d = ratio * parent_d;
    const double mass = sphere_mass_kg(density, d);
    if (d >= dust_threshold_m_) {
      kept_d.push_back(d);
      kept_mass += mass;
      continue;
    }
    add_dust(x, d, mass, 1.0);
    dust_fragment_mass += mass;
    ++stats_.dust_fragments;
  }
  // The spread share is what the fragments leave of the parent: mass conserved to rounding.
  const double spread_mass = std::max(parent_mass - kept_mass - dust_fragment_mass, 0.0);
  stats_.dust_fragments += spread_below_threshold(m.sampler, x, parent_d, density, spread_mass);
  const double dust_mass = dust_fragment_mass + spread_mass;
  // The dust leaves with the parent's velocity and its share of the force in flight.
  dust_momentum_ += v * dust_mass + force * (0.5 * dt_s * dust_mass / parent_mass);
  const std::vector<Vec3> offset = place_fragments(kept_d, parent_d, placement_attempts_, rng_);
  for (std::size_t k = 0; k < kept_d.size(); ++k) {
    const double scale =
        reduced_threshold_m_ ? stiffness_scale(kept_d[k], *reduced_threshold_m_) : 1.0;
    const ParticleId id = next_id++;
    const std::size_t s = p.add(*materials_, material, id, x + offset[k], v + cross(w, offset[k]),
                                w, kept_d[k], scale);
    p.generation[s] = std::uint8_t(generation);
    const double share = p.mass_kg[s] / parent_mass;
    p.load[s].force_n = force * share;
    p.load[s].torque_n_m = torque * share;
    draw_strength(p, s);
    newborn.push_back({id, family, parent_id});
    after_addition(p, s);
    if (flows_)
      flows_->moved(flows_parent_slot_, psd_slot(dust_.edges_m, kept_d[k])) += p.mass_kg[s];
    ++stats_.fragments;
  }
  if (event_log_.size() < kMaxLoggedEvents) {
    event.position_m = x;
    event.parent_diameter_m = parent_d;
    event.dust_mass_kg = dust_mass;
    event.parent_id = parent_id;
    event.fragments = std::uint32_t(kept_d.size());
    event.generation = std::uint8_t(parent_generation);
    event_log_.push_back(event);
  }
}

}  // namespace millsim
