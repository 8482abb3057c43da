#include "sim/simulation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "contact/penetration_limit.h"
#include "contact/reduced_stiffness.h"
#include "dem/integrator.h"
#include "gas/drag.h"
#include "geometry/mill.h"
#include "parallel/thread_team.h"
#include "particles/particle_sources.h"
#include "process/holdup_fill.h"
#include "process/outlet.h"

namespace millsim {

// The impact spectrum's energy bins: 1e-4 to 1e6 J/kg (impact speeds of 1.4 cm/s to 1.4 km/s),
// five per decade.
constexpr double kImpactSpectrumMinJPerKg = 1e-4, kImpactSpectrumMaxJPerKg = 1e6;
constexpr int kImpactSpectrumBinsPerDecade = 5;
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
          specs = read_particle_file(source.file_path, {scene.files_root}).particles;
        } catch (const InputErrorList& e) {
          for (const InputError& err : e.errors()) errors.push_back(err);
        } catch (const InputFileRefused& e) {
          errors.push_back({path + "/path", source.file_path.string(), e.what()});
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
    if (scene.mill && !inside_mill(*scene.mill, p.position_m[i], 0.0)) {
      errors.push_back({concat("particle ", p.id[i]),
                        concat("x = [", p.position_m[i].x, ", ", p.position_m[i].y, ", ",
                               p.position_m[i].z, "]"),
                        "expected the centre inside the mill's chamber (within the mantle, "
                        "between floor and top plate, outside the outlet tube)"});
      return;
    }
  }
}

// The smallest and largest particles the run can ever hold beyond its sources: each feed's size
// range and, for a breakable material, a fragment at the dust threshold. They bound the time
// step and the reduced-stiffness threshold.
struct SizeBound {
  int material;
  double diameter_m;
};

double smallest_size_m(const SizeDistribution& s) {
  switch (s.kind) {
    case SizeDistributionKind::Fixed:
      return s.diameter_m;
    case SizeDistributionKind::LogNormal:  // 3.5 σ below the median unless truncated
      return std::max(s.min_m, s.median_m / std::pow(s.geometric_std, 3.5));
    default:
      return s.min_m;
  }
}

double largest_size_m(const SizeDistribution& s) {
  switch (s.kind) {
    case SizeDistributionKind::Fixed:
      return s.diameter_m;
    case SizeDistributionKind::LogNormal:
      return std::min(s.max_m, s.median_m * std::pow(s.geometric_std, 3.5));
    default:
      return s.max_m;
  }
}

std::vector<SizeBound> future_sizes(const SceneConfig& scene) {
  std::vector<SizeBound> out;
  for (const FeedConfig& f : scene.feeds) {
    out.push_back({f.material, smallest_size_m(f.sizes)});
    out.push_back({f.material, largest_size_m(f.sizes)});
  }
  for (std::size_t m = 0; m < scene.materials.size(); ++m)
    if (scene.materials[m].breakage && scene.dust)
      out.push_back({int(m), scene.dust->threshold_diameter_m});
  return out;
}

// Log-spaced size classes covering everything the run can produce (40 classes).
std::vector<double> default_psd_edges(const SceneConfig& scene, double d_min, double d_max) {
  double lo = 0.5 * d_min;
  if (scene.dust) {
    double ratio = 1.0;
    for (const MaterialConfig& m : scene.materials)
      if (m.breakage) ratio = std::min(ratio, m.breakage->fragments.min_ratio);
    lo = std::min(lo, 0.5 * ratio * scene.dust->threshold_diameter_m);
  }
  const double hi = 1.05 * d_max;
  std::vector<double> edges;
  for (int k = 0; k <= 40; ++k) edges.push_back(lo * std::pow(hi / lo, k / 40.0));
  return edges;
}

}  // namespace

