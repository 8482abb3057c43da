// GasSolver: volume-averaged incompressible Navier–Stokes on the staggered grid of
// gas/gas_grid.h (unresolved CFD–DEM, "model A": the gas feels −ε∇p and the particles −V_p∇p).
// One step is a Chorin projection:
//   predictor   u* = u + Δt (−u·∇u + ν∇²u + g + S / (ε_f ρ))      explicit, per face
//   pressure    ∇·(ε_f ∇p) = (ρ/Δt) (∇·(ε_f u*) + ∂ε/∂t)         conjugate gradients
//   (gas/pressure_solver.h) correction  u = u* − (Δt/ρ) ∇p
// so the gas satisfies the volume-averaged continuity ∂ε/∂t + ∇·(ε u) = 0 to the solver's
// tolerance. S is the momentum the particles give the gas (gas/coupling.h), ε the gas volume
// fraction. What it leaves out (compressibility, turbulence models, the ε-gradient terms of the
// viscous stress) is listed in docs/gas.md.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "gas/gas_config.h"
#include "gas/gas_grid.h"
#include "gas/pressure_solver.h"

namespace millsim {

struct GasStepStats {
  std::uint64_t steps = 0;
  std::uint64_t pressure_iterations = 0;  // summed over the steps
  int last_pressure_iterations = 0;
  double last_pressure_residual = 0.0;
  double max_pressure_residual = 0.0;
  std::uint64_t matrix_builds = 0;  // the pressure matrix changes only when ε does
};

class GasSolver {
 public:
  GasSolver(const GasConfig& config, GasGrid grid, const Vec3& gravity_m_per_s2);

  const GasGrid& grid() const { return grid_; }
  const GasConfig& config() const { return config_; }
  double density_kg_per_m3() const { return config_.density_kg_per_m3; }
  double viscosity_pa_s() const { return config_.viscosity_pa_s; }

  // Advances the gas by dt. Returns a message when the step fails (non-finite field, pressure
  // solve not converged); the fields are then not to be trusted.
  std::optional<std::string> advance(double dt);

  // The largest stable step for the current state: courant / (Σ max|u_a|/h_a + 2ν Σ 1/h_a²).
  // The particle drag needs no limit: its response to the gas's change is implicit.
  double stable_step_s() const;
  // The largest drag relaxation rate of the gas, max B / (ε ρ) over faces, 1/s.
  double max_exchange_rate_per_s() const;

  // Particle coupling inputs (gas/coupling.h fills them before advance()).
  std::vector<double>& volume_fraction() { return fraction_; }  // ε per padded cell
  const std::vector<double>& volume_fraction() const { return fraction_; }
  std::array<std::vector<double>, 3>& momentum_source() { return source_; }  // N/m³ per face
  // B = Σ β_eff w g / V per face, kg/(m³ s): the implicit part of the drag on the gas, and
  // B u_seen, the same sum times the face velocity it acts from (the coupling passes the face's
  // velocity at the start of the CFD step). The gas gets B (u_seen − u_new) on top of the
  // explicit source: implicit in its own velocity (stable at any step), and exactly what the
  // particles are given back.
  std::array<std::vector<double>, 3>& exchange_coefficient() { return exchange_; }
  std::array<std::vector<double>, 3>& exchange_momentum() { return seen_; }
  // Σ dt (u_new − u_seen) per face where B > 0, summed over the steps since the coupling zeroed it:
  // the particles get the matching impulse β_eff Σ w (this) back (gas/coupling.cpp).
  std::array<std::vector<double>, 3>& drag_response_m() { return drag_response_; }
  // ε per face, as the momentum and continuity equations use it.
  const std::array<std::vector<double>, 3>& face_fractions() const { return face_fraction_; }
  // ε at face f of component a from its cells: the mean of the two; 1 on held faces (an inlet
  // prescribes the superficial velocity); the inner cell's on an outflow face.
  double mean_face_fraction(int axis, std::size_t f) const;
  // Sets the ε of a solved face where particles drag on the gas to the ε their drag was computed
  // at (gas/coupling.cpp), after volume_fraction_changed() set the means.
  void set_face_fraction(int axis, std::size_t f, double fraction) {
    face_fraction_[std::size_t(axis)][f] = fraction;
    matrix_stale_ = true;
  }
  // Call after editing volume_fraction(): refreshes face fractions and marks the matrix stale.
  void volume_fraction_changed();
  // Makes the current ε the previous one too (no ∂ε/∂t at the start of a run).
  void accept_volume_fraction() { previous_fraction_ = fraction_; }

  // Fields.
  const std::array<std::vector<double>, 3>& velocity() const { return velocity_; }
  std::array<std::vector<double>, 3>& velocity() { return velocity_; }
  const std::vector<double>& pressure() const { return pressure_; }
  const std::array<std::vector<double>, 3>& pressure_gradient() const { return gradient_; }

