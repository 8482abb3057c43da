// Breakage module (DESIGN.md data flow: impacts → selection → fragments; §5 dust table). Built
// only for scenes with a breakable material. Each step it takes the contact onsets recorded by
// the force pass, turns each into an equivalent wall-impact energy per breakable partner
// (strength.h), applies it to the particle's remaining strength (fatigue), and replaces every
// particle that breaks by fragments drawn from its material's breakage function
// (fragment_sizes.h) and placed inside it (fragment_spawn.h). Fragments smaller than the dust
// threshold are never created: their mass, count and momentum go to the dust table.
// Mass is conserved to rounding: parent = fragments + dust, each fragment's mass from its
// diameter exactly as the particle store computes it.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "comminution/fragment_sizes.h"
#include "contact/contact_forces.h"
#include "contact/walls.h"
#include "core/rng.h"
#include "particles/materials.h"
#include "particles/particle_store.h"
#include "process/mass_flows.h"
#include "process/psd.h"
#include "scene/scene_config.h"
#include "search/neighbor_list.h"

namespace millsim {

struct BreakageStats {
  std::uint64_t impacts = 0;          // impacts on breakable particles above W_min
  std::uint64_t fatigue_impacts = 0;  // of those, survived (and weakened, with fatigue)
  std::uint64_t events = 0;           // particles broken (by impacts and crushing)
  std::uint64_t crush_events = 0;     // of those, crushed past the penetration limit
  std::uint64_t fragments = 0;        // fragments created as particles
  std::uint64_t dust_fragments = 0;   // fragments sent to the dust table
  double broken_mass_kg = 0.0;
  std::uint64_t completed_impacts = 0;  // breaking impacts turned into their rebound
  // Breakage events by the broken particle's generation (0 = a fed or initial particle, 1 = a
  // fragment, 2 = a fragment of a fragment, ...; generations stop counting at 255).
  std::vector<std::uint64_t> events_by_generation;
  int max_generation = 0;  // of the particles (and dust) the run made
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, impacts, fatigue_impacts, events, crush_events, fragments, dust_fragments,
           broken_mass_kg, completed_impacts, events_by_generation, max_generation);
  }
};

// A particle squeezed past the penetration limit: by another particle, or against a wall only.
struct CrushedParticle {
  std::uint32_t slot;
  bool against_wall = false;
};

// One breakage event, as run.h5's /breakage_events lists it.
struct BreakageEvent {
  double time_s = 0.0;
  Vec3 position_m;
  double parent_diameter_m = 0.0;
  // Of the impact that broke it, by the scene's impact equivalence (the energy the strength
  // model compared); 0 for a particle crushed past the penetration limit.
  double specific_energy_j_per_kg = 0.0;
  double dust_mass_kg = 0.0;  // of the parent, gone to the dust table
  ParticleId parent_id = 0;
  std::uint32_t fragments = 0;  // kept as particles
  std::uint8_t generation = 0;  // of the parent (0: fed or initial)
  std::uint8_t crushed = 0;
  // The impact that broke it was on a wall, or it was crushed against one.
  std::uint8_t by_wall = 0;
};

class Breakage {
 public:
  // The event log keeps the first this many events (the counters count them all).
  static constexpr std::size_t kMaxLoggedEvents = 1000000;

  // `reduced_stiffness_threshold_m`: fragments below it get the reduced stiffness (§4).
  Breakage(const SceneConfig& scene, const MaterialTable& materials,
           std::optional<double> reduced_stiffness_threshold_m, std::uint64_t seed,
           std::vector<double> psd_edges_m);

  bool breakable(int material) const { return material_[std::size_t(material)].has_value(); }
  double dust_threshold_m() const { return dust_threshold_m_; }

  // Draws the strength of the particle in `slot` (a breakable material's particle just added).
  void draw_strength(ParticleStore& particles, std::size_t slot);

  // Called with a particle's slot just before it is removed and just after a fragment is added,
  // so the caller can keep its energy ledger.
  using ParticleHook = std::function<void(const ParticleStore&, std::size_t)>;

