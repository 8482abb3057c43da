// GasCoupling: everything between the particles and the gas solver (§3.1).
//  - Particle → gas, once per CFD step: each particle's solids volume goes to the fluid cells it
//    overlaps, in the share of its volume each holds (gas/gas_stencil.h), so a bed's end is as
//    sharp as the grid. The impulse each particle took from the gas since the last CFD step is
//    spread over the eight nearest faces with trilinear weights, renormalised over the solved
//    faces: the gas receives exactly minus what the particles received (Newton's third law, to
//    rounding).
//  - Gas → particle: each occupied DEM cell holds the mean fluid state (velocity, volume
//    fraction, density, viscosity, pressure gradient, vorticity) in a hashed table refreshed
//    once per CFD step; a particle reads its DEM cell's state, never the CFD grid, and keeps
//    that cell as a hint (particles/particle_store.h, FluidCellRef) to skip the lookup while it
//    stays there. The DEM cell's ε is its own volume mean of the cells' ε, and its gas velocity
//    the superficial velocity over that ε (DemCellFluidTable::average).
//  - The drag the particles exert on the gas is split: the impulse they took over the last
//    interval (explicit), plus an implicit response B (u_n − u*) to the gas's own change in
//    the predictor, which the particles get back as β_eff Σ w g (u* − u_n) dt right after the
//    gas step (g ≥ 1, response_gain). The gas stays stable in dense beds at any CFD step, the
//    balance stays exact, and in a steady state the response vanishes: each particle's drag is
//    the one it computed from its own reading of the gas.
//  - Drag caching (Fig. 5): a particle keeps its drag coefficient (or force) and the slip it
//    was computed at, and recomputes only when the slip has changed by more than the threshold
//    in some axis (relative to the stored slip speed).
// The compressible model (gas.model "compressible") takes the particles' momentum and the power of
// their drag as explicit sources per cell (no implicit response: its acoustic step is far below
// a mill's particle relaxation times, and the CFD step is held below half the drag relaxation
// time ρ/B of every cell), and hands the particles its local density and, with
// gas.slip_correction, the mean free path for Cunningham's correction.
// The CFD step is a whole number of DEM steps, from the gas solver's stability limit unless the
// scene fixes it. The gas lags the particles by one CFD step: at the end of an interval it
// advances over that interval with the impulse the particles took in it, and the particles
// read the result during the next one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "dem/box.h"
#include "gas/compressible/compressible_solver.h"
#include "gas/gas_config.h"
#include "gas/gas_solver.h"
#include "gas/gas_stencil.h"
#include "gas/gas_view.h"
#include "particles/particle_store.h"

namespace millsim {

struct FluidCellState {
  Vec3 velocity_m_per_s;            // interstitial gas velocity
  Vec3 pressure_gradient_pa_per_m;  // ∇p
  Vec3 vorticity_per_s;             // ∇×u (only with Saffman lift)
  double volume_fraction = 1.0;     // ε
  double density_kg_per_m3 = 0.0;
  double viscosity_pa_s = 0.0;
  double mean_free_path_m = 0.0;  // the compressible model's λ at the cell's mean state (else 0)
  double sound_speed_m_per_s = 0.0;  // the compressible model's c there (else 0)
};

// The hashed DEM-cell table: only cells that hold a particle are filled, on first use after
// clear().
class DemCellFluidTable {
 public:
  DemCellFluidTable() = default;
  // Cells of edge cell_m along each axis from origin_m.
  DemCellFluidTable(const Vec3& cell_m, const Vec3& origin_m);
  DemCellFluidTable(double cell_m, const Vec3& origin_m)
      : DemCellFluidTable(Vec3{cell_m, cell_m, cell_m}, origin_m) {}

