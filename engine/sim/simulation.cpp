#include "sim/simulation.h"

#include <algorithm>
#include <cmath>

#include "dem/integrator.h"
#include "dem/time_step.h"
#include "particles/particle_sources.h"

namespace millsim {
namespace {

// Collects every source's particles; reports problems per source path.
void add_sources(const SceneConfig& scene, const MaterialTable& materials, const PeriodicBox& box,
                 ParticleStore& out, InputErrors& errors) {
  Rng rng(scene.seed);
  std::vector<ParticleSpec> all;
  std::vector<int> material_of;
  for (std::size_t s = 0; s < scene.sources.size(); ++s) {
    const SourceConfig& source = scene.sources[s];
    const std::string path = concat("/sources/", s);
    std::vector<ParticleSpec> specs;
    switch (source.kind) {
      case SourceKind::List:
        specs = source.particles;
        break;
      case SourceKind::File:
        try {
          specs = read_particle_file(source.file_path).particles;
        } catch (const InputErrorList& e) {
          for (const InputError& err : e.errors()) errors.push_back(err);
        } catch (const IoError& e) {
          errors.push_back({path + "/path", source.file_path.string(), e.what()});
        }
        break;
      case SourceKind::Random:
        specs = random_packing(source, box, all, rng, path + "/count", errors);
        break;
    }
    for (const ParticleSpec& p : specs) all.push_back(p), material_of.push_back(source.material);
  }
  out.reserve(all.size());
  for (std::size_t k = 0; k < all.size(); ++k)
    out.add(materials, material_of[k], ParticleId(k + 1), all[k].position_m,
            all[k].velocity_m_per_s, all[k].angular_velocity_rad_per_s, all[k].diameter_m);
}

void check_inside_domain(const SceneConfig& scene, ParticleStore& p, const PeriodicBox& box,
                         InputErrors& errors) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    box.wrap(p.position_m[i]);
    for (int a = 0; a < 3; ++a) {
      if (scene.domain.periodic[a]) continue;
      const double x = p.position_m[i][a];
      if (x < box.min_m[a] || x > box.max_m[a]) {
        errors.push_back({concat("particle ", p.id[i]), concat("x[", a, "] = ", x),
                          concat("expected the centre inside the domain [", box.min_m[a], ", ",
                                 box.max_m[a], "] on this non-periodic axis")});
        return;
      }
    }
  }
}

}  // namespace

Simulation::Simulation(const SceneConfig& scene)
    : materials_(scene),
      contact_model_(scene.contact.model),
      gravity_m_per_s2_(scene.gravity_m_per_s2) {
  InputErrors errors;
  box_ = {scene.domain.min_m, scene.domain.max_m, scene.domain.periodic};
  walls_ = build_walls(scene, materials_);
  add_sources(scene, materials_, box_, particles_, errors);
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  if (particles_.size() == 0)
    errors.push_back({"/sources", "", "the sources produced no particles"});
  check_inside_domain(scene, particles_, box_, errors);

  // Time step: Rayleigh bound of the smallest particle (per material).
  time_.rayleigh_min_s = 1e300;
  double d_min = 1e300, d_max = 0.0;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    const MaterialConstants& m = materials_.material(particles_.material[i]);
    const double t = rayleigh_time_s(particles_.radius_m[i], m.youngs_modulus_pa, m.poisson_ratio,
                                     m.density_kg_per_m3);
    if (t < time_.rayleigh_min_s)
      time_.rayleigh_min_s = t, time_.rayleigh_particle = particles_.id[i];
    d_min = std::min(d_min, 2.0 * particles_.radius_m[i]);
    d_max = std::max(d_max, 2.0 * particles_.radius_m[i]);
  }
  if (scene.time.step_s) {
    time_.automatic = false;
    time_.step_s = *scene.time.step_s;
    if (particles_.size() && time_.step_s > time_.rayleigh_min_s)
      errors.push_back({"/time/step_s", concat(time_.step_s),
                        concat("expected at most the Rayleigh time of the smallest particle, ",
                               time_.rayleigh_min_s, " s (particle ", time_.rayleigh_particle,
                               "); lower it or use \"auto\"")});
  } else {
    time_.step_s = scene.time.safety_factor * time_.rayleigh_min_s;
  }
  total_steps_ =
      std::max<std::int64_t>(1, std::int64_t(std::ceil(scene.time.end_s / time_.step_s - 1e-9)));
  if (particles_.size() && total_steps_ > 2'000'000'000LL)
    errors.push_back({"/time/end_s", concat(scene.time.end_s),
                      concat("expected at most 2e9 steps of ", time_.step_s, " s")});

  // Skin: a quarter of the smallest diameter unless set; the periodic minimum image needs each
  // periodic length to exceed 2 (d_max + skin).
  double skin = scene.search.skin_m.value_or(0.25 * d_min);
  for (int a = 0; a < 3 && particles_.size(); ++a) {
    if (!box_.periodic[a]) continue;
    if (box_.length(a) <= 2.0 * d_max)
      errors.push_back({concat("/domain/max_m/", a), concat(box_.max_m[a]),
                        concat("a periodic axis must be longer than twice the largest diameter (",
                               2.0 * d_max, " m)")});
    skin = std::min(skin, 0.5 * box_.length(a) - d_max);
  }
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  neighbors_ = NeighborList(std::max(skin, 0.0), scene.search.cell_size_m);
  neighbors_.update(particles_, box_, walls_, true);
  compute_forces();
}

