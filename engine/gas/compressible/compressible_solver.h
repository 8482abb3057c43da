// CompressibleSolver: the compressible Navier–Stokes equations of an ideal gas (mass, momentum,
// total energy) by cell-centred finite volumes on the gas grid of gas/gas_grid.h, for flows
// past Mach 0.3: a spiral jet mill's sonic nozzles and under-expanded jets.
//   flux        Kurganov–Noelle–Petrova central-upwind (SIAM J. Sci. Comput. 23 (2001) 707),
//               the scheme of OpenFOAM's rhoCentralFoam, on face states reconstructed from the
//               primitive variables (ρ, u, p) with van Leer's limiter (MUSCL): second order in
//               smooth flow, non-oscillatory at shocks, and the face states stay within their
//               neighbours' range, so ρ and p stay positive under the CFL limit
//   viscous     Newtonian stress with Stokes' hypothesis, Fourier heat conduction at the
//               configured Prandtl number; central differences at faces
//   time        Heun's method (the two-stage strong-stability-preserving Runge–Kutta scheme)
//   walls       a face between a fluid cell and a solid cell or a wall is a mirror: no mass or
//               energy crosses it exactly (inviscid part); the viscous part sees the no-slip
//               (or slip) condition, walls are adiabatic
//   inlets      a set velocity at the configured temperature, or a reservoir at a stagnation
//               pressure and temperature (isentropic, up to Mach 1 at the inlet face)
//   outlets     the set static pressure while the outflow is subsonic, extrapolated otherwise
//   jets        a nozzle in a solid wall (GasJetConfig) puts its mass flow, momentum and
//               stagnation enthalpy into the fluid cells behind its faces: a pressure-set nozzle
//               as the notional nozzle of gas/compressible/notional_nozzle.h expanded to the
//               pressure of those cells, a speed-set one at that speed and pressure
//   particles   a momentum source per cell and the power of the drag on the particles as an
//               energy source (gas/coupling.h); the gas volume fraction is kept for the drag
//               laws but is not in these equations (dilute flow: docs/gas.md)
//   dust        the dust ledger's mass per volume c (dust/dust_ledger.h) as mass the gas must
//               accelerate: the dust follows the gas (its slip is small), so with every force on
//               the gas but convection and gravity f (pressure, viscous stress, jets, particles),
//               gas and dust share it, (ρ + c)(a − g) = f, and the dust's reaction on the gas is
//               F = −c (a − g) = −c f / (ρ + c), solved within each stage (no added-mass lag);
//               its power F·u is taken from the gas's energy. Sound then runs at c_s/√(1 + c/ρ)
//               and a dusty column stands at dp/dz = −(ρ + c) g (Marble, Annu. Rev. Fluid Mech. 2
//               (1970) 397, the equilibrium limit)
// A step that leaves a cell with non-positive or non-finite density or pressure fails with a
// message naming the cell, its position and the time. The state is stored as structure of
// arrays over the padded grid (one ghost layer).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/vec3.h"
#include "gas/compressible/ideal_gas.h"
#include "gas/compressible/notional_nozzle.h"
#include "gas/gas_config.h"
#include "gas/gas_grid.h"

namespace millsim {

class CompressibleSolver {
 public:
  // The state starts uniform at the config's initial pressure, temperature and velocity.
  CompressibleSolver(const GasConfig& config, GasGrid grid, const Vec3& gravity_m_per_s2);

  const GasGrid& grid() const { return grid_; }
  const IdealGas& gas() const { return gas_; }
  double viscosity_pa_s() const { return viscosity_pa_s_; }

  // Sets one fluid cell's state from its primitive variables.
  void set_state(std::size_t cell, double density_kg_per_m3, const Vec3& velocity_m_per_s,
                 double pressure_pa);

  // Advances by dt. Returns a message when a cell's density or pressure stops being positive and
  // finite; the state is then not to be trusted.
  std::optional<std::string> advance(double dt);

  // The largest stable step: courant / max over fluid cells of
  // Σ_a (|u_a| + c) / h_a + 2 max(4/3, γ/Pr) (μ/ρ) Σ_a 1/h_a².
  double stable_step_s(double courant) const;

  // Particle coupling inputs (gas/coupling.h fills them before advance()): the gas volume fraction
  // ε per padded cell (for the drag laws and output only), the momentum the particles give the
  // gas, N/m³ per cell, and the power they give it, W/m³.
  std::vector<double>& volume_fraction() { return fraction_; }
  const std::vector<double>& volume_fraction() const { return fraction_; }
  std::array<std::vector<double>, 3>& momentum_source() { return source_; }
  std::vector<double>& energy_source() { return energy_source_; }
  // Total momentum the gas received from the particles, N·s.
  const Vec3& received_impulse_n_s() const { return received_impulse_; }
  // The dust's mass per unit volume, kg/m³ per padded cell (the dust ledger's, filled before
  // advance()); empty: no dust in these equations.
  std::vector<double>& dust_density() { return dust_density_; }
  const std::vector<double>& dust_density() const { return dust_density_; }
  // Total momentum the gas gave the dust it carries, N·s, and the power it gave it, J.
  const Vec3& dust_impulse_n_s() const { return dust_impulse_; }
  double dust_work_j() const { return dust_work_j_; }

