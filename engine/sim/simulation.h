// Simulation: builds the run's state from a validated SceneConfig (only the modules the scene
// names) and advances it one DEM step at a time. The step reads like DESIGN.md's data flow;
// this class is a sequencer, not a home for everyone's data. Output and the run loop live in
// sim/run.h.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "contact/contact_forces.h"
#include "contact/walls.h"
#include "core/errors.h"
#include "dem/box.h"
#include "particles/materials.h"
#include "particles/particle_store.h"
#include "scene/scene_config.h"
#include "search/neighbor_list.h"
#include "sim/step_profile.h"

namespace millsim {

struct EnergyReport {
  double kinetic_j = 0.0;     // ½ m v²
  double rotational_j = 0.0;  // ½ I ω²
  double potential_j = 0.0;   // −m g·x (zero without gravity)
  double elastic_j = 0.0;     // stored in contact springs
  double total_j() const { return kinetic_j + rotational_j + potential_j + elastic_j; }
};

struct TimeStepInfo {
  double step_s = 0.0;
  bool automatic = true;
  double rayleigh_min_s = 0.0;          // smallest Rayleigh time over the particles
  std::uint64_t rayleigh_particle = 0;  // its id
};

class Simulation {
 public:
  // Throws InputErrorList when the scene cannot be built (bad particle files, overfull
  // packings, a time step above the stable bound, particles outside the domain, ...).
  explicit Simulation(const SceneConfig& scene);

  // One DEM step; returns the failure when the stability guard stops the run.
  std::optional<StepFailure> step();

  std::int64_t step_index() const { return step_index_; }
  double time_s() const { return double(step_index_) * time_.step_s; }
  std::int64_t total_steps() const { return total_steps_; }
  const TimeStepInfo& time_step() const { return time_; }

  const ParticleStore& particles() const { return particles_; }
  ParticleStore& particles() { return particles_; }  // tests and sources may edit state
  const PeriodicBox& box() const { return box_; }
  const std::vector<PlaneWall>& walls() const { return walls_; }
  const MaterialTable& materials() const { return materials_; }
  const NeighborList& neighbors() const { return neighbors_; }
  const ContactStepStats& contact_stats() const { return contact_stats_; }
  const StepProfile& profile() const { return profile_; }
  StepProfile& profile() { return profile_; }
  ContactModel contact_model() const { return contact_model_; }

  EnergyReport energy() const;
  // Recomputes forces for the current state (after editing particles by hand).
  void refresh_forces();

 private:
  void compute_forces();
  std::optional<StepFailure> check_health() const;

  MaterialTable materials_;
  ParticleStore particles_;
  PeriodicBox box_;
  std::vector<PlaneWall> walls_;
  NeighborList neighbors_;
  ContactModel contact_model_ = ContactModel::SeriesSprings;
  Vec3 gravity_m_per_s2_;
  TimeStepInfo time_;
  std::int64_t total_steps_ = 0;
  std::int64_t step_index_ = 0;
  ContactStepStats contact_stats_;
  StepProfile profile_;
};

}  // namespace millsim
