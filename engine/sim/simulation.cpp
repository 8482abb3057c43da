#include "sim/simulation.h"

#include <algorithm>
#include <cmath>

#include "contact/penetration_limit.h"
#include "contact/reduced_stiffness.h"
#include "dem/integrator.h"
#include "particles/particle_sources.h"

namespace millsim {
namespace {

struct SourceParticles {
  std::vector<ParticleSpec> specs;
  std::vector<int> material;
};

// Collects every source's particles; reports problems per source path.
SourceParticles collect_sources(const SceneConfig& scene, const PeriodicBox& box,
                                InputErrors& errors) {
  Rng rng(scene.seed);
  SourceParticles out;
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
        specs = random_packing(source, box, out.specs, rng, path + "/count", errors);
        break;
    }
    for (const ParticleSpec& p : specs)
      out.specs.push_back(p), out.material.push_back(source.material);
  }
  return out;
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
    : materials_(scene), contact_(scene.contact), gravity_m_per_s2_(scene.gravity_m_per_s2) {
  InputErrors errors;
  box_ = {scene.domain.min_m, scene.domain.max_m, scene.domain.periodic};
  walls_ = build_walls(scene, materials_);
  const SourceParticles sources = collect_sources(scene, box_, errors);
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  if (sources.specs.empty())
    throw InputErrorList({{"/sources", "", "the sources produced no particles"}});

  double d_min = 1e300, d_max = 0.0, fastest = 0.0;
  std::size_t smallest = 0;
  for (std::size_t k = 0; k < sources.specs.size(); ++k) {
    const double d = sources.specs[k].diameter_m;
    if (d < d_min) d_min = d, smallest = k;
    d_max = std::max(d_max, d);
    fastest = std::max(fastest, norm(sources.specs[k].velocity_m_per_s));
  }

  time_.impact_speed_m_per_s = contact_.max_impact_speed_m_per_s.value_or(
      default_max_impact_speed_m_per_s(fastest, gravity_m_per_s2_, box_));

  // Reduced stiffness (§4): the threshold first, so each particle gets its constants once.
  if (contact_.reduced_stiffness) {
    ReducedStiffnessInfo info;
    const int material = sources.material[smallest];
    const int wall = stiffest_wall(materials_, walls_);
    double wall_c = -1.0, e = materials_.material(material).restitution;
    if (wall >= 0) {
      const PairConstants& wp =
          materials_.wall_pair(walls_[std::size_t(wall)].pair_table, material);
      wall_c = wp.wall_normal_compliance;
      e = wp.restitution;
    }
    const PenetrationCase worst{
        &materials_.material(material), d_min, wall_c, e, time_.impact_speed_m_per_s,
        materials_.damping_model()};
    if (contact_.reduced_stiffness->threshold_diameter_m) {
      info.threshold_diameter_m = *contact_.reduced_stiffness->threshold_diameter_m;
      info.predicted_penetration_ratio =
          predicted_penetration_ratio(worst, stiffness_scale(d_min, info.threshold_diameter_m));
    } else {
      const ThresholdChoice choice = automatic_threshold(worst, d_max, contact_.penetration_limit);
      info.automatic = true;
      info.threshold_diameter_m = choice.threshold_diameter_m;
      info.predicted_penetration_ratio = choice.penetration_ratio;
      info.limited_by_real_stiffness = choice.limited_by_real_stiffness;
    }
    reduced_ = info;
  }
  particles_.reserve(sources.specs.size());
  for (std::size_t k = 0; k < sources.specs.size(); ++k) {
    const ParticleSpec& s = sources.specs[k];
    const double scale =
        reduced_ ? stiffness_scale(s.diameter_m, reduced_->threshold_diameter_m) : 1.0;
    if (scale < 1.0) ++reduced_->reduced_particles;
    particles_.add(materials_, sources.material[k], ParticleId(k + 1), s.position_m,
                   s.velocity_m_per_s, s.angular_velocity_rad_per_s, s.diameter_m, scale);
  }
  check_inside_domain(scene, particles_, box_, errors);
  choose_time_step(scene, errors);

  // Skin: ¼ √(d_min d_max) re-derived at each rebuild unless set (search/neighbor_list.cpp). The
  // periodic minimum image needs each periodic length to exceed 2 (d_max + skin).
  double max_skin = 1e300;
  for (int a = 0; a < 3; ++a) {
    if (!box_.periodic[a]) continue;
    if (box_.length(a) <= 2.0 * d_max)
      errors.push_back({concat("/domain/max_m/", a), concat(box_.max_m[a]),
                        concat("a periodic axis must be longer than twice the largest diameter (",
                               2.0 * d_max, " m)")});
    max_skin = std::min(max_skin, 0.5 * box_.length(a) - d_max);
  }
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  const bool automatic_skin = !scene.search.skin_m.has_value();
  neighbors_ =
      NeighborList({std::clamp(scene.search.skin_m.value_or(0.0), 0.0, max_skin), automatic_skin,
                    max_skin, scene.search.cell_size_m, scene.search.subcells_per_axis});
  neighbors_.update(particles_, box_, walls_, true);
  compute_forces();
  if (contact_stats_.max_overlap_ratio > contact_.penetration_limit)
    throw InputErrorList({{"/sources", "",
                           concat(describe_worst_overlap(), " at the start; at most ",
                                  100.0 * contact_.penetration_limit,
                                  " % is allowed (/contact/penetration_limit): move them apart, "
                                  "or use a random source, which never overlaps")}});

  const EnergyReport e0 = energy();
  energy_reference_j_ = e0.total_j();
  double mass = 0.0;
  for (double m : particles_.mass_kg) mass += m;
  double height = 0.0;
  const double g = norm(gravity_m_per_s2_);
  for (int a = 0; a < 3 && g > 0.0; ++a) {
    height += std::abs(gravity_m_per_s2_[a] / g) * box_.length(a);
    if (box_.periodic[a] && gravity_m_per_s2_[a] != 0.0) check_energy_ = false;  // no potential
  }
  energy_scale_j_ = e0.kinetic_j + e0.rotational_j + e0.elastic_j + mass * g * height + 1e-300;
}

void Simulation::choose_time_step(const SceneConfig& scene, InputErrors& errors) {
  const double v = time_.impact_speed_m_per_s;
  time_.bounds = time_step_bounds(particles_, materials_, walls_, v);
  const TimeStepBounds& b = time_.bounds;
  time_.stable_bound_s = std::min(b.rayleigh_s, b.contact_s / kMinStepsPerContact);
  const double automatic =
      std::min(scene.time.safety_factor * b.rayleigh_s, b.contact_s / scene.time.steps_per_contact);
  if (reduced_) {
    const TimeStepBounds real =
        time_step_bounds(particles_, materials_, walls_, v, /*at_real_stiffness=*/true);
    reduced_->time_step_gain = automatic / std::min(scene.time.safety_factor * real.rayleigh_s,
                                                    real.contact_s / scene.time.steps_per_contact);
  }
  if (scene.time.step_s) {
    time_.automatic = false;
    time_.step_s = *scene.time.step_s;
    if (time_.step_s > b.rayleigh_s)
      errors.push_back({"/time/step_s", concat(time_.step_s),
                        concat("expected at most the Rayleigh time of the smallest particle, ",
                               b.rayleigh_s, " s (particle ", b.rayleigh_particle,
                               "); lower it, use \"auto\", or reduce the stiffness of the finest "
                               "particles (/contact/reduced_stiffness)")});
    else if (time_.step_s > b.contact_s / 4.0)
      errors.push_back(
          {"/time/step_s", concat(time_.step_s),
           concat("expected at most a quarter of the shortest Hertz contact time, ",
                  b.contact_s / 4.0, " s (particle ", b.contact_particle, " against ",
                  b.contact_with_wall ? "the stiffest wall" : "an equal particle", " at ", v,
                  " m/s, /contact/max_impact_speed_m_per_s); lower it or "
                  "use \"auto\"")});
  } else {
    time_.step_s = automatic;
  }
  total_steps_ =
      std::max<std::int64_t>(1, std::int64_t(std::ceil(scene.time.end_s / time_.step_s - 1e-9)));
  if (total_steps_ > 2'000'000'000LL)
    errors.push_back({"/time/end_s", concat(scene.time.end_s),
                      concat("expected at most 2e9 steps of ", time_.step_s, " s")});
}

std::string Simulation::describe_worst_overlap() const {
  const ContactStepStats& c = contact_stats_;
  const std::string partner = c.max_overlap_wall >= 0
                                  ? "wall \"" + walls_[std::size_t(c.max_overlap_wall)].name + "\""
                                  : concat("particle ", c.max_overlap_partner);
  return concat("particle ", c.max_overlap_particle, " overlaps ", partner, " by ",
                100.0 * c.max_overlap_ratio, " % of its diameter");
}

void Simulation::compute_forces() {
  clear_forces(particles_, gravity_m_per_s2_);
  contact_stats_.reset();
  compute_pair_forces(contact_.model, materials_, box_, time_.step_s, contact_.penetration_limit,
                      particles_, neighbors_, contact_stats_);
  compute_wall_forces(materials_, walls_, time_.step_s, contact_.penetration_limit, particles_,
                      neighbors_, contact_stats_);
}

void Simulation::refresh_forces() {
  neighbors_.update(particles_, box_, walls_, true);
  compute_forces();
}

std::optional<StepFailure> Simulation::step() {
  const double dt = time_.step_s;
  double max_speed = 0.0;
  profile_.time(Phase::KickDrift, [&] { max_speed = kick_drift(particles_, dt); });
  profile_.time(Phase::Neighbors, [&] {
    neighbors_.note_motion(max_speed * dt);
    neighbors_.update(particles_, box_, walls_, false);
  });
  profile_.time(Phase::Forces, [&] { compute_forces(); });
  profile_.time(Phase::Kick, [&] {
    kick(particles_, dt);
    if (contact_.penetration_limiter &&
        !(contact_stats_.pairs_over_limit.empty() && contact_stats_.walls_over_limit.empty()))
      limiter_events_ += apply_penetration_limiter(contact_stats_, materials_, box_, walls_,
                                                   neighbors_, particles_);
  });
  ++step_index_;
  std::optional<StepFailure> failure;
  if (step_index_ % 16 == 0 || step_index_ == total_steps_ ||
      contact_stats_.max_overlap_ratio > 2.0 * contact_.penetration_limit)
    profile_.time(Phase::Health, [&] { failure = check_health(); });
  return failure;
}

std::optional<StepFailure> Simulation::check_health() {
  const ParticleStore& p = particles_;
  const std::string dt_text = concat(time_.step_s, " s");
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (is_finite(p.position_m[i]) && is_finite(p.velocity_m_per_s[i]) &&
        is_finite(p.angular_velocity_rad_per_s[i]))
      continue;
    return StepFailure{step_index_, time_s(), p.id[i], "non_finite_state",
                       concat("particle ", p.id[i], " (d = ", 2 * p.radius_m[i],
                              " m) has a non-finite position or velocity; the time step ", dt_text,
                              " is likely too large for its contacts: lower /time/step_s or "
                              "/time/safety_factor")};
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      if (box_.periodic[a]) continue;
      const double x = p.position_m[i][a], r = p.radius_m[i];
      if (x < box_.min_m[a] - r || x > box_.max_m[a] + r)
        return StepFailure{
            step_index_, time_s(), p.id[i], "particle_escaped",
            concat("particle ", p.id[i], " (d = ", 2 * r, " m, speed ", norm(p.velocity_m_per_s[i]),
                   " m/s) left the domain through a "
                   "wall on axis ",
                   a, ": the impact was too fast for the step ", dt_text,
                   "; raise /contact/max_impact_speed_m_per_s to at least "
                   "that speed so the automatic step resolves it")};
    }
  const double overlap_guard = 2.0 * contact_.penetration_limit;
  if (contact_stats_.max_overlap_ratio > overlap_guard)
    return StepFailure{
        step_index_, time_s(), contact_stats_.max_overlap_particle, "excessive_overlap",
        concat(describe_worst_overlap(), "; the guard stops runs at ", 100.0 * overlap_guard,
               " % (twice /contact/penetration_limit). The "
               "contact is too soft or too fast for the step ",
               dt_text,
               ": raise /contact/max_impact_speed_m_per_s, lower the reduced-"
               "stiffness threshold, or lower the step")};
  if (check_energy_ && step_index_ % 256 == 0) {
    const double growth = energy().total_j() - energy_reference_j_;
    if (growth > 0.05 * energy_scale_j_)
      return StepFailure{
          step_index_, time_s(), 0, "energy_growth",
          concat("the total energy grew by ", growth, " J (", 100.0 * growth / energy_scale_j_,
                 " % of the energy in play) with no source to supply it: the step ", dt_text,
                 " is too large for the stiffest contacts; lower "
                 "/time/step_s or /time/safety_factor")};
  }
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
  e.elastic_j = contact_elastic_energy_j(contact_.model, materials_, box_, walls_, p, neighbors_);
  return e;
}

}  // namespace millsim
