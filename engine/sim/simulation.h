// Simulation: builds the run's state from a validated SceneConfig (only the modules the scene
// names) and advances it one DEM step at a time. The step reads like DESIGN.md's data flow;
// this class is a sequencer, not a home for everyone's data. Output and the run loop live in
// sim/run.h.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "comminution/breakage.h"
#include "contact/contact_forces.h"
#include "contact/walls.h"
#include "core/errors.h"
#include "dem/box.h"
#include "dem/time_step.h"
#include "dust/dust_grinding.h"
#include "dust/dust_ledger.h"
#include "gas/coupling.h"
#include "particles/materials.h"
#include "particles/particle_store.h"
#include "process/feed.h"
#include "process/impact_spectrum.h"
#include "process/psd.h"
#include "scene/scene_config.h"
#include "search/neighbor_list.h"
#include "sim/multi_rate.h"
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
  double impact_speed_m_per_s = 0.0;  // expected largest impact speed used for the bounds
  TimeStepBounds bounds;              // with reduced stiffness, if on
  double stable_bound_s = 0.0;        // the largest step accepted: min(t_R, t_c / 8)
  double travel_bound_s = 0.0;        // the penetration limiter's (dem/time_step.h)
};

struct ReducedStiffnessInfo {
  double threshold_diameter_m = 0.0;
  bool automatic = false;
  double predicted_penetration_ratio = 0.0;  // of the smallest particle at the impact speed
  bool limited_by_real_stiffness = false;
  std::uint64_t reduced_particles = 0;
  double time_step_gain = 1.0;  // automatic step with reduction / without (§4: ≈ 3 in Fig. 9)
};

// Where the mass went: particles + outlet + dust = initial + fed + filled, to rounding.
struct MassBalance {
  double initial_kg = 0.0;
  double fed_kg = 0.0;
  double filled_kg = 0.0;  // added by a hold-up fill (Simulation::fill_holdup), particles and dust
  double particles_kg = 0.0;
  double outlet_kg = 0.0;
  double dust_kg = 0.0;  // made by breakage, and the ledger's dust a fill added
  double relative_error() const {
    const double in = initial_kg + fed_kg + filled_kg;
    return in > 0.0 ? (particles_kg + outlet_kg + dust_kg - in) / in : 0.0;
  }
};

// How far the constructor takes a run.
enum class SimulationStart {
  Complete,     // the gas spun up (scene.gas.spin_up_s) and the first forces computed
  ForRestore,   // a checkpoint's state goes in next (checkpoint_io): no spin-up
  AfterSpinUp,  // the caller spins the gas up (spin_up_gas, as it likes) and calls finish_start
};

// Where the momentum went (kg m/s): held by the particles (Σ m v, plus ½ dt Σ F, the force in
// flight that velocity Verlet still owes), carried out by outlet particles and by dust, against
// what the run started with and what the feeds brought in. Their difference is the impulse of
// the walls, gravity and the gas: zero to rounding in a closed periodic scene without them.
struct MomentumBalance {
  Vec3 initial, fed, filled, particles, in_flight, outlet, dust;  // filled: by a hold-up fill
  Vec3 held() const { return particles + in_flight + outlet + dust; }
  Vec3 external_impulse() const { return held() - initial - fed - filled; }
};

// What a hold-up fill did (Simulation::fill_holdup). Per compartment: process/mass_flows.h.
struct HoldupFill {
  double time_s = 0.0;
  std::vector<double> target_kg, before_kg, after_kg;
  std::uint64_t particles_added = 0;
  double particles_kg = 0.0, dust_kg = 0.0;
  double energy_j = 0.0;  // kinetic, rotational and potential energy added, less that removed
  std::uint64_t rejected_draws = 0;
  std::vector<int> without_source, out_of_room;  // particle slots left short (holdup_fill.h)
  std::vector<int> dust_without_mass;            // ledger classes short that held nothing
  // With removal: the particles taken from slots above their target, and the dust.
  std::uint64_t particles_removed = 0;
  double particles_removed_kg = 0.0, dust_removed_kg = 0.0;
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, time_s, target_kg, before_kg, after_kg, particles_added, particles_kg, dust_kg);
    io_all(a, energy_j, rejected_draws, without_source, out_of_room, dust_without_mass);
    io_all(a, particles_removed, particles_removed_kg, dust_removed_kg);
  }
};