  // Trilinear samples at a point inside the domain (periodic axes wrapped by the caller). The
  // pressure gradient includes the imposed hydrostatic gradient of periodic axes.
  Vec3 velocity_at(const Vec3& x) const;
  Vec3 pressure_gradient_at(const Vec3& x) const;
  double volume_fraction_at(const Vec3& x) const;
  Vec3 vorticity_at(const Vec3& x) const;  // ∇×u by central differences of velocity_at
  // The superficial velocity ε u at x, trilinear over the faces that bound fluid (walls' and
  // inlets' faces included, the faces inside solids and the ghost band left out, their weight
  // given to the others): what the DEM-cell table divides by its own ε (gas/coupling.h). The
  // flux is continuous where ε jumps (a bed's end), and near a wall the tangential flow is read
  // from the first fluid faces instead of falling towards zero inside the solid.
  Vec3 superficial_velocity_at(const Vec3& x) const;

  // The largest divergence residual |∇·(ε u) + ∂ε/∂t| · V over fluid cells after the last
  // step, m³/s (tests).
  double max_continuity_error_m3_per_s() const { return continuity_error_; }
  // Total momentum the gas received from the particles (explicit source + implicit drag), N·s.
  const Vec3& received_impulse_n_s() const { return received_impulse_; }
  const GasStepStats& stats() const { return stats_; }
  // The gas's body force per unit mass (gravity along non-periodic axes).
  const Vec3& body_force_m_per_s2() const { return gravity_m_per_s2_; }
  double time_s() const { return time_s_; }

  // The Smagorinsky eddy viscosity ν_t at each padded cell, m²/s, from the last step's
  // velocity (empty when the constant is 0).
  const std::vector<double>& eddy_viscosity() const { return eddy_viscosity_; }
  // Fills the ghost layers of the velocity (boundary conditions, periodic copies).
  void fill_velocity_ghosts(std::array<std::vector<double>, 3>& u) const;

  // Sets every scheduled inflow (gas_grid.h) to its schedule's value at time t: its faces'
  // velocity and, for a jet, its body force. advance() calls it for the end of each step.
  void apply_inflow_schedules(double t);
  // The speed each scheduled inflow was last set to, m/s (aligned with
  // grid().scheduled_inflows).
  const std::vector<double>& inflow_speeds() const { return inflow_speed_; }
  // The speed jet k blows at now, and the inflow velocity of boundary patch k now (0 unless an
  // inlet): the configured value, or the schedule's last applied one.
  double jet_speed_m_per_s(std::size_t jet) const;
  Vec3 inlet_velocity_m_per_s(std::size_t patch) const;

  // Checkpoints: the fields and the counters. The pressure matrix is not kept: it is assembled
  // again from the face fractions at the next step (one more in stats().matrix_builds).
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, gravity_m_per_s2_, background_gradient_pa_per_m_, eddy_viscosity_, velocity_,
           predicted_, source_, exchange_, gradient_, drag_response_, seen_, relief_,
           face_fraction_, pressure_, fraction_, previous_fraction_, row_of_cell_, cell_of_row_,
           rhs_, solution_, stats_, continuity_error_, received_impulse_, time_s_);
    if constexpr (A::kLoading) {
      matrix_stale_ = true;
      apply_inflow_schedules(time_s_);  // the jets' body forces are not in the checkpoint
    }
  }

 private:
  void predictor(double dt);
  bool tvd_stencil(std::size_t f, int a, int b, std::size_t s) const;
  double limited_upwind_slope(const std::vector<double>& u, std::size_t f, std::size_t s,
                              double carrier) const;
  void update_eddy_viscosity();
  void assemble_pressure_matrix();
  bool solve_pressure(double dt);
  void correct(double dt);
  void fill_copy_ghosts(std::vector<double>& cell_field) const;
  void fill_gradient_ghosts();
  double interpolate(const std::vector<double>& field, const Vec3& x, int face_axis) const;

  GasConfig config_;
  GasGrid grid_;
  Vec3 gravity_m_per_s2_;  // the gas's body force per mass: g, or −(imposed ∇p)/ρ if periodic
  // Along a periodic axis gravity cannot build a hydrostatic pressure: its weight is carried by
  // an imposed mean gradient ρ g instead (the gas does not accelerate, particles feel buoyancy).
  Vec3 background_gradient_pa_per_m_;
  double kinematic_viscosity_ = 0.0;
  // Smagorinsky eddy viscosity per padded cell (empty when off), and its filter width.
  std::vector<double> eddy_viscosity_;
  double filter_width_m_ = 0.0;

  std::array<std::vector<double>, 3> velocity_, predicted_, source_, exchange_, gradient_,
      drag_response_, seen_;
  // 1 / (1 + Δt B / (ε ρ)) per face: how much the implicit drag lets the pressure move the gas
  // (it scales the pressure equation's coefficients and the correction, as in SIMPLE's 1/a_P).
  std::array<std::vector<double>, 3> relief_;
  std::array<std::vector<double>, 3> face_fraction_;
  std::vector<double> pressure_, fraction_, previous_fraction_;

  // Pressure system over the fluid cells.
  std::vector<std::int32_t> row_of_cell_;  // -1 outside the fluid
  std::vector<std::size_t> cell_of_row_;
  std::vector<double> rhs_, solution_;
  PressureSolver pressure_solver_;
  bool matrix_stale_ = true;

  GasStepStats stats_;
  double continuity_error_ = 0.0;
  Vec3 received_impulse_;
  double time_s_ = 0.0;
  std::vector<double> inflow_speed_;  // per scheduled inflow, what its faces hold now
};

}  // namespace millsim