Simulation::Simulation(const SceneConfig& scene, SimulationStart start)
    : materials_(scene), contact_(scene.contact), gravity_m_per_s2_(scene.gravity_m_per_s2) {
  InputErrors errors;
  box_ = {scene.domain.min_m, scene.domain.max_m, scene.domain.periodic};
  walls_ = build_walls(scene, materials_);
  const SourceParticles sources = collect_sources(scene, box_, errors);
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  if (sources.specs.empty() && scene.feeds.empty())
    throw InputErrorList(
        {{"/sources", "", "the sources produced no particles and no feed is set"}});

  double d_min = 1e300, d_max = 0.0, fastest = 0.0;
  int smallest_material = 0;
  for (std::size_t k = 0; k < sources.specs.size(); ++k) {
    const double d = sources.specs[k].diameter_m;
    if (d < d_min) d_min = d, smallest_material = sources.material[k];
    d_max = std::max(d_max, d);
    fastest = std::max(fastest, norm(sources.specs[k].velocity_m_per_s));
  }
  const std::vector<SizeBound> future = future_sizes(scene);
  for (const SizeBound& b : future) {
    if (b.diameter_m < d_min) d_min = b.diameter_m, smallest_material = b.material;
    d_max = std::max(d_max, b.diameter_m);
  }
  for (const FeedConfig& f : scene.feeds)
    fastest = std::max(fastest, norm(f.velocity_m_per_s) + 3.0 * f.velocity_spread_m_per_s);

  time_.impact_speed_m_per_s = contact_.max_impact_speed_m_per_s.value_or(
      default_max_impact_speed_m_per_s(fastest, gravity_m_per_s2_, box_));

  // Reduced stiffness (§4): the threshold first, so each particle gets its constants once.
  if (contact_.reduced_stiffness) {
    ReducedStiffnessInfo info;
    const int material = smallest_material;
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
  const std::vector<double> psd_edges =
      scene.psd.edges_m.empty() ? default_psd_edges(scene, d_min, d_max) : scene.psd.edges_m;
  if (scene.gas) particles_.enable_fluid_state();
  multi_rate_on_ = scene.time.multi_rate;
  if (multi_rate_on_) particles_.enable_multi_rate_state();
  if (scene.breakage) {
    particles_.enable_breakage_state();
    breakage_.emplace(
        scene, materials_,
        reduced_ ? std::optional<double>(reduced_->threshold_diameter_m) : std::nullopt,
        scene.seed ^ 0x9e3779b97f4a7c15ULL, psd_edges);
  }
  if (scene.output.impact_spectrum.value_or(scene.breakage.has_value()))
    impact_spectrum_.emplace(psd_edges, kImpactSpectrumMinJPerKg, kImpactSpectrumMaxJPerKg,
                             kImpactSpectrumBinsPerDecade);
  outlets_ = scene.outlets;
  mill_ = scene.mill;
  outlet_ = PsdTally(psd_edges);
  product_window_s_ = scene.psd.product_window_s;
  window_outlet_ = window_dust_table_ = PsdTally(psd_edges);
  outlet_mass_kg_.assign(outlets_.size(), 0.0);
  for (std::size_t f = 0; f < scene.feeds.size(); ++f)
    feeders_.emplace_back(scene.feeds[f],
                          materials_.material(scene.feeds[f].material).density_kg_per_m3,
                          scene.seed + 0x51ed270b27ULL * (f + 1));

  particles_.reserve(sources.specs.size());
  for (std::size_t k = 0; k < sources.specs.size(); ++k) {
    const ParticleSpec& s = sources.specs[k];
    const double scale =
        reduced_ ? stiffness_scale(s.diameter_m, reduced_->threshold_diameter_m) : 1.0;
    if (scale < 1.0) ++reduced_->reduced_particles;
    const std::size_t slot =
        particles_.add(materials_, sources.material[k], next_id_++, s.position_m,
                       s.velocity_m_per_s, s.angular_velocity_rad_per_s, s.diameter_m, scale);
    if (breakage_) breakage_->draw_strength(particles_, slot);
  }
  if (breakage_ || !outlets_.empty() || !feeders_.empty()) {
    flows_ = make_mass_flows(psd_edges);
    for (std::size_t i = 0; i < particles_.size(); ++i)
      add_tracked(*flows_, psd_slot(psd_edges, 2.0 * particles_.radius_m[i]), particles_.mass_kg[i],
                  cross_section_m2(particles_.radius_m[i]));
    if (breakage_) breakage_->record_flows(&*flows_);
  }
  check_inside_domain(scene, particles_, box_, errors);
  // Particles the run may create later (id 0 in the bounds): the smallest fragment and the
  // smallest and largest fed particles, with the stiffness they will get.
  ParticleStore later;
  for (const SizeBound& b : future)
    later.add(materials_, b.material, 0, {}, {}, {}, b.diameter_m,
              reduced_ ? stiffness_scale(b.diameter_m, reduced_->threshold_diameter_m) : 1.0);
  if (scene.gas) {
    // Explicit drag needs the step well inside the Stokes relaxation time of the smallest
    // particle, τ = ρ_p d² / (18 μ).
    const double rho_p = materials_.material(smallest_material).density_kg_per_m3;
    drag_relaxation_s_ = rho_p * d_min * d_min / (18.0 * scene.gas->viscosity_pa_s);
  }
  choose_time_step(scene, later, errors);
  multi_rate_.max_wait_steps = max_wait_steps(time_.step_s, drag_relaxation_s_);
  if (multi_rate_on_ && scene.time.wall_riders) {
    RiderRule rule;
    rule.wall = stiffest_wall_stiffness(materials_, walls_);
    rule.impact_speed_m_per_s = time_.impact_speed_m_per_s;
    rule.safety_factor = scene.time.safety_factor;
    rule.steps_per_contact = scene.time.steps_per_contact;
    rule.penetration_limit = contact_.penetration_limit;
    // The same bound over the run's smallest particles (the step, unless drag or the scene set
    // a shorter one); a larger fixed step counts instead, so no rider steps past its own bound.
    const TimeStepBounds& b = time_.bounds;
    rule.run_bound_s =
        std::max(time_.step_s, contact_step_bound_s(b.rayleigh_s, b.contact_s, time_.travel_bound_s,
                                                    rule.safety_factor, rule.steps_per_contact));
    while (rule.max_level < kMaxRiderLevel &&
           (std::int64_t(2) << rule.max_level) <= multi_rate_.max_wait_steps)
      ++rule.max_level;
    rider_rule_ = rule;
  }
  if (scene.gas) {
    const GasConfig& gas = *scene.gas;
    for (int a = 0; a < 3; ++a) {
      const double h = box_.length(a) / gas.cells[std::size_t(a)];
      if (h < d_max && !(box_.periodic[a] && gas.cells[std::size_t(a)] == 1))
        errors.push_back({concat("/gas/cells/", a), concat(gas.cells[std::size_t(a)]),
                          concat("a gas cell (", h, " m along axis ", a,
                                 ") must be larger than the largest particle (", d_max,
                                 " m): the volume-averaged equations need several particles per "
                                 "cell; use at most ",
                                 std::max(1, int(box_.length(a) / d_max)), " cells")});
    }
    if (errors.empty()) {
      gas_.emplace(gas, box_, gravity_m_per_s2_,
                   std::max(d_max, scene.search.cell_size_m.value_or(0.0)));
      const GasGrid& grid = gas_->grid();
      for (std::size_t k = 0; k < gas.boundaries.size(); ++k)
        if (grid.patch_faces[k] == 0)
          errors.push_back({concat("/gas/boundaries/", k), gas.boundaries[k].name,
                            concat("the patch covers no boundary face centre of the gas grid "
                                   "(cells are ",
                                   grid.h_m.x, " x ", grid.h_m.y, " x ", grid.h_m.z,
                                   " m): enlarge it or refine /gas/cells")});
      for (std::size_t k = 0; k < gas.jets.size(); ++k)
        if (grid.jet_faces[k] == 0)
          errors.push_back({"/mill/nozzles", gas.jets[k].name,
                            "the nozzle's jet points into no solid-fluid face of the gas grid "
                            "near its exit: check its angle, or refine /gas/cells"});
    }
  }

  if (scene.dust && scene.dust->model == DustModel::Ledger && gas_ && breakage_) {
    const GasConfig& gas = *scene.gas;
    for (const MaterialConfig& m : scene.materials)
      if (m.breakage) dust_density_kg_per_m3_ = m.density_kg_per_m3;
    dust_edges_m_ = breakage_->dust().edges_m;
    dust_ledger_.emplace(
        gas_->grid(),
        dust_classes(dust_edges_m_, scene.dust->threshold_diameter_m, dust_density_kg_per_m3_,
                     gas.viscosity_pa_s, dust_mean_free_path_m(gas)),
        gravity_m_per_s2_);
    if (scene.dust->grinding)
      for (std::size_t m = 0; m < scene.materials.size(); ++m)
        if (scene.materials[m].breakage)
          dust_grinding_.emplace(*dust_ledger_, dust_edges_m_, scene.materials[m], int(m),
                                 scene.breakage->equivalence);
    dust_two_way_ = scene.dust->two_way.value_or(gas.model == GasModel::Compressible);
    dust_carry_courant_ = scene.dust->carry_courant;
    breakage_->record_dust(true);
    window_dust_out_kg_.assign(std::size_t(dust_ledger_->class_count()), 0.0);
    dust_out_seen_kg_ = window_dust_out_kg_;
  }
  if (breakage_ && product_window_s_) breakage_->record_dust(true);  // the table's, in the window
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
  neighbors_ = NeighborList(
      {std::clamp(scene.search.skin_m.value_or(0.0), 0.0, max_skin), automatic_skin, max_skin,
       scene.search.cell_size_m, scene.search.subcells_per_axis, scene.search.grid_levels,
       time_.step_s, scene.search.conventional_nbs ? SearchMethod::Nbs : SearchMethod::Hashed,
       scene.search.rotating_frame, scene.search.skin_by_speed});
  neighbors_.update(particles_, box_, walls_, true);

  for (double m : particles_.mass_kg) initial_mass_kg_ += m;
  for (const FeedConfig& f : scene.feeds) {
    const double fed = f.mass_rate_kg_per_s * std::min(f.end_s - f.start_s, scene.time.end_s);
    const double speed = norm(f.velocity_m_per_s) + 3.0 * f.velocity_spread_m_per_s;
    feed_mass_bound_kg_ += fed;
    feed_kinetic_bound_j_ += 0.5 * fed * speed * speed;
  }
  const double g = norm(gravity_m_per_s2_);
  for (int a = 0; a < 3 && g > 0.0; ++a)
    if (box_.periodic[a] && gravity_m_per_s2_[a] != 0.0) check_energy_ = false;  // no potential
  if (gas_) check_energy_ = false;  // the gas is an energy source the ledger does not track

  if (gas_ && start == SimulationStart::AfterSpinUp) {
    // The scene's errors are all found now, before the caller spends the spin-up on it.
    check_start_overlaps();
    start_pending_ = true;
    return;
  }
  if (gas_ && start == SimulationStart::Complete) spin_up_gas(~std::uint64_t(0));
  complete_start(start != SimulationStart::ForRestore);
}

void Simulation::spin_up_gas(std::uint64_t max_steps) {
  if (auto failure = gas_->spin_up(max_steps))
    throw InputErrorList({{"/gas/spin_up_s", concat(gas_->config().spin_up_s),
                           "the gas failed while spinning up alone: " + *failure}});
}

void Simulation::finish_start() {
  if (!start_pending_) return;
  if (!gas_->spin_up_done()) spin_up_gas(~std::uint64_t(0));
  complete_start(true);
}

void Simulation::complete_start(bool first_gas_step) {
  if (gas_ && first_gas_step)
    if (auto failure = gas_->advance(particles_, time_.step_s, 0))
      throw InputErrorList({{"/gas", "", "the first gas step failed: " + *failure}});
  compute_all_forces();
  throw_on_start_overlap(contact_stats_);
  // The initial overlaps were no impacts.
  contact_stats_.record_impacts = breakage_.has_value() || impact_spectrum_.has_value();
  start_pending_ = false;
  set_energy_baseline();
  const MomentumBalance now = momentum_balance();
  initial_momentum_ = now.particles + now.in_flight;
}

void Simulation::tally_impacts() {
  const ParticleStore& p = particles_;
  for (const Impact& impact : contact_stats_.impacts) {
    const std::uint32_t i = impact.particle, j = impact.partner;
    const double vn = impact.speed_m_per_s, vt = impact.tangential_speed_m_per_s;
    if (impact.with_wall) {
      impact_spectrum_->add({1, p.material[i], std::int32_t(j)}, 2.0 * p.radius_m[i], vn, vt);
      continue;
    }
    // Once for each of the two particles, in its own size class.
    impact_spectrum_->add({0, p.material[i], p.material[j]}, 2.0 * p.radius_m[i], vn, vt);
    impact_spectrum_->add({0, p.material[j], p.material[i]}, 2.0 * p.radius_m[j], vn, vt);
  }
}

void Simulation::throw_on_start_overlap(const ContactStepStats& stats) const {
  if (stats.max_overlap_ratio > contact_.penetration_limit)
    throw InputErrorList({{"/sources", "",
                           concat(describe_worst_overlap(stats), " at the start; at most ",
                                  100.0 * contact_.penetration_limit,
                                  " % is allowed (/contact/penetration_limit): move them apart, "
                                  "or use a random source, which never overlaps")}});
}

// The start's overlap check on copies of the particles and the neighbour list, so the state the
// run starts from is that of a start without the check.
void Simulation::check_start_overlaps() const {
  ParticleStore particles = particles_;
  NeighborList neighbors = neighbors_;
  ContactStepStats stats;
  clear_forces(particles, gravity_m_per_s2_);
  compute_pair_forces(contact_.model, materials_, box_, time_.step_s, contact_.penetration_limit,
                      particles, neighbors, stats);
  compute_wall_forces(materials_, walls_, time_.step_s, contact_.penetration_limit, particles,
                      neighbors, stats);
  throw_on_start_overlap(stats);
}

void Simulation::set_energy_baseline() {
  const EnergyReport e0 = energy();
  energy_reference_j_ = e0.total_j();
  energy_added_j_ = 0.0;
  double mass = feed_mass_bound_kg_, height = 0.0;
  for (double m : particles_.mass_kg) mass += m;
  const double g = norm(gravity_m_per_s2_);
  for (int a = 0; a < 3 && g > 0.0; ++a)
    height += std::abs(gravity_m_per_s2_[a] / g) * box_.length(a);
  energy_scale_j_ = e0.kinetic_j + e0.rotational_j + e0.elastic_j + feed_kinetic_bound_j_ +
                    mass * g * height + 1e-300;
}

// The tighter of two sets of bounds.
static TimeStepBounds tighter(TimeStepBounds a, const TimeStepBounds& b) {
  if (b.rayleigh_s < a.rayleigh_s) a.rayleigh_s = b.rayleigh_s, a.rayleigh_particle = 0;
  if (b.contact_s < a.contact_s)
    a.contact_s = b.contact_s, a.contact_particle = 0, a.contact_with_wall = b.contact_with_wall;
  a.smallest_diameter_m = std::min(a.smallest_diameter_m, b.smallest_diameter_m);
  return a;
}

static std::string describe_particle(ParticleId id) {
  return id == 0 ? std::string("the smallest fragment or fed particle") : concat("particle ", id);
}

void Simulation::choose_time_step(const SceneConfig& scene, const ParticleStore& later,
                                  InputErrors& errors) {
  const double v = time_.impact_speed_m_per_s;
  time_.bounds = tighter(time_step_bounds(particles_, materials_, walls_, v),
                         time_step_bounds(later, materials_, walls_, v));
  const TimeStepBounds& b = time_.bounds;
  time_.stable_bound_s = std::min(b.rayleigh_s, b.contact_s / kMinStepsPerContact);
  time_.travel_bound_s = penetration_travel_bound_s(b, contact_.penetration_limit, v);
  auto automatic_step_s = [&](const TimeStepBounds& bounds) {
    return std::min(contact_step_bound_s(bounds.rayleigh_s, bounds.contact_s, time_.travel_bound_s,
                                         scene.time.safety_factor, scene.time.steps_per_contact),
                    0.2 * drag_relaxation_s_);
  };
  const double automatic = automatic_step_s(b);
  if (reduced_) {
    const TimeStepBounds real =
        tighter(time_step_bounds(particles_, materials_, walls_, v, /*at_real_stiffness=*/true),
                time_step_bounds(later, materials_, walls_, v, /*at_real_stiffness=*/true));
    reduced_->time_step_gain = automatic / automatic_step_s(real);
  }
  if (scene.time.step_s) {
    time_.automatic = false;
    time_.step_s = *scene.time.step_s;
    if (time_.step_s > b.rayleigh_s)
      errors.push_back({"/time/step_s", concat(time_.step_s),
                        concat("expected at most the Rayleigh time of the smallest particle, ",
                               b.rayleigh_s, " s (", describe_particle(b.rayleigh_particle),
                               "); lower it, use \"auto\", or reduce the stiffness of the finest "
                               "particles (/contact/reduced_stiffness)")});
    else if (time_.step_s > b.contact_s / 4.0)
      errors.push_back(
          {"/time/step_s", concat(time_.step_s),
           concat("expected at most a quarter of the shortest Hertz contact time, ",
                  b.contact_s / 4.0, " s (", describe_particle(b.contact_particle), " against ",
                  b.contact_with_wall ? "the stiffest wall" : "an equal particle", " at ", v,
                  " m/s, /contact/max_impact_speed_m_per_s); lower it or "
                  "use \"auto\"")});
    else if (time_.step_s > 0.5 * drag_relaxation_s_)
      errors.push_back({"/time/step_s", concat(time_.step_s),
                        concat("expected at most half the drag relaxation time of the smallest "
                               "particle, ",
                               0.5 * drag_relaxation_s_,
                               " s (explicit drag is unstable past it); lower it or use "
                               "\"auto\"")});
  } else {
    time_.step_s = automatic;
  }
  // Counted in double first: end / step can exceed any integer (1e6 s at 1e-13 s), and a cast
  // of that would wrap to one step.
  const double steps = std::ceil(scene.time.end_s / time_.step_s - 1e-9);
  if (!(steps <= 2e9))
    errors.push_back({"/time/end_s", concat(scene.time.end_s),
                      concat("expected at most 2e9 steps of ", time_.step_s, " s (this is ", steps,
                             "): shorten the run or use a larger step")});
  total_steps_ = std::max<std::int64_t>(1, std::int64_t(std::min(steps, 2e9)));
}

std::string Simulation::describe_worst_overlap(const ContactStepStats& c) const {
  const std::string partner = c.max_overlap_wall >= 0
                                  ? "wall \"" + walls_[std::size_t(c.max_overlap_wall)].name + "\""
                                  : concat("particle ", c.max_overlap_partner);
  return concat("particle ", c.max_overlap_particle, " overlaps ", partner, " by ",
                100.0 * c.max_overlap_ratio, " % of its diameter");
}

std::size_t Simulation::min_items_for_threads() const {
  // Every pass of a step splits the slots as the owner shares do, the force pass and the
  // kick-drift on the same ones (a multi-rate step's listed passes cut their lists at the shares'
  // units: dem/integrator.h, listed_pieces; docs/threads.md, "When threads pay").
  return kMinSlotsForOwnerPasses;
}

void Simulation::compute_forces(const std::vector<NeighborList::PairRange>* wall_ranges) {
  if (loads_listed_) {
  } else if (forces_prepared_) {
    begin_force_pass(particles_);
  } else {
    clear_forces(particles_, gravity_m_per_s2_);
  }
  forces_prepared_ = loads_listed_ = false;
  contact_stats_.reset();
  const MinItemsForThreadsScope minimum(min_items_for_threads());
  compute_pair_forces(contact_.model, materials_, box_, time_.step_s, contact_.penetration_limit,
                      particles_, neighbors_, contact_stats_);
  compute_wall_forces(materials_, walls_, time_.step_s, contact_.penetration_limit, particles_,
                      neighbors_, contact_stats_, wall_ranges);
}

void Simulation::compute_all_forces() {
  compute_forces();
  if (gas_) gas_->add_fluid_forces(particles_, time_.step_s, false);
}

void Simulation::refresh_forces() {
  finish_stepping_kick();
  catch_up_free_flight();
  neighbors_.update(particles_, box_, walls_, true);
  compute_all_forces();
  set_energy_baseline();
}

std::optional<StepFailure> Simulation::step() {
  return advance(1);
}

std::optional<StepFailure> Simulation::advance(std::int64_t steps) {
  finish_start();  // AfterSpinUp without the caller's spin-up: all of it now
  std::optional<StepFailure> failure;
  for (std::int64_t s = 0; s < steps && !failure; ++s)
    failure = step_once(carry_kicks_ && s + 1 < steps);
  finish_stepping_kick();
  catch_up_free_flight();
  return failure;
}

void Simulation::prepare_multi_rate() {
  // The sets are about to change: the stepping particles' pending kick is that of the old set.
  if (multi_rate_.marked_rebuilds != neighbors_.stats().rebuilds ||
      multi_rate_.lists_version != particles_.population_version)
    finish_stepping_kick();
  if (multi_rate_.marked_rebuilds != neighbors_.stats().rebuilds) {
    // The list was rebuilt, which happens only with every particle complete.
    mark_free_flight(particles_, neighbors_, multi_rate_, rider_rule_ ? &*rider_rule_ : nullptr,
                     &materials_);
    multi_rate_.waiting_since_step = step_index_;
    for (RiderLevel& level : multi_rate_.riders) level.since_step = step_index_;
  } else {
    relist_if_moved(particles_, neighbors_, multi_rate_);
  }
}

void Simulation::book_stepping_exchange() {
  MultiRate& m = multi_rate_;
  if (m.held_exchange_steps == 0) return;
  const double held_s = double(m.held_exchange_steps) * time_.step_s;
  m.held_exchange_steps = 0;
  profile_.time(Phase::Fluid, [&] {
    gas_->add_held_impulse(book_held_exchange(particles_, m.stepping, held_s));
  });
}

void Simulation::finish_stepping_kick() {
  book_stepping_exchange();
  if (!stepping_kick_pending_) return;
  stepping_kick_pending_ = false;
  profile_.time(Phase::Kick, [&] {
    const MinItemsForThreadsScope minimum(min_items_for_threads());
    kick_listed(particles_, multi_rate_.stepping, time_.step_s, &neighbors_.owner_shares);
  });
}

void Simulation::catch_up_free_flight() {
  if (!multi_rate_on_) return;
  MultiRate& m = multi_rate_;
  if (!m.riders.empty()) {
    relist_if_moved(particles_, neighbors_, m);
    for (int level = 1; level <= int(m.riders.size()); ++level) catch_up_riders(level);
  }
  const std::int64_t waited = step_index_ - m.waiting_since_step;
  if (waited <= 0) return;
  m.waiting_since_step = step_index_;
  relist_if_moved(particles_, neighbors_, m);
  m.speeds_valid = false;
  if (m.waiting.empty()) return;
  const double h = double(waited) * time_.step_s;
  profile_.time(Phase::FreeFlight, [&] {
    m.block_speed2.assign((particles_.size() + kSpeedBlockSlots - 1) / kSpeedBlockSlots, 0.0);
    const SlotShares* shares = &neighbors_.owner_shares;
    kick_drift_listed(particles_, m.waiting, h, gravity_m_per_s2_, m.block_speed2,
                      neighbors_.speed_report(particles_), false, shares);
    if (gas_) gas_->add_fluid_forces(particles_, m.waiting, h);
    kick_listed(particles_, m.waiting, h, shares);
  });
  ++m.stats.catch_ups;
  m.stats.long_steps += double(m.waiting.size());
}

void Simulation::catch_up_riders(int level) {
  MultiRate& m = multi_rate_;
  RiderLevel& l = m.riders[std::size_t(level - 1)];
  const std::int64_t waited = step_index_ - l.since_step;
  if (waited <= 0) return;
  l.since_step = step_index_;
  if (l.slots.empty()) return;
  if (!m.rider_ranges_valid)  // slots moved since the rebuild (process_population prevents it)
    throw std::logic_error("wall riders to catch up after their slots moved, before a rebuild");
  const double h = double(waited) * time_.step_s;
  profile_.time(Phase::WallRiders, [&] {
    static thread_local std::vector<double> scratch_block_speed2;
    scratch_block_speed2.assign((particles_.size() + kSpeedBlockSlots - 1) / kSpeedBlockSlots, 0.0);
    // Their fluid force as the stepping particles': kept, evaluated after a CFD step and at
    // least every max_wait_steps steps.
    const bool refresh = gas_ && (l.fluid_refreshed_step <= m.gas_changed_step ||
                                  step_index_ - l.fluid_refreshed_step >= m.max_wait_steps);
    const SlotShares* shares = &neighbors_.owner_shares;
    if (gas_ && !refresh) {
      kick_drift_keeping_fluid(particles_, l.slots, h, gravity_m_per_s2_, scratch_block_speed2,
                               neighbors_.speed_report(particles_), false, shares);
      gas_->add_held_impulse(book_held_exchange(particles_, l.slots, h));
    } else {
      kick_drift_listed(particles_, l.slots, h, gravity_m_per_s2_, scratch_block_speed2,
                        neighbors_.speed_report(particles_), false, shares);
    }
    ContactStepStats stats;
    stats.record_impacts = contact_stats_.record_impacts;
    compute_wall_forces(materials_, walls_, h, contact_.penetration_limit, particles_, neighbors_,
                        stats, &l.wall_ranges);
    if (refresh) {
      gas_->add_fluid_forces(particles_, l.slots, h);
      l.fluid_refreshed_step = step_index_;
    }
    kick_listed(particles_, l.slots, h, shares);
    for (const Impact& impact : stats.impacts)
      m.rider_events.push_back({particles_.id[impact.particle], impact.partner, false,
                                impact.speed_m_per_s, impact.tangential_speed_m_per_s,
                                step_index_});
    for (const std::uint32_t k : stats.walls_over_limit)
      m.rider_events.push_back({particles_.id[neighbors_.wall_particle[k]],
                                neighbors_.wall_index[k], true, 0.0, 0.0, step_index_});
    l.touching_walls = stats.touching_walls;
    if (stats.max_overlap_ratio > contact_stats_.max_overlap_ratio) {
      contact_stats_.max_overlap_ratio = stats.max_overlap_ratio;
      contact_stats_.max_overlap_particle = stats.max_overlap_particle;
      contact_stats_.max_overlap_partner = 0;
      contact_stats_.max_overlap_wall = stats.max_overlap_wall;
    }
    bound_rider_speeds(particles_, time_.step_s, level, neighbors_.speed_report(particles_), m);
  });
  ++m.stats.rider_catch_ups;
  m.stats.rider_steps += double(l.slots.size());
  m.stats.rider_waited_steps += double(waited - 1) * double(l.slots.size());
}

void Simulation::take_rider_events() {
  MultiRate& m = multi_rate_;
  if (m.rider_events.empty()) return;
  // An event recorded before this step: its rider may lag the clock now, so bring everyone up
  // to date before the breakage reads it (which may record more events, all of this step).
  bool earlier = false;
  for (const RiderEvent& e : m.rider_events) earlier = earlier || e.step < step_index_;
  if (earlier) catch_up_free_flight();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> slot_of;  // id → slot, for the events
  for (const RiderEvent& e : m.rider_events) slot_of.push_back({e.id, 0});
  std::sort(slot_of.begin(), slot_of.end());
  std::size_t found = 0;
  for (std::uint32_t i = 0; i < std::uint32_t(particles_.size()) && found < slot_of.size(); ++i) {
    auto it = std::lower_bound(slot_of.begin(), slot_of.end(),
                               std::pair<std::uint64_t, std::uint32_t>{particles_.id[i], 0});
    for (; it != slot_of.end() && it->first == particles_.id[i]; ++it) it->second = i + 1, ++found;
  }
  for (const RiderEvent& e : m.rider_events) {
    const auto it = std::lower_bound(slot_of.begin(), slot_of.end(),
                                     std::pair<std::uint64_t, std::uint32_t>{e.id, 0});
    if (it == slot_of.end() || it->first != e.id || it->second == 0) continue;  // left meanwhile
    const std::uint32_t slot = it->second - 1;
    if (e.crushed) {
      if (breakage_) rider_crushed_.push_back(slot);
    } else {
      contact_stats_.impacts.push_back(
          {slot, e.wall, true, e.speed_m_per_s, e.tangential_speed_m_per_s});
    }
  }
  m.rider_events.clear();
}

std::optional<StepFailure> Simulation::step_multi_rate(bool may_defer) {
  const double dt = time_.step_s;
  MultiRate& m = multi_rate_;
  const SlotShares* shares = &neighbors_.owner_shares;
  if (kick_pending_) profile_.time(Phase::Kick, [&] { kick(particles_, dt, shares); });
  kick_pending_ = false;
  // The last step's closing kick of the stepping particles, done in their kick-drift's pass.
  const bool kick_first = stepping_kick_pending_;
  stepping_kick_pending_ = false;
  if (!m.speeds_valid) bound_waiting_speeds(particles_, dt, neighbors_.speed_report(particles_), m);
  // The stepping particles' fluid force: evaluated this step, or the kept one applied.
  const bool refresh =
      !gas_ || m.fluid_refresh_due || step_index_ + 1 - m.fluid_refreshed_step >= m.max_wait_steps;
  if (refresh) book_stepping_exchange();  // the kept forces are about to be evaluated again
  double max_speed = 0.0;
  profile_.time(Phase::KickDrift, [&] {
    const MinItemsForThreadsScope minimum(min_items_for_threads());
    m.block_speed2 = m.waiting_block_speed2;
    double stepping_max2 = 0.0;
    if (refresh) {
      stepping_max2 =
          kick_drift_listed(particles_, m.stepping, dt, gravity_m_per_s2_, m.block_speed2,
                            neighbors_.speed_report(particles_), kick_first, shares);
    } else {
      stepping_max2 =
          kick_drift_keeping_fluid(particles_, m.stepping, dt, gravity_m_per_s2_, m.block_speed2,
                                   neighbors_.speed_report(particles_), kick_first, shares);
      ++m.held_exchange_steps;
      m.stats.held_fluid_steps += double(m.stepping.size());
    }
    const double max2 = std::max(stepping_max2, m.waiting_max_speed2);
    block_max_speed_.resize(m.block_speed2.size());
    for (std::size_t b = 0; b < m.block_speed2.size(); ++b)
      block_max_speed_[b] = std::sqrt(m.block_speed2[b]);
    max_speed = std::sqrt(max2);
    loads_listed_ = true;
  });
  neighbors_.note_motion(block_max_speed_, max_speed, dt);
  // The list is about to measure motion or rebuild: every particle must be where it is now, so
  // this step becomes a full one.
  const bool full = neighbors_.rebuild_likely();
  if (full) {
    book_stepping_exchange();  // a rebuild may reorder the slots
    catch_up_free_flight();
    profile_.time(Phase::KickDrift, [&] {
      const MinItemsForThreadsScope minimum(min_items_for_threads());
      kick_drift_listed(particles_, m.waiting, dt, gravity_m_per_s2_, m.block_speed2,
                        neighbors_.speed_report(particles_), false, shares);
      for (RiderLevel& level : m.riders)
        kick_drift_listed(particles_, level.slots, dt, gravity_m_per_s2_, m.block_speed2,
                          neighbors_.speed_report(particles_), false, shares);
    });
    ++m.stats.full_steps;
  }
  profile_.time(Phase::Neighbors, [&] {
    const MinItemsForThreadsScope minimum(min_items_for_threads());
    neighbors_.update(particles_, box_, walls_, false);
  });
  // The riders' wall candidates wait for their own steps, except in a full step.
  const bool riders_apart = !full && m.any_riders();
  profile_.time(Phase::Forces,
                [&] { compute_forces(riders_apart ? &m.stepping_wall_ranges : nullptr); });
  if (gas_)
    profile_.time(Phase::Fluid, [&] {
      if (full && refresh) {
        gas_->add_fluid_forces(particles_, dt, true);
      } else if (full) {
        gas_->add_fluid_forces(particles_, m.waiting, dt);  // the stepping ones keep theirs
        for (RiderLevel& level : m.riders) gas_->add_fluid_forces(particles_, level.slots, dt);
      } else if (refresh) {
        gas_->add_fluid_forces(particles_, m.stepping, dt);
      }
    });
  particle_steps_ += double(full ? particles_.size() : m.stepping.size());
  if (!full) m.stats.waiting_particle_steps += double(m.waiting.size());
  contact_steps_ += contact_stats_.touching_pairs;
  ++step_index_;
  if (gas_ && refresh) {
    m.fluid_refreshed_step = step_index_;
    m.fluid_refresh_due = false;
    ++m.stats.fluid_refreshes;
  }
  const bool limiter = limiter_due();
  // As step_once: while nothing looks at the stepping particles before the next step's
  // kick-drift, their closing kick waits for it (whatever reads them first calls
  // finish_stepping_kick: the breakage when something may break, outlets and feeds, the gas,
  // the health check, a change of the sets, the end of advance()).
  const bool defer =
      may_defer && !full && !limiter && !(gas_ && gas_->due(step_index_)) && !health_due();
  profile_.time(Phase::Kick, [&] {
    {
      const MinItemsForThreadsScope minimum(min_items_for_threads());
      if (full)
        kick(particles_, dt, shares);
      else if (!defer)
        kick_listed(particles_, m.stepping, dt, shares);
    }
    if (limiter)
      limiter_events_ += apply_penetration_limiter(contact_stats_, materials_, box_, walls_,
                                                   neighbors_, particles_);
  });
  stepping_kick_pending_ = defer;
  carried_kicks_ += defer ? 1 : 0;
  if (full) {
    m.waiting_since_step = step_index_, m.speeds_valid = false;
    for (RiderLevel& level : m.riders) level.since_step = step_index_, level.touching_walls = 0;
  } else {
    for (int level = 1; level <= int(m.riders.size()); ++level)
      if (step_index_ - m.riders[std::size_t(level - 1)].since_step >= (std::int64_t(1) << level))
        catch_up_riders(level);
  }
  take_rider_events();
  if (impact_spectrum_ && !contact_stats_.impacts.empty()) tally_impacts();
  if (breakage_ || !outlets_.empty() || !feeders_.empty()) process_population();
  if (gas_ && gas_->due(step_index_)) {
    finish_stepping_kick();
    catch_up_free_flight();
    m.speeds_valid = false;  // the drag response changes velocities
    if (auto failure = advance_gas()) return failure;
  }
  if (step_index_ - m.waiting_since_step >= m.max_wait_steps) catch_up_free_flight();
  std::optional<StepFailure> failure;
  if (health_due()) {
    finish_stepping_kick();  // a rider's overlap may have called for it after the kick
    profile_.time(Phase::Health, [&] { failure = check_health(); });
  }
  return failure;
}

std::optional<StepFailure> Simulation::step_once(bool may_defer) {
  if (multi_rate_on_) {
    prepare_multi_rate();
    if (!multi_rate_.waiting.empty() || multi_rate_.any_riders()) return step_multi_rate(may_defer);
    book_stepping_exchange();
  }
  const double dt = time_.step_s;
  double max_speed = 0.0;
  profile_.time(Phase::KickDrift, [&] {
    const SlotShares* shares = &neighbors_.owner_shares;
    max_speed = kick_pending_
                    ? kick_then_kick_drift(particles_, dt, gravity_m_per_s2_, block_max_speed_,
                                           neighbors_.speed_report(particles_), shares)
                    : kick_drift(particles_, dt, gravity_m_per_s2_, block_max_speed_,
                                 neighbors_.speed_report(particles_), shares);
    forces_prepared_ = true;
    kick_pending_ = false;
  });
  profile_.time(Phase::Neighbors, [&] {
    neighbors_.note_motion(block_max_speed_, max_speed, dt);
    const MinItemsForThreadsScope minimum(min_items_for_threads());
    neighbors_.update(particles_, box_, walls_, false);
  });
  profile_.time(Phase::Forces, [&] { compute_forces(); });
  if (gas_) profile_.time(Phase::Fluid, [&] { gas_->add_fluid_forces(particles_, dt, true); });
  particle_steps_ += double(particles_.size());
  contact_steps_ += contact_stats_.touching_pairs;
  ++step_index_;
  if (multi_rate_on_) take_rider_events();  // a last catch-up's, before the list rebuilt
  // The force pass's impacts, while their slots are the ones the pass saw.
  if (impact_spectrum_ && !contact_stats_.impacts.empty()) tally_impacts();
  const bool limiter = limiter_due();
  const bool population = breakage_ || !outlets_.empty() || !feeders_.empty();
  const bool gas_due = gas_ && gas_->due(step_index_);
  if (may_defer && !limiter && !population && !gas_due && !health_due()) {
    kick_pending_ = true;  // done by the next step's kick-drift
    ++carried_kicks_;
    return std::nullopt;
  }
  profile_.time(Phase::Kick, [&] {
    kick(particles_, dt, &neighbors_.owner_shares);
    if (limiter)
      limiter_events_ += apply_penetration_limiter(contact_stats_, materials_, box_, walls_,
                                                   neighbors_, particles_);
  });
  if (population) process_population();
  std::optional<StepFailure> failure;
  if (gas_due)
    if (auto gas_failure = advance_gas()) return gas_failure;
  if (health_due()) profile_.time(Phase::Health, [&] { failure = check_health(); });
  return failure;
}

bool Simulation::limiter_due() const {
  return contact_.penetration_limiter &&
         !(contact_stats_.pairs_over_limit.empty() && contact_stats_.walls_over_limit.empty());
}

// The guard's checks read every particle, and under multi-rate stepping a checked step closes
// the stepping particles' kick instead of carrying it: every 64 steps. An overlap past the guard
// is checked at the step it appears (a run blowing up passes it first), and a non-finite state
// stays non-finite until it is seen.
constexpr std::int64_t kHealthCheckSteps = 64;
// The energy balance (a sum over every particle and contact) on every fourth checked step.
constexpr std::int64_t kEnergyCheckSteps = 4 * kHealthCheckSteps;

bool Simulation::health_due() const {
  return step_index_ % kHealthCheckSteps == 0 || step_index_ == total_steps_ ||
         contact_stats_.max_overlap_ratio > 2.0 * contact_.penetration_limit;
}

void Simulation::lay_dust_on_gas() {
  CompressibleSolver* compressible = gas_->compressible();
  std::vector<double>& density =
      dust_two_way_ ? compressible->dust_density() : dust_density_scratch_;
  dust_ledger_->density_kg_per_m3(density);
  const GasGrid& grid = dust_ledger_->grid();
  for (std::size_t c = 0; c < grid.padded_size; ++c) {
    if (!(density[c] > 0.0) || !grid.fluid[c]) continue;
    const double gas_density =
        compressible ? compressible->density_kg_per_m3(c) : gas_->gas().density_kg_per_m3();
    dust_max_cell_loading_ = std::max(dust_max_cell_loading_, density[c] / gas_density);
  }
}

std::optional<StepFailure> Simulation::advance_gas() {
  std::optional<std::string> message;
  profile_.time(Phase::Gas, [&] {
    if (dust_ledger_) lay_dust_on_gas();
    message = gas_->advance(particles_, time_.step_s, step_index_);
  });
  multi_rate_.fluid_refresh_due = true;  // kept fluid forces (multi-rate) are stale now
  multi_rate_.gas_changed_step = step_index_;
  if (message) return StepFailure{step_index_, time_s(), 0, "gas_solver", *message};
  if (dust_ledger_ && dust_carry_due()) {
    // The dust rides the gas just solved over the DEM time since it was last carried.
    profile_.time(Phase::Gas, [&] {
      const double dt = double(step_index_ - dust_advanced_step_) * time_.step_s;
      dust_ledger_->advance(gas_->view(), dt);
      if (dust_grinding_) dust_grinding_->grind(*dust_ledger_, particles_, materials_, dt);
      if (flows_) {
        const double area = tracked_area_m2(*flows_);
        for (int k = 0; k < dust_ledger_->class_count(); ++k) {
          const std::size_t c = std::size_t(MassFlows::dust(k, flows_->slots));
          const double held = dust_ledger_->held_kg(k);
          flows_->held_kg_s[c] += held * dt;
          flows_->exposure_kg_m2_s[c] += held * area * dt;
        }
      }
    });
    dust_advanced_step_ = step_index_;
    const bool counted = in_product_window();
    for (int k = 0; k < dust_ledger_->class_count(); ++k) {
      const double out = dust_ledger_->outflow_kg(k);
      if (counted) window_dust_out_kg_[std::size_t(k)] += out - dust_out_seen_kg_[std::size_t(k)];
      dust_out_seen_kg_[std::size_t(k)] = out;
    }
  }
  return std::nullopt;
}

// The ledger's dust moves at the gas's speed plus its slip, far below the gas's sound speed that
// sets the CFD step, so it is carried at its own step: at the last CFD step before the time since
// its last carry would pass carry_courant over its fastest class's outgoing rate at that carry.
// Each class still takes the sub-steps its rates need (a gas that sped up meanwhile costs a
// sub-step, never stability). At every CFD step until the first carry, and while nothing moves.
bool Simulation::dust_carry_due() const {
  if (!(dust_carry_courant_ > 0.0) || dust_ledger_->stats().advances == 0) return true;
  const double since_s = double(step_index_ - dust_advanced_step_) * time_.step_s;
  const double next_s = double(gas_->next_cfd_step() - step_index_) * time_.step_s;
  return since_s + next_s > dust_ledger_->carry_interval_s(dust_carry_courant_);
}

double Simulation::particle_energy_j(std::size_t i) const {
  const ParticleStore& p = particles_;
  return 0.5 * p.mass_kg[i] * norm2(p.motion[i].velocity_m_per_s) +
         0.5 * norm2(p.motion[i].angular_velocity_rad_per_s) / p.inv_inertia_per_kg_m2[i] -
         p.mass_kg[i] * dot(gravity_m_per_s2_, p.position_m[i]);
}

void Simulation::process_population() {
  const std::uint64_t version = particles_.population_version;
  std::vector<Newborn> newborn;
  if (flows_) integrate_tracked(*flows_, time_s());  // the hold-up until now, before it changes
  const auto removed = [this](const ParticleStore& store, std::size_t i) {
    energy_added_j_ -= particle_energy_j(i);
    if (gas_) gas_->release(store, i);
    if (flows_)
      add_tracked(*flows_, psd_slot(outlet_.edges_m, 2.0 * store.radius_m[i]), -store.mass_kg[i],
                  -cross_section_m2(store.radius_m[i]));
  };
  const auto added = [this](const ParticleStore& store, std::size_t i) {
    energy_added_j_ += particle_energy_j(i);
    if (flows_)
      add_tracked(*flows_, psd_slot(outlet_.edges_m, 2.0 * store.radius_m[i]), store.mass_kg[i],
                  cross_section_m2(store.radius_m[i]));
  };
  const ContactStepStats& c = contact_stats_;
  if (breakage_ && !(c.impacts.empty() && c.pairs_over_limit.empty() &&
                     c.walls_over_limit.empty() && rider_crushed_.empty())) {
    // The smaller partner of each contact past the penetration limit is crushed; pairs first,
    // so a particle squeezed by another against a wall counts as crushed by the other.
    std::vector<CrushedParticle> crushed;
    for (std::uint32_t k : c.pairs_over_limit) {
      const std::uint32_t i = neighbors_.pairs.first[k], j = neighbors_.pairs.second[k];
      crushed.push_back({particles_.radius_m[i] <= particles_.radius_m[j] ? i : j, false});
    }
    for (std::uint32_t k : c.walls_over_limit)
      crushed.push_back({neighbors_.wall_particle[k], true});
    for (std::uint32_t i : rider_crushed_) crushed.push_back({i, true});
    // Before anything may break: a breakage moves fragments with their parents' velocities (the
    // stepping particles' pending kick first), and it moves slots, after which the riders' wall
    // candidates (listed by slot) are stale until the rebuild (the riders brought up to date
    // while they are not).
    const bool riders = multi_rate_on_ && multi_rate_.any_riders();
    if ((stepping_kick_pending_ || multi_rate_.held_exchange_steps > 0 || riders) &&
        breakage_->may_break(c.impacts, crushed, walls_, particles_)) {
      finish_stepping_kick();
      if (riders)
        for (int level = 1; level <= int(multi_rate_.riders.size()); ++level)
          catch_up_riders(level);
    }
    profile_.time(Phase::Breakage, [&] {
      breakage_->process(c.impacts, crushed, time_.step_s, time_s(), walls_, box_, particles_,
                         next_id_, newborn, removed, added);
      if (dust_ledger_)
        deposit_fresh_dust();
      else if (product_window_s_)
        tally_windowed_table_dust();
      contact_stats_.impacts.clear();  // slots are stale now
      contact_stats_.pairs_over_limit.clear();
      contact_stats_.walls_over_limit.clear();
    });
  }
  rider_crushed_.clear();
  // Outlets and feeds change the population too, and each change costs a neighbour-list
  // rebuild. They are applied when the list rebuilds anyway: with a breakage event, or once per
  // list on the step before the motion bound is expected to rebuild it (their rebuild then takes
  // the place of that one), and at least every kMaxDeferredSteps steps, longer than a list lives in
  // the mill (75 steps): a particle past an outlet lingers, and fed mass waits, for at most that
  // long. The feed's rate is kept exactly (mass accrues).
  constexpr std::int64_t kMaxDeferredSteps = 256;
  const std::uint64_t list = neighbors_.stats().rebuilds;
  const bool apply_now = particles_.population_version != version ||
                         (neighbors_.rebuild_expected_next_step() && population_list_ != list) ||
                         step_index_ - last_population_step_ >= kMaxDeferredSteps;
  if (!apply_now) return;
  finish_stepping_kick();  // outlets read velocities, and a rebuild may follow
  catch_up_free_flight();
  last_population_step_ = step_index_;
  population_list_ = list;
  profile_.time(Phase::Population, [&] {
    if (!outlets_.empty())
      for (std::size_t i = particles_.size(); i-- > 0;) {
        const int outlet = outlet_of(outlets_, particles_.position_m[i]);
        if (outlet < 0) continue;
        const double m = particles_.mass_kg[i];
        outlet_.add(2.0 * particles_.radius_m[i], m);
        if (in_product_window()) window_outlet_.add(2.0 * particles_.radius_m[i], m);
        outlet_mass_kg_[std::size_t(outlet)] += m;
        if (flows_) {
          const std::size_t slot =
              std::size_t(psd_slot(outlet_.edges_m, 2.0 * particles_.radius_m[i]));
          flows_->left_kg[slot] += m;
          flows_->left_count[slot] += 1.0;
        }
        // With its force in flight (the next half-kick), as the breakage module does for dust.
        outlet_momentum_ += particles_.motion[i].velocity_m_per_s * m +
                            particles_.load[i].force_n * (0.5 * time_.step_s);
        removed(particles_, i);
        particles_.remove_swap(i);
      }
    for (Feeder& feeder : feeders_) {
      const int material = feeder.config().material;
      for (const ParticleSpec& spec : feeder.take_due(time_s(), particles_, box_)) {
        const double scale =
            reduced_ ? stiffness_scale(spec.diameter_m, reduced_->threshold_diameter_m) : 1.0;
        const ParticleId id = next_id_++;
        const std::size_t slot = particles_.add(materials_, material, id, spec.position_m,
                                                spec.velocity_m_per_s, {}, spec.diameter_m, scale);
        if (breakage_) breakage_->draw_strength(particles_, slot);
        fed_mass_kg_ += particles_.mass_kg[slot];
        if (flows_)
          flows_->fed_kg[std::size_t(psd_slot(outlet_.edges_m, spec.diameter_m))] +=
              particles_.mass_kg[slot];
        fed_momentum_ += particles_.motion[slot].velocity_m_per_s * particles_.mass_kg[slot];
        added(particles_, slot);
        newborn.push_back({id, 0, 0});
      }
    }
    if (particles_.population_version != version) {
      // Rebuild now, so the list never refers to removed slots and the newborn are marked
      // before the next force pass.
      neighbors_.mark_newborn(std::move(newborn), contact_.penetration_limit);
      const MinItemsForThreadsScope minimum(min_items_for_threads());
      neighbors_.update(particles_, box_, walls_, true);
    }
  });
}

HoldupFill Simulation::fill_holdup(const std::vector<double>& target_kg, std::uint64_t seed,
                                   bool removes) {
  if (!mill_ || !flows_)
    throw std::logic_error("a hold-up fill needs a mill and the run's mass flows");
  finish_stepping_kick();  // every particle complete: the copies take their sources' state
  catch_up_free_flight();
  HoldupFill fill;
  fill.time_s = time_s();
  fill.target_kg = target_kg;
  fill.before_kg = holdup_by_compartment_kg();
  const int slots = flows_->slots;
  std::vector<double> deficit(std::size_t(slots), 0.0);
  for (int s = 0; s < slots && s < int(target_kg.size()); ++s)
    deficit[std::size_t(s)] = target_kg[std::size_t(s)] - fill.before_kg[std::size_t(s)];
  const auto clear_of_walls = [&](const Vec3& x, double r) {
    if (!inside_mill(*mill_, x, r) || outlet_of(outlets_, x) >= 0) return false;
    for (const Wall& w : walls_)
      if (wall_gap_m(w, x) < r) return false;
    return true;
  };
  Rng rng(seed);
  integrate_tracked(*flows_, time_s());  // the hold-up until now, before it changes
  // The forces in flight (the next half-kick, counted as held) change with the population: the
  // removed particles' go, the copies' come, and a removed particle's contacts leave its partners.
  // All of that change is the fill's.
  const Vec3 in_flight_before = momentum_balance().in_flight;
  if (removes) {
    // First, so that the copies may take the room the removed particles leave.
    std::vector<double> excess(deficit.size());
    for (std::size_t s = 0; s < deficit.size(); ++s) excess[s] = -deficit[s];
    const RemovalPlan removal = plan_removals(particles_, outlet_.edges_m, excess, rng);
    for (const std::uint32_t i : removal.particles) {  // highest slot first
      const double m = particles_.mass_kg[i];
      fill.particles_removed_kg += m;
      fill.energy_j -= particle_energy_j(i);
      filled_momentum_ -= particles_.motion[i].velocity_m_per_s * m;
      if (gas_) gas_->release(particles_, i);
      add_tracked(*flows_, psd_slot(outlet_.edges_m, 2.0 * particles_.radius_m[i]), -m,
                  -cross_section_m2(particles_.radius_m[i]));
      particles_.remove_swap(i);
    }
    fill.particles_removed = removal.particles.size();
  }
  const CopyPlan plan =
      plan_copies(particles_, outlet_.edges_m, deficit, mill_->axis_point_m, clear_of_walls, rng);
  for (const ParticleCopy& c : plan.copies) {
    const std::size_t source = c.source;  // a slot held before the fill: adding moves none
    const double d = 2.0 * particles_.radius_m[source];
    const double scale = reduced_ ? stiffness_scale(d, reduced_->threshold_diameter_m) : 1.0;
    const std::size_t slot =
        particles_.add(materials_, particles_.material[source], next_id_++, c.position_m,
                       c.velocity_m_per_s, c.angular_velocity_rad_per_s, d, scale);
    if (breakage_) {
      // A copy stands for its source as the mill holds it: worn by the impacts it survived
      // (fatigue), not a fresh particle of its size, which would break less often than the
      // hold-up it fills.
      particles_.remaining_capacity_j_per_kg[slot] = particles_.remaining_capacity_j_per_kg[source];
      particles_.generation[slot] = particles_.generation[source];
    }
    const double m = particles_.mass_kg[slot];
    fill.particles_kg += m;
    fill.energy_j += particle_energy_j(slot);
    filled_momentum_ += particles_.motion[slot].velocity_m_per_s * m;
    add_tracked(*flows_, psd_slot(outlet_.edges_m, d), m, cross_section_m2(0.5 * d));
  }
  if (dust_ledger_)
    for (int k = 0; k < dust_ledger_->class_count(); ++k) {
      const std::size_t c = std::size_t(MassFlows::dust(k, slots));
      if (c >= target_kg.size()) continue;
      if (removes && target_kg[c] < fill.before_kg[c]) {
        fill.dust_removed_kg -= dust_ledger_->scale_class(k, target_kg[c] / fill.before_kg[c]);
        continue;
      }
      if (!(target_kg[c] > fill.before_kg[c])) continue;
      if (fill.before_kg[c] > 0.0)
        fill.dust_kg += dust_ledger_->scale_class(k, target_kg[c] / fill.before_kg[c]);
      else
        fill.dust_without_mass.push_back(k);
    }
  fill.particles_added = plan.copies.size();
  fill.rejected_draws = plan.rejected_draws;
  fill.without_source = plan.without_source;
  fill.out_of_room = plan.out_of_room;
  filled_mass_kg_ +=
      fill.particles_kg + fill.dust_kg - fill.particles_removed_kg - fill.dust_removed_kg;
  filled_energy_j_ += fill.energy_j;
  fill.after_kg = holdup_by_compartment_kg();
  refresh_forces();
  filled_momentum_ += momentum_balance().in_flight - in_flight_before;
  return fill;
}

void Simulation::deposit_fresh_dust() {
  std::vector<Breakage::DustDeposit>& fresh = breakage_->fresh_dust();
  for (const Breakage::DustDeposit& d : fresh) {
    Vec3 x = d.position_m;
    box_.wrap(x);
    dust_ledger_->deposit(
        x, dust_class_of(dust_edges_m_, dust_ledger_->class_count(), d.diameter_m), d.mass_kg);
  }
  fresh.clear();
}

void Simulation::tally_windowed_table_dust() {
  std::vector<Breakage::DustDeposit>& fresh = breakage_->fresh_dust();
  if (in_product_window())
    for (const Breakage::DustDeposit& d : fresh)
      window_dust_table_.add(d.diameter_m, d.mass_kg, d.number);
  fresh.clear();
}

PsdTally Simulation::product_tally() const {
  PsdTally product = product_window_s_ ? window_outlet_ : outlet_;
  if (dust_ledger_) {
    const std::vector<DustClass>& classes = dust_ledger_->classes();
    for (int k = 0; k < dust_ledger_->class_count(); ++k) {
      const double d = classes[std::size_t(k)].diameter_m;
      const double mass =
          product_window_s_ ? window_dust_out_kg_[std::size_t(k)] : dust_ledger_->outflow_kg(k);
      if (mass > 0.0) product.add(d, mass, mass / sphere_mass_kg(dust_density_kg_per_m3_, d));
    }
  } else if (breakage_) {
    product.add(product_window_s_ ? window_dust_table_ : breakage_->dust());
  }
  return product;
}

std::optional<MassFlows> Simulation::mass_flows() const {
  if (!flows_) return std::nullopt;
  MassFlows f = *flows_;
  integrate_tracked(f, time_s());
  if (dust_ledger_)
    for (int k = 0; k < dust_ledger_->class_count(); ++k) {
      const int from = MassFlows::dust(k, f.slots);
      f.left_kg[std::size_t(from)] = dust_ledger_->outflow_kg(k);
      if (!dust_grinding_) continue;
      // Each class's ground mass lands by the same shares every time (dust/dust_grinding.h).
      const double ground = dust_grinding_->stats().ground_kg[std::size_t(k)];
      const std::vector<double>& to = dust_grinding_->moved_to(k);
      for (std::size_t l = 0; l < to.size(); ++l)
        if (int(l) != k) f.moved(from, MassFlows::dust(int(l), f.slots)) = ground * to[l];
    }
  return f;
}

std::vector<double> Simulation::holdup_by_compartment_kg() const {
  const int slots = int(outlet_.edges_m.size()) + 1;
  std::vector<double> held(2 * std::size_t(slots), 0.0);
  for (std::size_t i = 0; i < particles_.size(); ++i)
    held[std::size_t(psd_slot(outlet_.edges_m, 2.0 * particles_.radius_m[i]))] +=
        particles_.mass_kg[i];
  if (dust_ledger_)
    for (int k = 0; k < dust_ledger_->class_count(); ++k)
      held[std::size_t(MassFlows::dust(k, slots))] = dust_ledger_->held_kg(k);
  return held;
}

MassBalance Simulation::mass_balance() const {
  MassBalance b;
  b.initial_kg = initial_mass_kg_;
  b.fed_kg = fed_mass_kg_;
  b.filled_kg = filled_mass_kg_;
  for (double m : particles_.mass_kg) b.particles_kg += m;
  b.outlet_kg = outlet_.total_mass_kg();
  b.dust_kg = breakage_ ? breakage_->dust().total_mass_kg() : 0.0;
  if (dust_ledger_) b.dust_kg += dust_ledger_->filled_kg();
  return b;
}

MomentumBalance Simulation::momentum_balance() const {
  MomentumBalance b;
  b.initial = initial_momentum_;
  b.fed = fed_momentum_;
  b.filled = filled_momentum_;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    b.particles += particles_.motion[i].velocity_m_per_s * particles_.mass_kg[i];
    b.in_flight += particles_.load[i].force_n * (0.5 * time_.step_s);
  }
  b.outlet = outlet_momentum_;
  if (breakage_) b.dust = breakage_->dust_momentum_kg_m_per_s();
  return b;
}