  // Applies one step's impacts. Broken particles are removed, fragments appended with new ids
  // from `next_id` and listed in `newborn` (for the neighbour list). Returns the events.
  // Each fragment takes its mass share of the parent's stored force and torque, so the next
  // half-kicks stay balanced (dem/integrator.h); the dust's share leaves with the dust as
  // ½ dt F m_dust/m: the dust momentum is then exactly what Verlet would have given it.
  // `crushed`: particles squeezed past the penetration limit this step (by another particle or
  // against a wall; the first listing of a slot counts). A breakable one
  // breaks: Hertz contact is meaningless there and the real particle would have fractured; an
  // impact-energy criterion misses such slow squeezes (a fine caught between a wall and a
  // coarse particle). An impact that breaks a particle is completed first (complete_impact).
  // `time_s`: the time the events are logged at.
  std::uint64_t process(const std::vector<Impact>& impacts,
                        const std::vector<CrushedParticle>& crushed, double dt_s, double time_s,
                        const std::vector<Wall>& walls, const PeriodicBox& box,
                        ParticleStore& particles, ParticleId& next_id,
                        std::vector<Newborn>& newborn, const ParticleHook& before_removal,
                        const ParticleHook& after_addition);

  // Whether process() could break anything with these impacts and crushes: a crushed particle
  // of a breakable material, or an impact above its W_min (process() then draws whether it
  // breaks). Changes nothing.
  bool may_break(const std::vector<Impact>& impacts, const std::vector<CrushedParticle>& crushed,
                 const std::vector<Wall>& walls, const ParticleStore& particles) const;

  const BreakageStats& stats() const { return stats_; }
  const std::vector<BreakageEvent>& event_log() const { return event_log_; }
  const PsdTally& dust() const { return dust_; }
  // Dust made since the caller last emptied the list, where it was made (the parent's centre),
  // when recording is on (the dust ledger, dust/dust_ledger.h); the table above holds it too.
  struct DustDeposit {
    Vec3 position_m;
    double diameter_m;  // the class's representative size, as in the table
    double mass_kg;
    double number;  // of particles the mass stands for, as in the table
  };
  void record_dust(bool on) { record_dust_ = on; }
  std::vector<DustDeposit>& fresh_dust() { return fresh_dust_; }
  const Vec3& dust_momentum_kg_m_per_s() const { return dust_momentum_; }
  // Where breakage moves mass, into `flows` (process/mass_flows.h) from now on, on the dust
  // table's edges: each event of a parent in slot j, its fragments' mass from particles j to
  // particles of their slots, its dust's to dust of theirs. The flows outlive the breakage.
  void record_flows(MassFlows* flows) { flows_ = flows; }

  // Checkpoints: the generator, the fragment pools, the dust table and the counters (the rest is
  // the scene's).
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, rng_, dust_, dust_momentum_, stats_, pools_, event_log_);
  }

 private:
  struct Material {
    MaterialBreakageConfig config;
    FragmentSizeSampler sampler;
  };

  // Specific energy of the impact on `particle` (J/kg), by the scene's equivalence.
  double impact_energy_j_per_kg(const Impact& impact, bool on_partner,
                                const std::vector<Wall>& walls, const ParticleStore& p) const;
  // Turns an impact's normal approach into its restitution rebound (momentum-conserving
  // between two particles; the wall takes its impulse), before the fragments are spawned.
  void complete_impact(const Impact& impact, const std::vector<Wall>& walls, const PeriodicBox& box,
                       ParticleStore& p);
  // Adds `mass` below the dust threshold to the dust table, spread over its classes by the
  // breakage function; returns the number of particles that mass stands for.
  std::uint64_t spread_below_threshold(const FragmentSizeSampler& sampler, const Vec3& x,
                                       double parent_d, double density, double mass);
  // One entry of dust made at x: into the table, and the fresh list when recording.
  void add_dust(const Vec3& x, double diameter_m, double mass_kg, double number);
  // `event`: the log's record, filled here with what the breakage made.
  void break_particle(std::size_t slot, double dt_s, BreakageEvent event, ParticleStore& p,
                      ParticleId& next_id, std::vector<Newborn>& newborn,
                      const ParticleHook& after_addition);

  const MaterialTable* materials_;
  std::vector<std::optional<Material>> material_;
  ImpactEquivalence equivalence_;
  int placement_attempts_;
  double dust_threshold_m_;
  std::optional<double> reduced_threshold_m_;
  Rng rng_;
  std::vector<FragmentPool> pools_;  // per material: draws kept for later breakages
  PsdTally dust_;
  Vec3 dust_momentum_;
  bool record_dust_ = false;
  std::vector<DustDeposit> fresh_dust_;  // emptied by the caller after each process()
  MassFlows* flows_ = nullptr;
  int flows_parent_slot_ = 0;  // of the parent break_particle is breaking
  BreakageStats stats_;
  std::vector<BreakageEvent> event_log_;
};

}  // namespace millsim