  void clear();
  // The state of the DEM cell that holds x (wrapped into the domain by the caller).
  const FluidCellState& at(const Vec3& x, const GasView& gas, bool with_vorticity);
  // The same, with the particle's hint: when x is still in the cell the hint names and the
  // table has not been cleared since, no hash lookup; the hint is updated otherwise.
  const FluidCellState& at(const Vec3& x, const GasView& gas, bool with_vorticity,
                           FluidCellRef& hint);
  // The same without filling: null when the cell has not been filled since clear(). A caller
  // may call it from several threads at once while nothing fills the table; `last` is the
  // caller's own memory of the cell it found last (the next particle is often in it too).
  const FluidCellState* find(const Vec3& x, FluidCellRef& hint, FluidCellRef& last) const;
  // Like at(x, ..., hint) but a cell not filled yet gets its slot and index now and its state
  // from fill_pending(), which must run before any state is read: the states of many new cells
  // are then averaged on the engine's threads, each into its own index, so the table is the same
  // as at() would have made, bit for bit, on any thread count.
  void reserve(const Vec3& x, FluidCellRef& hint);
  void fill_pending(const GasView& gas, bool with_vorticity);
  const FluidCellState& state(std::uint32_t index) const { return states_[index]; }
  std::size_t size() const { return states_.size(); }
  std::uint64_t fills() const { return fills_; }
  const Vec3& cell_m() const { return cell_m_; }
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, keys_, slot_state_, states_, fills_, last_key_, last_state_, generation_);
  }

 private:
  FluidCellState average(long i, long j, long k, const GasView& gas, bool with_vorticity) const;
  std::uint64_t key_of(const Vec3& x, long& i, long& j, long& k) const;
  std::uint32_t find_or_fill(std::uint64_t key, long i, long j, long k, const GasView& gas,
                             bool with_vorticity);
  // The index of the cell's state; `inserted` when the cell was not in the table (its state then
  // still to be written).
  std::uint32_t find_or_insert(std::uint64_t key, bool& inserted);
  void grow();

  Vec3 cell_m_{1.0, 1.0, 1.0};
  Vec3 origin_m_;
  std::vector<std::uint64_t> keys_;  // 0 = empty slot, else packed cell + 1
  std::vector<std::uint32_t> slot_state_;
  std::vector<FluidCellState> states_;
  std::uint64_t fills_ = 0;
  Vec3 inverse_cell_{1.0, 1.0, 1.0};
  std::uint64_t last_key_ = 0;  // the last cell looked up (0 = none) and its state
  std::uint32_t last_state_ = 0;
  std::uint32_t generation_ = 1;  // bumped by clear(): particles' hints from before are stale
  struct PendingCell {
    std::uint32_t state;
    long i, j, k;
  };
  std::vector<PendingCell> pending_;  // reserved since the last fill_pending (empty between)
};

struct CouplingStats {
  std::uint64_t cfd_steps = 0;
  std::uint64_t gas_substeps = 0;   // > cfd_steps only when the gas needs a step below the DEM's
  std::uint64_t spin_up_steps = 0;  // gas steps solved alone before time 0 (spin_up_s)
  double spin_up_done_s = 0.0;      // of config().spin_up_s, so far
  int steps_per_cfd = 1;            // DEM steps per CFD step (the latest)
  int min_steps_per_cfd = 1 << 30, max_steps_per_cfd = 0;
  std::uint64_t drag_evaluations = 0;   // drag (and lift) computed
  std::uint64_t drag_reuses = 0;        // cached drag used
  std::uint64_t clamped_cells = 0;      // cell-steps whose ε hit the floor
  std::uint64_t unplaced_deposits = 0;  // particles whose whole stencil was outside the fluid
  // The compressible model, over the drag evaluations: the largest slip Mach number |u − v| / c
  // and Knudsen number 2λ/d met, and how many evaluations had a slip Mach number above 0.3
  // (where the incompressible drag laws start to under-predict: docs/gas.md).
  double max_slip_mach = 0.0, max_knudsen = 0.0;
  std::uint64_t drag_evaluations_past_mach_0_3 = 0;
  // With gas.mach_correction: the largest factor Loth's correction put on an evaluated drag.
  double max_mach_drag_factor = 1.0;
  double min_volume_fraction = 1.0;
  Vec3 particle_impulse_n_s;     // Σ (drag + lift) dt over all particles and steps
  Vec3 deposited_impulse_n_s;    // handed to the gas as its momentum source
  double gas_seconds = 0.0;      // gas solve
  double deposit_seconds = 0.0;  // particle → gas
};

class GasCoupling {
 public:
  // `dem_cell_m`: the smallest DEM-cell edge of the fluid table (no smaller than the largest
  // particle). Along each axis the table's cells are the gas cells divided into as many equal
  // parts no smaller than that as fit (at least one), so every DEM cell lies in one gas cell.
  GasCoupling(const GasConfig& config, const PeriodicBox& box, const Vec3& gravity_m_per_s2,
              double dem_cell_m);

  // True when the CFD step is due at this DEM step.
  bool due(std::int64_t step_index) const { return step_index >= next_cfd_step_; }
  // The DEM step of the next CFD step.
  std::int64_t next_cfd_step() const { return next_cfd_step_; }
  // One CFD step at DEM step `step_index`: deposits the particles' volume and the impulse they
  // took since the last CFD step, advances the gas over that same interval, hands the implicit
  // drag response back, clears the DEM-cell table and chooses the next interval from the gas's
  // stability limit. Returns a message on failure.
  std::optional<std::string> advance(ParticleStore& p, double dem_step_s, std::int64_t step_index);
  // Solves the gas alone towards config().spin_up_s at its own stable step, before any particle
  // exchange (the developed flow a run starts from): at most `max_steps` gas steps, continuing
  // where the last call stopped. Returns a message when a step fails.
  std::optional<std::string> spin_up(std::uint64_t max_steps = ~std::uint64_t(0));
  bool spin_up_done() const { return stats_.spin_up_done_s >= config_.spin_up_s; }
  // Adds drag, lift and the pressure-gradient force to p.force_n. With `accumulate` the drag
  // and lift impulse (F dt) is kept for the gas; off for a force pass that is not a step's.
  void add_fluid_forces(ParticleStore& p, double dem_step_s, bool accumulate);
  // The same for the listed slots only, over a step `step_s` of their own (multi-rate stepping,
  // sim/multi_rate.h), impulse kept. Per particle the same numbers as the pass over all.
  void add_fluid_forces(ParticleStore& p, const std::vector<std::uint32_t>& slots, double step_s);
  // Every evaluation also keeps the force and its exchanged part in p.fluid_held_force_n and
  // p.fluid_held_exchange_n when the store has those columns; the steps that apply the kept force
  // instead (sim/multi_rate.h) report their impulse here when they book it.
  void add_held_impulse(const Vec3& impulse_n_s);
  // A particle leaves the run (outlet, breakage): its pending impulse still goes to the gas.
  void release(const ParticleStore& p, std::size_t slot);