class Simulation {
 public:
  // Throws InputErrorList when the scene cannot be built (bad particle files, overfull
  // packings, a time step above the stable bound, particles outside the domain or overlapping
  // past the penetration limit at the start, ...): with AfterSpinUp too, before any spin-up.
  Simulation(const SceneConfig& scene, SimulationStart start);
  // `for_restore`: ForRestore, else Complete.
  explicit Simulation(const SceneConfig& scene, bool for_restore = false)
      : Simulation(scene, for_restore ? SimulationStart::ForRestore : SimulationStart::Complete) {}
  // Modules keep pointers to the material table: a simulation stays where it was built.
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // AfterSpinUp only: the gas still spins up or the first forces are still to compute. Spin-up
  // steps and the gas state in between are the same however the spin-up is divided into calls.
  bool start_pending() const { return start_pending_; }
  // At most `max_steps` more gas steps of the spin-up; throws InputErrorList when the gas fails.
  void spin_up_gas(std::uint64_t max_steps);
  // The rest of the spin-up, the first gas step and forces: the state Complete builds.
  void finish_start();

  // One DEM step; returns the failure when the stability guard stops the run. The state is
  // complete on return (with multi-rate stepping, particles in free flight are caught up).
  std::optional<StepFailure> step();
  // `steps` DEM steps (fewer when one fails), the same trajectory bit for bit as calling step()
  // that often, but faster: while nothing looks at the state between two steps of the call (no
  // limiter event, population change, gas step or health check), a step's closing kick is
  // carried into the next step's opening kick-drift, one pass over the particles instead of two.
  // The state is complete on return. With multi-rate stepping (sim/multi_rate.h) the particles
  // in free flight wait between the times something reads them, and are caught up on return.
  std::optional<StepFailure> advance(std::int64_t steps);
  // Whether advance() carries closing kicks into the next step (the default). Off, every step
  // closes its own: the same numbers, more slowly (tests hold the two to the same bits).
  void carry_closing_kicks(bool on) { carry_kicks_ = on; }
  // Steps whose closing kick was carried into the next one, since this object was built (a count
  // for tests and profiles; not in checkpoints).
  std::uint64_t carried_kicks() const { return carried_kicks_; }

  std::int64_t step_index() const { return step_index_; }
  double time_s() const { return double(step_index_) * time_.step_s; }
  std::int64_t total_steps() const { return total_steps_; }
  const TimeStepInfo& time_step() const { return time_; }
  const std::optional<ReducedStiffnessInfo>& reduced_stiffness() const { return reduced_; }
  std::uint64_t penetration_limiter_events() const { return limiter_events_; }

  const ParticleStore& particles() const { return particles_; }
  ParticleStore& particles() { return particles_; }  // tests and sources may edit state
  const PeriodicBox& box() const { return box_; }
  const std::vector<Wall>& walls() const { return walls_; }
  const MaterialTable& materials() const { return materials_; }
  const NeighborList& neighbors() const { return neighbors_; }
  const ContactStepStats& contact_stats() const { return contact_stats_; }
  const StepProfile& profile() const { return profile_; }
  StepProfile& profile() { return profile_; }
  ContactModel contact_model() const { return contact_.model; }