void Simulation::compute_forces() {
  clear_forces(particles_, gravity_m_per_s2_);
  contact_stats_.max_overlap_ratio = 0.0;
  compute_pair_forces(contact_model_, materials_, box_, time_.step_s, particles_, neighbors_,
                      contact_stats_);
  compute_wall_forces(materials_, walls_, time_.step_s, particles_, neighbors_, contact_stats_);
}

void Simulation::refresh_forces() {
  neighbors_.update(particles_, box_, walls_, true);
  compute_forces();
}

std::optional<StepFailure> Simulation::step() {
  const double dt = time_.step_s;
  profile_.time(Phase::KickDrift, [&] {
    kick_drift(particles_, dt);
    if (box_.any_periodic())
      for (Vec3& x : particles_.position_m) box_.wrap(x);
  });
  profile_.time(Phase::Neighbors, [&] { neighbors_.update(particles_, box_, walls_, false); });
  profile_.time(Phase::Forces, [&] { compute_forces(); });
  profile_.time(Phase::Kick, [&] { kick(particles_, dt); });
  ++step_index_;
  std::optional<StepFailure> failure;
  if (step_index_ % 16 == 0 || step_index_ == total_steps_)
    profile_.time(Phase::Health, [&] { failure = check_health(); });
  return failure;
}

std::optional<StepFailure> Simulation::check_health() const {
  const ParticleStore& p = particles_;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (is_finite(p.position_m[i]) && is_finite(p.velocity_m_per_s[i]) &&
        is_finite(p.angular_velocity_rad_per_s[i]))
      continue;
    return StepFailure{
        step_index_, time_s(), p.id[i], "non_finite_state",
        concat("particle ", p.id[i], " (d = ", 2 * p.radius_m[i],
               " m) has a non-finite position or velocity; the time step ", time_.step_s,
               " s is likely too large for its contacts: lower "
               "/time/step_s or /time/safety_factor")};
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      if (box_.periodic[a]) continue;
      const double x = p.position_m[i][a], r = p.radius_m[i];
      if (x < box_.min_m[a] - r || x > box_.max_m[a] + r)
        return StepFailure{step_index_, time_s(), p.id[i], "particle_escaped",
                           concat("particle ", p.id[i], " (d = ", 2 * r,
                                  " m) left the domain "
                                  "through a wall on axis ",
                                  a, " at ", x,
                                  " m; its impact was "
                                  "too fast for the time step ",
                                  time_.step_s, " s: lower /time/safety_factor")};
    }
  if (contact_stats_.max_overlap_ratio > 0.5)
    return StepFailure{step_index_, time_s(), contact_stats_.max_overlap_particle,
                       "excessive_overlap",
                       concat("particle ", contact_stats_.max_overlap_particle,
                              " overlaps a "
                              "partner by ",
                              100.0 * contact_stats_.max_overlap_ratio,
                              " % of its diameter (limit 50 %): the contacts are too soft for "
                              "the impact speeds, or the time step is too large")};
  return std::nullopt;
}

EnergyReport Simulation::energy() const {
  EnergyReport e;
  const ParticleStore& p = particles_;
  for (std::size_t i = 0; i < p.size(); ++i) {
    e.kinetic_j += 0.5 * p.mass_kg[i] * norm2(p.velocity_m_per_s[i]);
    e.rotational_j += 0.5 * norm2(p.angular_velocity_rad_per_s[i]) / p.inv_inertia_per_kg_m2[i];
    e.potential_j -= p.mass_kg[i] * dot(gravity_m_per_s2_, p.position_m[i]);
  }
  e.elastic_j = contact_elastic_energy_j(contact_model_, materials_, box_, walls_, p, neighbors_);
  return e;
}

}  // namespace millsim