  // The incompressible solver (only under gas.model "incompressible"), the compressible one (only
  // under "compressible"), and read access to whichever it is.
  const GasSolver& gas() const { return *incompressible_; }
  GasSolver& gas() { return *incompressible_; }
  const CompressibleSolver* compressible() const {
    return compressible_ ? &*compressible_ : nullptr;
  }
  CompressibleSolver* compressible() { return compressible_ ? &*compressible_ : nullptr; }
  GasView view() const {
    return {incompressible_ ? &*incompressible_ : nullptr,
            compressible_ ? &*compressible_ : nullptr};
  }
  const GasGrid& grid() const { return view().grid(); }
  const GasConfig& config() const { return config_; }
  const CouplingStats& stats() const { return stats_; }
  const DemCellFluidTable& table() const { return table_; }
  // The mean fluid state a particle at x reads (tests, output).
  const FluidCellState& fluid_at(const Vec3& x);

  // Checkpoints: the gas, the DEM-cell table, the exchange schedule and the counters.
  template <class A>
  void checkpoint_io(A& a) {
    if (incompressible_) io(a, *incompressible_);
    if (compressible_) io(a, *compressible_);
    io_all(a, table_, next_cfd_step_, released_, last_cfd_step_, last_steps_, stats_,
           max_exchange_rate_per_s_);
  }

 private:
  template <class SlotOf>
  void fluid_pass(ParticleStore& p, std::size_t count, SlotOf&& slot_of, double dt,
                  bool accumulate);
  void deposit(const ParticleStore& p, double interval_s);
  void deposit_compressible(const ParticleStore& p, double interval_s);
  void deposit_solid_volume(const GasGrid& g, const Vec3& wrapped_x, double radius_m);
  void add_solid_volume(const Stencil& s, double radius_m);
  double response_gain(int a, std::size_t f, double read_fraction) const;
  void update_volume_fraction(const GasGrid& g, std::vector<double>& fraction);
  std::optional<std::string> advance_gas(double dt);
  double gas_stable_step_s() const;
  Stencil face_stencil(const Vec3& wrapped_x, int axis) const;
  void return_drag_response(ParticleStore& p);
  int choose_steps(double dem_step_s) const;

  GasConfig config_;
  PeriodicBox box_;
  std::optional<GasSolver> incompressible_;
  std::optional<CompressibleSolver> compressible_;
  DemCellFluidTable table_;
  // Scratch of fluid_pass, per block of particles: its counts and sums (combined in block order,
  // so the same for any thread count), and the particles whose DEM cell it found unfilled.
  struct FluidPassTally {
    std::uint64_t evaluations = 0, past_mach = 0;
    double max_mach = 0.0, max_knudsen = 0.0, max_mach_factor = 1.0;
    Vec3 impulse_n_s;
    std::size_t missed = 0;
  };
  std::vector<FluidPassTally> pass_tally_;
  std::vector<std::uint32_t> pass_missed_;
  std::int64_t next_cfd_step_ = 0;
  std::array<std::vector<double>, 3> drag_fraction_;  // Σ B ε_read per face (scratch of deposit)
  // What deposit() gave each particle slot's drag response, for return_drag_response() to read
  // back (the same faces and numbers, without remaking the stencils): per slot, where its entries
  // begin and how many it has per axis (none when β = 0); per entry, the face and (β w) g on it.
  struct ResponseStencil {
    std::uint32_t begin = 0;
    std::uint8_t count[3] = {0, 0, 0};
  };
  std::vector<ResponseStencil> response_stencil_;
  std::vector<std::uint32_t> response_face_;
  std::vector<double> response_coefficient_;
  struct Released {
    Vec3 position_m, impulse_n_s, velocity_m_per_s;
  };
  std::vector<Released> released_;
  std::vector<double> solid_volume_;       // per padded cell, scratch
  std::vector<Stencil> deposit_stencils_;  // compressible deposit: per particle, two, scratch
  std::vector<double> exchange_per_cell_;  // compressible: Σ β w / V per padded cell, scratch
  std::int64_t last_cfd_step_ = 0;
  int last_steps_ = 0;
  CouplingStats stats_;
  double max_exchange_rate_per_s_ = 0.0;  // compressible: max over cells of B / ρ, last deposit
};

}  // namespace millsim