  // Breakage, outlets and feeds (each absent unless the scene has it).
  const Breakage* breakage() const { return breakage_ ? &*breakage_ : nullptr; }
  // The gas solver and its coupling (absent unless the scene has a gas section).
  const GasCoupling* gas() const { return gas_ ? &*gas_ : nullptr; }
  // The dust ledger (absent unless the scene's dust model is "ledger").
  const DustLedger* dust_ledger() const { return dust_ledger_ ? &*dust_ledger_ : nullptr; }
  bool dust_two_way() const { return dust_two_way_; }
  double dust_carry_courant() const { return dust_carry_courant_; }
  double dust_max_cell_loading() const { return dust_max_cell_loading_; }
  // The ledger's grinding by the particles (absent unless the scene's dust.grinding is "sweep").
  const DustGrinding* dust_grinding() const { return dust_grinding_ ? &*dust_grinding_ : nullptr; }
  GasCoupling* gas() { return gas_ ? &*gas_ : nullptr; }
  const std::vector<Feeder>& feeders() const { return feeders_; }
  const std::optional<MillConfig>& mill() const { return mill_; }
  const PsdTally& outlet_tally() const { return outlet_; }  // particles that left by an outlet
  const std::vector<double>& outlet_mass_by_outlet_kg() const { return outlet_mass_kg_; }
  // The run's product: outlet particles + the dust table, or with the dust ledger, outlet
  // particles + the dust that left through the gas's outlets.
  PsdTally product_tally() const;
  const std::optional<std::array<double, 2>>& product_window_s() const { return product_window_s_; }
  // Where the mass went, by PSD slot and phase, cumulative up to now (process/mass_flows.h; absent
  // in scenes without outlets, feeds or breakage), and the hold-up now by compartment.
  std::optional<MassFlows> mass_flows() const;
  std::vector<double> holdup_by_compartment_kg() const;
  MassBalance mass_balance() const;
  // Momentum that left the run with outlet particles and dust.
  Vec3 removed_momentum_kg_m_per_s() const;
  MomentumBalance momentum_balance() const;
  // Σ m |v| over the particles: the size of the momentum in play, for relative checks.
  double momentum_scale_kg_m_per_s() const;
  double particle_steps() const { return particle_steps_; }
  // Multi-rate stepping's state and counters (absent unless the scene has /time/multi_rate).
  const MultiRate* multi_rate() const { return multi_rate_on_ ? &multi_rate_ : nullptr; }
  // The impact-energy spectrum (absent unless the scene's output has it; on with breakage).
  const ImpactSpectrum* impact_spectrum() const {
    return impact_spectrum_ ? &*impact_spectrum_ : nullptr;
  }
  // Ends the spectrum's output interval now (the run loop, at each snapshot on its schedule).
  void close_impact_interval() {
    if (impact_spectrum_) impact_spectrum_->close_interval(time_s());
  }
  // Σ over steps of the touching particle pairs: contact-steps, for per-contact figures.
  std::uint64_t contact_steps() const { return contact_steps_; }

  // Checkpoints (checkpoint/checkpoint_file.h): everything an exact continuation reads, saved
  // into or restored from an archive. A restore goes into a Simulation built from the same
  // scene, which fixes what is not listed here (materials, walls, the modules a scene has).
  template <class A>
  void checkpoint_io(A& a);

  // Fills the hold-up towards `target_kg` per compartment (process/mass_flows.h): a particle
  // slot short of it with copies of its particles turned about the mill's axis
  // (process/holdup_fill.h; `seed` draws them), a ledger dust class by scaling its mass in every
  // cell; a compartment at or above its target is left as it is, unless `removes`: then a
  // particle slot above it loses particles drawn at random from it and a dust class is scaled
  // down. The mass, momentum and energy added, less those removed, are booked as filled
  // (mass_balance(), momentum_balance(), filled_energy_j()), the copies and removals as tracked
  // hold-up in the mass flows, not as fed or left. Then forces are recomputed and the
  // energy guard takes the filled state as its reference (refresh_forces). Needs a mill and mass
  // flows (a scene with outlets, feeds or breakage); throws std::logic_error otherwise.
  HoldupFill fill_holdup(const std::vector<double>& target_kg, std::uint64_t seed,
                         bool removes = false);
  double filled_energy_j() const { return filled_energy_j_; }

  EnergyReport energy() const;
  // Recomputes forces for the current state after editing particles by hand; the edited state
  // becomes the energy guard's reference.
  void refresh_forces();