  // Trilinear samples over the fluid cells around a point inside the domain (periodic axes
  // wrapped by the caller); the pressure gradient is the cells' central difference (one-sided
  // next to a wall), interpolated the same way.
  Vec3 velocity_at(const Vec3& x) const;
  double density_at(const Vec3& x) const;
  double pressure_at(const Vec3& x) const;
  Vec3 pressure_gradient_at(const Vec3& x) const;
  double volume_fraction_at(const Vec3& x) const;
  Vec3 vorticity_at(const Vec3& x) const;  // ∇×u by central differences of velocity_at

  // Each jet of the config as the last step's second stage left it: what it delivered and the
  // notional jet it entered as (speed-set jets: their speed, at the pressure they met).
  const std::vector<NozzleExit>& jets() const { return jet_exit_; }
  // The mass that entered through each jet during the last step, per second.
  const std::vector<double>& jet_inflow_kg_per_s() const { return jet_inflow_; }

  // Per padded cell (meaningful in fluid cells).
  double density_kg_per_m3(std::size_t c) const { return density_[c]; }
  Vec3 velocity_m_per_s(std::size_t c) const;
  double pressure_pa(std::size_t c) const;
  double temperature_k(std::size_t c) const;
  double mach(std::size_t c) const;

  // Totals over the fluid cells.
  double total_mass_kg() const;
  double total_energy_j() const;
  Vec3 total_momentum_n_s() const;
  // The mass that entered through each boundary patch of the config during the last step, per
  // second (negative: it left), as the step's two stages together moved it.
  const std::vector<double>& patch_inflow_kg_per_s() const { return patch_inflow_; }
  double time_s() const { return time_s_; }
  std::uint64_t steps() const { return steps_; }

  // Checkpoints: the conserved state, the coupling fields and the counters (the primitive
  // variables, gradients and jets' states follow from them at the next step; the dust density is
  // laid again before it).
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, density_, momentum_, energy_, fraction_, source_, energy_source_, received_impulse_,
           jet_exit_, jet_inflow_, patch_inflow_, time_s_, steps_, dust_impulse_, dust_work_j_);
    if constexpr (A::kLoading) update_pressure_gradient();
  }

  // The first fluid cell (in cell order) whose density or pressure is not positive and finite,
  // as the message that stops the run; advance() asks it after each step.
  std::optional<std::string> check_state() const;

 private:
  // Conserved variables: density, momentum (3), total energy per volume.
  static constexpr int kVariables = 5;
  using State = std::array<std::vector<double>, kVariables>;

  // Whether the grid's passes run on the engine's threads (parallel/thread_team.h).
  bool on_team() const;
  void compute_primitives();
  void fill_ghosts();
  // The velocity the viscous stress sees at padded cell n, a neighbour of fluid cell c along
  // axis a: n's own, or c's mirrored across a wall (no-slip, moving wall, or slip).
  Vec3 neighbour_velocity(std::size_t c, std::size_t n, int a) const;
  void compute_velocity_gradients();
  // Each fluid cell's limited slope of every primitive along axis a (MUSCL, van Leer), into
  // slope_: a face's two states are its cells' values ∓ half their slopes.
  void compute_slopes(int a);
  // The stage's residual; with dust, returns the sums add_dust_reaction gives (else zeros).
  std::pair<Vec3, double> compute_residual(double stage_weight);
  void add_jet_sources(double stage_weight);
  // The dust's reaction on the gas (above), added to the stage's residual; returns its sums over
  // the fluid cells, in cell order: force (N/m³ summed) and power (W/m³ summed).
  std::pair<Vec3, double> add_dust_reaction();
  bool dusty() const { return dust_density_.size() == grid_.padded_size; }
  void update_pressure_gradient();
  template <class Field>
  auto sample(const Field& value_of, const Vec3& x) const;

  GasGrid grid_;
  IdealGas gas_;
  double viscosity_pa_s_ = 0.0;
  Vec3 gravity_m_per_s2_;
  std::vector<GasBoundaryPatch> patches_;

  // Per padded cell: what a neighbour there is to the reconstruction (see CellRole).
  std::vector<std::uint8_t> role_;

  std::vector<double> density_;                  // ρ
  std::array<std::vector<double>, 3> momentum_;  // ρu
  std::vector<double> energy_;                   // ρE
  State start_, residual_;
  // Primitive variables per padded cell, ghosts included: ρ, u, v, w, p.
  std::array<std::vector<double>, kVariables> primitive_;
  // ∂u_b/∂x_d per fluid cell, index 3b + d (viscous flows only).
  std::array<std::vector<double>, 9> velocity_gradient_;
  // The limited slope per primitive and fluid cell along the axis whose faces are being summed.
  std::array<std::vector<double>, kVariables> slope_;

  std::vector<double> patch_inflow_;
  std::vector<std::vector<std::pair<int, double>>>
      slab_inflow_;  // per slab: (patch, kg/s) in order
  std::vector<GasJetConfig> jet_config_;
  std::vector<NozzleExit> jet_exit_;
  std::vector<double> jet_inflow_;

  std::vector<double> fraction_, energy_source_;
  std::array<std::vector<double>, 3> source_, gradient_;
  Vec3 received_impulse_;
  std::vector<double> dust_density_;
  std::vector<Vec3> dust_force_;  // per padded cell, this stage's F (N/m³)
  Vec3 dust_impulse_;
  double dust_work_j_ = 0.0;
  double time_s_ = 0.0;
  std::uint64_t steps_ = 0;
};

}  // namespace millsim