double Simulation::momentum_scale_kg_m_per_s() const {
  double scale = 0.0;
  for (std::size_t i = 0; i < particles_.size(); ++i)
    scale += particles_.mass_kg[i] * norm(particles_.motion[i].velocity_m_per_s);
  return scale;
}

Vec3 Simulation::removed_momentum_kg_m_per_s() const {
  return outlet_momentum_ + (breakage_ ? breakage_->dust_momentum_kg_m_per_s() : Vec3{});
}

std::optional<StepFailure> Simulation::check_health() {
  const ParticleStore& p = particles_;
  const std::string dt_text = concat(time_.step_s, " s");
  // The first slot with a non-finite state, then the first outside the box: per block of slots
  // on the engine's threads, the lowest over the blocks (what one pass in slot order finds).
  const std::size_t n = p.size(), block = balanced_block_items(n);
  const bool team = worth_threads(n);
  const std::size_t non_finite = first_index_where(team, n, block, [&](std::size_t i) {
    return !(is_finite(p.position_m[i]) && is_finite(p.motion[i].velocity_m_per_s) &&
             is_finite(p.motion[i].angular_velocity_rad_per_s));
  });
  if (non_finite < n) {
    const std::size_t i = non_finite;
    return StepFailure{step_index_, time_s(), p.id[i], "non_finite_state",
                       concat("particle ", p.id[i], " (d = ", 2 * p.radius_m[i],
                              " m) has a non-finite position or velocity; the time step ", dt_text,
                              " is likely too large for its contacts: lower /time/step_s or "
                              "/time/safety_factor")};
  }
  auto outside_on_axis = [&](std::size_t i, int a) {
    const double x = p.position_m[i][a], r = p.radius_m[i];
    return !box_.periodic[a] && (x < box_.min_m[a] - r || x > box_.max_m[a] + r);
  };
  const std::size_t escaped = first_index_where(team, n, block, [&](std::size_t i) {
    return outside_on_axis(i, 0) || outside_on_axis(i, 1) || outside_on_axis(i, 2);
  });
  if (const std::size_t i = escaped; i < n)
    for (int a = 0; a < 3; ++a) {
      if (outside_on_axis(i, a))
        return StepFailure{step_index_, time_s(), p.id[i], "particle_escaped",
                           concat("particle ", p.id[i], " (d = ", 2 * p.radius_m[i], " m, speed ",
                                  norm(p.motion[i].velocity_m_per_s),
                                  " m/s) left the domain through a "
                                  "wall on axis ",
                                  a, ": the impact was too fast for the step ", dt_text,
                                  "; raise /contact/max_impact_speed_m_per_s to at least "
                                  "that speed so the automatic step resolves it")};
    }
  const double overlap_guard = 2.0 * contact_.penetration_limit;
  if (contact_stats_.max_overlap_ratio > overlap_guard)
    return StepFailure{step_index_, time_s(), contact_stats_.max_overlap_particle,
                       "excessive_overlap",
                       concat(describe_worst_overlap(contact_stats_), "; the guard stops runs at ",
                              100.0 * overlap_guard,
                              " % (twice /contact/penetration_limit). The "
                              "contact is too soft or too fast for the step ",
                              dt_text,
                              ": raise /contact/max_impact_speed_m_per_s, lower the reduced-"
                              "stiffness threshold, or lower the step")};
  if (check_energy_ && step_index_ % kEnergyCheckSteps == 0) {
    const double growth = energy().total_j() - energy_reference_j_ - energy_added_j_;
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
    e.kinetic_j += 0.5 * p.mass_kg[i] * norm2(p.motion[i].velocity_m_per_s);
    e.rotational_j +=
        0.5 * norm2(p.motion[i].angular_velocity_rad_per_s) / p.inv_inertia_per_kg_m2[i];
    e.potential_j -= p.mass_kg[i] * dot(gravity_m_per_s2_, p.position_m[i]);
  }
  e.elastic_j = contact_elastic_energy_j(contact_.model, materials_, box_, walls_, p, neighbors_);
  return e;
}

}  // namespace millsim