 private:
  // `later`: particles the run may create (feeds, the smallest fragment), for the bounds.
  void choose_time_step(const SceneConfig& scene, const ParticleStore& later, InputErrors& errors);
  // The force pass; `wall_ranges`: the wall candidates to compute (all when null).
  // worth_threads()' minimum for the force pass and the rebuild (parallel/thread_team.h).
  std::size_t min_items_for_threads() const;
  void compute_forces(const std::vector<NeighborList::PairRange>* wall_ranges = nullptr);
  // Contact forces, then the fluid forces of a force pass that is not a step's (no impulse).
  void compute_all_forces();
  // Breakage, outlets and feeds at the end of a step; rebuilds the neighbour list when the
  // population changed.
  void process_population();
  double particle_energy_j(std::size_t slot) const;
  // The energy guard's reference and scale, from the current state.
  void set_energy_baseline();
  std::optional<StepFailure> check_health();
  // One step; with `may_defer` its closing kick may be left for the next step (advance()).
  std::optional<StepFailure> step_once(bool may_defer);
  // One step of the particles that are not in free flight (sim/multi_rate.h); a full step of all
  // when the neighbour list is about to measure motion. With `may_defer`, the stepping particles'
  // closing kick may be left for the next step's kick-drift, as step_once's.
  std::optional<StepFailure> step_multi_rate(bool may_defer);
  // The stepping particles' closing kick, if the last multi-rate step left it: called by
  // whatever reads their velocities or changes the sets before the next step's kick-drift. Their
  // held exchange is booked first (book_stepping_exchange).
  void finish_stepping_kick();
  // The exchange the stepping particles' kept fluid forces made over the steps since it was last
  // booked, into their impulses for the gas (sim/multi_rate.h: before anything reads the impulses,
  // replaces the kept forces, or changes the stepping set or its slots).
  void book_stepping_exchange();
  // After a rebuild: which particles are in free flight now.
  void prepare_multi_rate();
  // Brings the particles in free flight and the wall riders up to the current step in one long
  // step each.
  void catch_up_free_flight();
  // Brings one wall-rider level up to the current step: one step of its own, its wall contacts
  // computed at that step.
  void catch_up_riders(int level);
  // The wall riders' recorded impacts and crushes into this step's statistics (by their current
  // slots), with the whole population caught up first if any was recorded before this step.
  void take_rider_events();
  // After a step's force pass: whether the penetration limiter must act, and whether the
  // stability guard looks at the state.
  bool limiter_due() const;
  bool health_due() const;
  // One CFD step at the current DEM step; the failure when the gas solver stops.
  std::optional<StepFailure> advance_gas();
  // The ledger's dust per volume onto the compressible gas (two-way) and its largest mass
  // loading c/ρ so far, before each gas advance.
  void lay_dust_on_gas();
  std::string describe_worst_overlap(const ContactStepStats& stats) const;
  // Counts this step's impacts into the spectrum (before breakage turns their slots stale).
  void tally_impacts();
  // The end of the constructor's work: the first gas step (unless restoring), the first forces,
  // the start's overlap check and the energy guard's reference.
  void complete_start(bool first_gas_step);
  void check_start_overlaps() const;
  void throw_on_start_overlap(const ContactStepStats& stats) const;

  MaterialTable materials_;
  ParticleStore particles_;
  PeriodicBox box_;
  std::vector<Wall> walls_;
  NeighborList neighbors_;
  ContactConfig contact_;
  Vec3 gravity_m_per_s2_;
  TimeStepInfo time_;
  std::optional<ReducedStiffnessInfo> reduced_;
  std::int64_t total_steps_ = 0;
  std::int64_t step_index_ = 0;
  std::uint64_t limiter_events_ = 0;
  double energy_reference_j_ = 0.0;  // total energy at the start
  double energy_scale_j_ = 0.0;      // size of the energies in play, for the growth check
  bool check_energy_ = true;
  ContactStepStats contact_stats_;
  StepProfile profile_;
  ParticleId next_id_ = 1;
  double particle_steps_ = 0.0;
  std::uint64_t contact_steps_ = 0;
  std::vector<double> block_max_speed_;  // per slot block, from the kick-drift pass
  bool forces_prepared_ = false;         // previous_load holds gravity only (dem/integrator.h)
  bool loads_listed_ = false;            // a listed kick-drift prepared each stepped load itself
  bool kick_pending_ = false;            // the last step's closing kick is still to do (advance())
  // The same for multi-rate's stepping particles (kick_listed of multi_rate_.stepping). Never set
  // between two calls of advance(), so not in checkpoints.
  bool stepping_kick_pending_ = false;
  bool carry_kicks_ = true;  // carry_closing_kicks()
  std::uint64_t carried_kicks_ = 0;
  double energy_added_j_ = 0.0;  // energy of particles added minus removed since the start
  std::optional<Breakage> breakage_;
  std::optional<GasCoupling> gas_;
  std::vector<OutletConfig> outlets_;
  std::optional<MillConfig> mill_;
  std::vector<Feeder> feeders_;
  PsdTally outlet_;
  std::vector<double> outlet_mass_kg_;
  Vec3 outlet_momentum_;
  double initial_mass_kg_ = 0.0;
  double fed_mass_kg_ = 0.0;
  double filled_mass_kg_ = 0.0;  // fill_holdup's, particles and dust
  Vec3 filled_momentum_;
  double filled_energy_j_ = 0.0;
  Vec3 fed_momentum_;      // Σ m v of the fed particles as they entered
  Vec3 initial_momentum_;  // held by the particles at the start (with the force in flight)
  std::int64_t last_population_step_ = 0;              // when outlets and feeds were last applied
  std::uint64_t population_list_ = ~std::uint64_t(0);  // the list (rebuild count) they were at
  double feed_mass_bound_kg_ = 0.0;                    // what the feeds can bring in over the run
  double feed_kinetic_bound_j_ = 0.0;
  double drag_relaxation_s_ = 1e300;  // Stokes τ of the smallest particle (gas scenes only)
  bool multi_rate_on_ = false;
  MultiRate multi_rate_;
  std::optional<RiderRule> rider_rule_;       // /time/wall_riders
  std::vector<std::uint32_t> rider_crushed_;  // slots taken from the riders' events this step
  bool start_pending_ = false;                // AfterSpinUp, until finish_start()
  std::optional<ImpactSpectrum> impact_spectrum_;
  std::optional<DustLedger> dust_ledger_;
  std::optional<DustGrinding> dust_grinding_;
  std::vector<double> dust_edges_m_;          // the dust table's PSD edges (the ledger's classes)
  double dust_density_kg_per_m3_ = 0.0;       // the breakable material's: the ledger's dust
  std::int64_t dust_advanced_step_ = 0;       // the step the ledger was last carried to
  double dust_carry_courant_ = 0.0;           // /dust/carry_courant (0: every CFD step)
  bool dust_two_way_ = false;                 // the gas carries the ledger's dust as inertia
  double dust_max_cell_loading_ = 0.0;        // the largest c/ρ of a gas cell at a gas advance
  std::vector<double> dust_density_scratch_;  // one-way: the ledger's kg/m³, for the loading
  // The product's window (psd.product_window_s; absent: the whole run) and what left in it:
  // outlet particles, the ledger's dust out per class, or the table's dust made.
  std::optional<std::array<double, 2>> product_window_s_;
  PsdTally window_outlet_, window_dust_table_;
  std::vector<double> window_dust_out_kg_, dust_out_seen_kg_;
  std::optional<MassFlows> flows_;  // breakage records into it (Breakage::record_flows)
  bool in_product_window() const {
    return !product_window_s_ ||
           (time_s() >= (*product_window_s_)[0] && time_s() < (*product_window_s_)[1]);
  }
  // Whether the ledger is carried at this CFD step (/dust/carry_courant).
  bool dust_carry_due() const;
  // Moves the dust the breakage made this step into the ledger.
  void deposit_fresh_dust();
  // The table's dust made this step, into the product when inside its window.
  void tally_windowed_table_dust();
};

template <class A>
void Simulation::checkpoint_io(A& a) {
  io_all(a, particles_, neighbors_, time_, reduced_, total_steps_, step_index_, limiter_events_);
  io_all(a, energy_reference_j_, energy_scale_j_, check_energy_, contact_stats_, profile_, next_id_,
         particle_steps_, contact_steps_, block_max_speed_, forces_prepared_, kick_pending_,
         energy_added_j_, loads_listed_, multi_rate_on_, multi_rate_);
  // The modules the scene has: present in both the saved and the restoring run.
  if (breakage_) io(a, *breakage_);
  if (gas_) io(a, *gas_);
  if (dust_ledger_) io_all(a, *dust_ledger_, dust_advanced_step_, dust_max_cell_loading_);
  if (dust_grinding_) io(a, *dust_grinding_);
  io_all(a, window_outlet_, window_dust_table_, window_dust_out_kg_, dust_out_seen_kg_, flows_);
  for (Feeder& f : feeders_) io(a, f);
  io_all(a, outlet_, outlet_mass_kg_, outlet_momentum_, initial_mass_kg_, fed_mass_kg_,
         last_population_step_, feed_mass_bound_kg_, feed_kinetic_bound_j_, drag_relaxation_s_,
         impact_spectrum_, fed_momentum_, initial_momentum_, population_list_);
  io_all(a, filled_mass_kg_, filled_momentum_, filled_energy_j_);
}

}  // namespace millsim
