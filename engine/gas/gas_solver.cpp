#include "gas/gas_solver.h"

#include <algorithm>
#include <cmath>

#include "core/errors.h"
#include "gas/gas_stencil.h"

namespace millsim {

GasSolver::GasSolver(const GasConfig& config, GasGrid grid, const Vec3& gravity_m_per_s2)
    : config_(config),
      grid_(std::move(grid)),
      gravity_m_per_s2_(gravity_m_per_s2),
      pressure_solver_(config.pressure_tolerance, config.max_pressure_iterations,
                       config.pressure_preconditioner) {
  kinematic_viscosity_ = config_.viscosity_pa_s / config_.density_kg_per_m3;
  if (config_.smagorinsky_constant > 0.0) {
    // Δ: the geometric mean cell edge over the axes that resolve anything.
    double product = 1.0;
    int axes = 0;
    for (int a = 0; a < 3; ++a)
      if (!(grid_.periodic[std::size_t(a)] && grid_.n[std::size_t(a)] == 1))
        product *= grid_.h_m[a], ++axes;
    filter_width_m_ = axes > 0 ? std::pow(product, 1.0 / axes) : grid_.h_m.x;
    eddy_viscosity_.assign(grid_.padded_size, 0.0);
  }
  for (int a = 0; a < 3; ++a)
    if (grid_.periodic[std::size_t(a)]) {
      const double imposed = config_.mean_pressure_gradient_pa_per_m[a];
      background_gradient_pa_per_m_[a] = config_.density_kg_per_m3 * gravity_m_per_s2_[a] + imposed;
      gravity_m_per_s2_[a] = -imposed / config_.density_kg_per_m3;  // the net body force
    }
  const std::size_t n = grid_.padded_size;
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    velocity_[au].assign(n, 0.0);
    predicted_[au].assign(n, 0.0);
    source_[au].assign(n, 0.0);
    exchange_[au].assign(n, 0.0);
    drag_response_[au].assign(n, 0.0);
    seen_[au].assign(n, 0.0);
    relief_[au].assign(n, 1.0);
    gradient_[au].assign(n, 0.0);
    face_fraction_[au].assign(n, 1.0);
    for (std::size_t f = 0; f < n; ++f) {
      const FaceKind kind = grid_.face[au][f];
      if (kind == FaceKind::Unknown || kind == FaceKind::Outflow || kind == FaceKind::Periodic)
        velocity_[au][f] = config_.initial_velocity_m_per_s[a];
      else if (kind == FaceKind::Fixed)
        velocity_[au][f] = grid_.fixed_value[au][f];
    }
  }
  pressure_.assign(n, 0.0);
  fraction_.assign(n, 1.0);
  previous_fraction_.assign(n, 1.0);
  row_of_cell_.assign(n, -1);
  for (std::size_t c = 0; c < n; ++c)
    if (grid_.fluid[c]) {
      row_of_cell_[c] = std::int32_t(cell_of_row_.size());
      cell_of_row_.push_back(c);
    }
  rhs_.assign(cell_of_row_.size(), 0.0);
  solution_ = rhs_;
  // The spin-up runs before the particles' time 0, so a schedule reads the run's own clock.
  time_s_ = -config_.spin_up_s;
  inflow_speed_.assign(grid_.scheduled_inflows.size(), 0.0);
  apply_inflow_schedules(time_s_);
  fill_velocity_ghosts(velocity_);
  volume_fraction_changed();
}

double GasSolver::mean_face_fraction(int a, std::size_t f) const {
  const std::size_t au = std::size_t(a);
  switch (grid_.face[au][f]) {
    case FaceKind::Unknown:
      return 0.5 * (fraction_[grid_.wrap_cell(f, a)] +
                    fraction_[grid_.wrap_cell(f + grid_.stride[au], a)]);
    case FaceKind::Outflow:
      return grid_.coords(f)[au] == 0 ? fraction_[f + grid_.stride[au]] : fraction_[f];
    default:
      return 1.0;
  }
}

void GasSolver::volume_fraction_changed() {
  for (std::size_t c = 0; c < grid_.padded_size; ++c)
    if (!grid_.fluid[c]) fraction_[c] = 1.0;
  fill_copy_ghosts(fraction_);
  for (int a = 0; a < 3; ++a)
    for (std::size_t f = 0; f < grid_.padded_size; ++f)
      face_fraction_[std::size_t(a)][f] = mean_face_fraction(a, f);
  matrix_stale_ = true;
}

// Ghost cells of a cell-centred field: periodic copies, else the inner cell's value.
void GasSolver::fill_copy_ghosts(std::vector<double>& v) const {
  for (int a = 0; a < 3; ++a)
    grid_.for_each_ghost(a,
                         [&](std::size_t ghost, std::size_t inner, bool) { v[ghost] = v[inner]; });
}

void GasSolver::fill_velocity_ghosts(std::array<std::vector<double>, 3>& u) const {
  const GasGrid& g = grid_;
  for (int a = 0; a < 3; ++a) {
    const bool periodic = g.periodic[std::size_t(a)];
    g.for_each_ghost(a, [&](std::size_t ghost, std::size_t inner, bool high) {
      if (periodic) {
        for (int b = 0; b < 3; ++b) u[std::size_t(b)][ghost] = u[std::size_t(b)][inner];
        return;
      }
      const GhostBoundary& bc = g.ghost[ghost];
      for (int b = 0; b < 3; ++b) {
        std::vector<double>& ub = u[std::size_t(b)];
        if (b == a) {
          if (high) ub[ghost] = ub[inner];  // beyond the high boundary face
          continue;
        }
        switch (bc.kind) {
          case GasBoundaryKind::Wall:
          case GasBoundaryKind::Inlet:
            ub[ghost] = 2.0 * bc.velocity_m_per_s[b] - ub[inner];
            break;
          case GasBoundaryKind::Slip:
          case GasBoundaryKind::Outlet:
            ub[ghost] = ub[inner];
            break;
        }
      }
    });
  }
}

double GasSolver::stable_step_s() const {
  const GasGrid& g = grid_;
  double rate = 0.0, nu = kinematic_viscosity_;
  for (double nu_t : eddy_viscosity_) nu = std::max(nu, kinematic_viscosity_ + nu_t);
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    double umax = 0.0;
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      const FaceKind kind = g.face[au][f];
      if (kind != FaceKind::None && kind != FaceKind::Solid)
        umax = std::max(umax, std::abs(velocity_[au][f]));
    }
    rate += umax / g.h_m[a];
    if (!(g.periodic[au] && g.n[au] == 1)) rate += 2.0 * nu / (g.h_m[a] * g.h_m[a]);
  }
  return rate > 0.0 ? config_.courant / rate : 1e300;
}

double GasSolver::max_exchange_rate_per_s() const {
  double rate = 0.0;
  for (int a = 0; a < 3; ++a)
    for (std::size_t f = 0; f < grid_.padded_size; ++f)
      if (exchange_[std::size_t(a)][f] > 0.0)
        rate = std::max(rate, exchange_[std::size_t(a)][f] /
                                  (face_fraction_[std::size_t(a)][f] * config_.density_kg_per_m3));
  return rate;
}

// ν_t = (C_s Δ)² |S|, |S| = √(2 S_ij S_ij), at the cell centres: the normal rates from the
// cell's own faces, the shear rates from the neighbours' centred velocities (ghosts hold the
// walls' mirror values and the periodic copies).
void GasSolver::update_eddy_viscosity() {
  const GasGrid& g = grid_;
  const double scale = std::pow(config_.smagorinsky_constant * filter_width_m_, 2);
  const auto centred = [&](int a, std::size_t c) {
    return 0.5 *
           (velocity_[std::size_t(a)][c] + velocity_[std::size_t(a)][c - g.stride[std::size_t(a)]]);
  };
  for (int k = 1; k <= g.n[2]; ++k)
    for (int j = 1; j <= g.n[1]; ++j)
      for (int i = 1; i <= g.n[0]; ++i) {
        const std::size_t c = g.index(i, j, k);
        if (!g.fluid[c]) {
          eddy_viscosity_[c] = 0.0;
          continue;
        }
        double grad[3][3];  // grad[a][b] = ∂u_a/∂x_b
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const std::size_t sb = g.stride[std::size_t(b)];
            grad[a][b] =
                a == b
                    ? (velocity_[std::size_t(a)][c] - velocity_[std::size_t(a)][c - sb]) / g.h_m[b]
                    : (centred(a, c + sb) - centred(a, c - sb)) / (2.0 * g.h_m[b]);
          }
        double s2 = 0.0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const double sab = 0.5 * (grad[a][b] + grad[b][a]);
            s2 += sab * sab;
          }
        eddy_viscosity_[c] = scale * std::sqrt(2.0 * s2);
      }
  fill_copy_ghosts(eddy_viscosity_);
}

namespace {

// Van Leer's limited slope from the two one-sided differences (harmonic mean, 0 at extrema).
inline double van_leer(double a, double b) {
  return a * b > 0.0 ? 2.0 * a * b / (a + b) : 0.0;
}

}  // namespace

// True when the a-faces f ± s, f ± 2s along b exist and are ordinary faces (no solid mirror, no
// ghost band): the TVD reconstruction's stencil.
bool GasSolver::tvd_stencil(std::size_t f, int a, int b, std::size_t s) const {
  const int i = grid_.coords(f)[std::size_t(b)];
  if (i < 2 || i + 2 > grid_.n[std::size_t(b)] + 1) return false;
  const std::vector<FaceKind>& kind = grid_.face[std::size_t(a)];
  for (std::size_t g : {f - 2 * s, f - s, f + s, f + 2 * s})
    if (kind[g] == FaceKind::Solid || kind[g] == FaceKind::None) return false;
  return true;
}

// (u_{+½} − u_{−½}) along b, with the face values reconstructed from the upwind side with van
// Leer's limiter (MUSCL); divided by h it is the advected gradient.
double GasSolver::limited_upwind_slope(const std::vector<double>& u, std::size_t f, std::size_t s,
                                       double carrier) const {
  const double um2 = u[f - 2 * s], um1 = u[f - s], u0 = u[f], up1 = u[f + s], up2 = u[f + 2 * s];
  if (carrier > 0.0) {
    const double plus = u0 + 0.5 * van_leer(u0 - um1, up1 - u0);
    const double minus = um1 + 0.5 * van_leer(um1 - um2, u0 - um1);
    return plus - minus;
  }
  const double minus = u0 - 0.5 * van_leer(up1 - u0, u0 - um1);
  const double plus = up1 - 0.5 * van_leer(up2 - up1, up1 - u0);
  return plus - minus;
}

void GasSolver::predictor(double dt) {
  const GasGrid& g = grid_;
  const double rho = config_.density_kg_per_m3;
  const bool eddy = !eddy_viscosity_.empty();
  if (eddy) update_eddy_viscosity();
  const AdvectionScheme scheme = config_.advection;
  const bool jets = !g.jet_force_n_per_m3[0].empty();
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    const std::vector<double>& u = velocity_[au];
    const std::vector<FaceKind>& kind = g.face[au];
    std::vector<double>& out = predicted_[au];
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      if (kind[f] != FaceKind::Unknown) {
        out[f] = u[f];
        continue;
      }
      const double uf = u[f];
      const double nu =
          kinematic_viscosity_ + (eddy ? 0.5 * (eddy_viscosity_[g.wrap_cell(f, a)] +
                                                eddy_viscosity_[g.wrap_cell(f + g.stride[au], a)])
                                       : 0.0);
      double advection = 0.0, diffusion = 0.0;
      for (int b = 0; b < 3; ++b) {
        const std::size_t bu = std::size_t(b), s = g.stride[bu];
        const double h = g.h_m[b];
        // A neighbour inside a solid mirrors this face (no slip half-way between).
        const double up = kind[f + s] == FaceKind::Solid ? -uf : u[f + s];
        const double down = kind[f - s] == FaceKind::Solid ? -uf : u[f - s];
        diffusion += (up - 2.0 * uf + down) / (h * h);
        double carrier;  // the b-velocity at this a-face
        if (b == a) {
          carrier = uf;
        } else {
          const std::size_t sa = g.stride[au];
          const std::vector<double>& ub = velocity_[bu];
          carrier = 0.25 * (ub[f] + ub[f + sa] + ub[f - s] + ub[f + sa - s]);
        }
        const bool upwind =
            scheme == AdvectionScheme::Upwind ||
            (scheme != AdvectionScheme::Central && std::abs(carrier) * h > 2.0 * nu);
        double slope;
        if (upwind && scheme == AdvectionScheme::Tvd && tvd_stencil(f, a, b, s))
          slope = limited_upwind_slope(u, f, s, carrier) / h;
        else if (upwind)
          slope = carrier > 0.0 ? (uf - down) / h : (up - uf) / h;
        else
          slope = (up - down) / (2.0 * h);
        advection += carrier * slope;
      }
      // The particles' drag on the gas: the impulse they took (explicit source S) plus the
      // implicit response B (ū − u*) to the gas's own change, which keeps dense beds stable at
      // CFD steps beyond ε ρ / B (gas/coupling.h hands the same response back to the particles).
      const double inertia = face_fraction_[au][f] * rho;
      const double b = exchange_[au][f];
      const double relief = 1.0 / (1.0 + dt * b / inertia);
      const double jet = jets ? g.jet_force_n_per_m3[au][f] : 0.0;
      const double body = gravity_m_per_s2_[a] + (source_[au][f] + seen_[au][f] + jet) / inertia;
      out[f] = (uf + dt * (-advection + nu * diffusion + body)) * relief;
      if (relief != relief_[au][f]) relief_[au][f] = relief, matrix_stale_ = true;
    }
    // Outflow faces: zero gradient from the inner face.
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      if (kind[f] != FaceKind::Outflow) continue;
      const std::size_t inner = g.coords(f)[au] == 0 ? f + g.stride[au] : f - g.stride[au];
      out[f] = kind[inner] == FaceKind::Unknown ? out[inner] : u[f];
    }
  }
}

void GasSolver::assemble_pressure_matrix() {
  const GasGrid& g = grid_;
  std::vector<MatrixEntry> triplets;
  triplets.reserve(cell_of_row_.size() * 7);
  for (std::size_t row = 0; row < cell_of_row_.size(); ++row) {
    const std::size_t c = cell_of_row_[row];
    double diagonal = 0.0;
    for (int a = 0; a < 3; ++a) {
      const std::size_t au = std::size_t(a), s = g.stride[au];
      const double w = g.face_area_m2(a) / g.h_m[a];
      for (int side = 0; side < 2; ++side) {
        const std::size_t f = g.canonical_face(side == 0 ? c - s : c, a);
        const FaceKind kind = g.face[au][f];
        if (kind == FaceKind::Outflow) {
          diagonal += 2.0 * w * face_fraction_[au][f] * relief_[au][f];
        } else if (kind == FaceKind::Unknown) {
          const std::size_t nb = g.wrap_cell(side == 0 ? c - s : c + s, a);
          const double wf = w * face_fraction_[au][f] * relief_[au][f];
          diagonal += wf;
          if (nb != c)
            triplets.push_back({std::int32_t(row), row_of_cell_[nb], -wf});
          else
            diagonal -= wf;  // a one-cell periodic axis: the face couples the cell to itself
        }
      }
    }
    // Without an outflow the pressure is fixed up to a constant: pin the first cell's level
    // (the right-hand side is made compatible, so this changes nothing else).
    if (row == 0 && !g.has_outflow) diagonal *= 2.0;
    triplets.push_back({std::int32_t(row), std::int32_t(row), diagonal});
  }
  std::vector<std::array<int, 3>> cells(cell_of_row_.size());
  for (std::size_t row = 0; row < cell_of_row_.size(); ++row)
    cells[row] = g.coords(cell_of_row_[row]);
  pressure_solver_.set_matrix(std::int32_t(cell_of_row_.size()), triplets, cells);
  matrix_stale_ = false;
  ++stats_.matrix_builds;
}

bool GasSolver::solve_pressure(double dt) {
  const GasGrid& g = grid_;
  const double rho = config_.density_kg_per_m3, volume = g.cell_volume_m3();
  double mean = 0.0;
  for (std::size_t row = 0; row < cell_of_row_.size(); ++row) {
    const std::size_t c = cell_of_row_[row];
    double divergence = volume * (fraction_[c] - previous_fraction_[c]) / dt;
    double boundary = 0.0;
    for (int a = 0; a < 3; ++a) {
      const std::size_t au = std::size_t(a), s = g.stride[au];
      const std::size_t up = c, down = g.canonical_face(c - s, a);
      const double area = g.face_area_m2(a);
      divergence += area * (face_fraction_[au][up] * predicted_[au][up] -
                            face_fraction_[au][down] * predicted_[au][down]);
      for (std::size_t f : {up, down})
        if (g.face[au][f] == FaceKind::Outflow)
          boundary += 2.0 * area / g.h_m[a] * face_fraction_[au][f] * relief_[au][f] *
                      g.ghost[f == up ? c + s : f].pressure_pa;
    }
    rhs_[row] = -rho / dt * divergence + boundary;
    mean += rhs_[row];
  }
  if (!g.has_outflow)
    for (double& b : rhs_) b -= mean / double(cell_of_row_.size());
  if (matrix_stale_) assemble_pressure_matrix();
  for (std::size_t row = 0; row < cell_of_row_.size(); ++row)
    solution_[row] = pressure_[cell_of_row_[row]];
  const bool converged = pressure_solver_.solve(rhs_, solution_);
  const double residual = pressure_solver_.residual();
  stats_.last_pressure_iterations = pressure_solver_.iterations();
  stats_.last_pressure_residual = residual;
  stats_.pressure_iterations += std::uint64_t(pressure_solver_.iterations());
  stats_.max_pressure_residual = std::max(stats_.max_pressure_residual, residual);
  for (std::size_t row = 0; row < cell_of_row_.size(); ++row)
    pressure_[cell_of_row_[row]] = solution_[row];
  fill_copy_ghosts(pressure_);
  return converged || residual < 100.0 * config_.pressure_tolerance;
}

void GasSolver::correct(double dt) {
  const GasGrid& g = grid_;
  const double rho = config_.density_kg_per_m3;
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a), s = g.stride[au];
    const double h = g.h_m[a];
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      const FaceKind kind = g.face[au][f];
      double grad = 0.0;
      if (kind == FaceKind::Unknown) {
        grad = (pressure_[g.wrap_cell(f + s, a)] - pressure_[g.wrap_cell(f, a)]) / h;
      } else if (kind == FaceKind::Outflow) {
        const bool low = g.coords(f)[au] == 0;
        const double outside = g.ghost[low ? f : f + s].pressure_pa;
        grad =
            low ? (pressure_[f + s] - outside) / (0.5 * h) : (outside - pressure_[f]) / (0.5 * h);
      } else {
        velocity_[au][f] = kind == FaceKind::Periodic ? velocity_[au][f] : predicted_[au][f];
        continue;
      }
      gradient_[au][f] = grad;
      velocity_[au][f] = predicted_[au][f] - relief_[au][f] * dt / rho * grad;
      const double b = exchange_[au][f];
      if (b > 0.0) {  // the implicit drag acted on the whole change, pressure included
        const double seen = seen_[au][f] / b;  // the velocity the particles here were dragged by
        received_impulse_[a] += b * g.cell_volume_m3() * dt * (seen - velocity_[au][f]);
        drag_response_[au][f] += dt * (velocity_[au][f] - seen);
      }
    }
  }
  fill_velocity_ghosts(velocity_);
  fill_gradient_ghosts();
}

// Pressure gradient on faces that are not solved for: the nearest solved face along the axis
// (a wall sees the gradient of the gas next to it), periodic copies and ghost copies.
void GasSolver::fill_gradient_ghosts() {
  const GasGrid& g = grid_;
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a), s = g.stride[au];
    std::vector<double>& grad = gradient_[au];
    const std::vector<FaceKind>& kind = g.face[au];
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      if (kind[f] != FaceKind::Fixed && kind[f] != FaceKind::Solid) continue;
      const bool low_fluid = g.fluid[g.wrap_cell(f, a)] != 0;
      const std::size_t nb = low_fluid ? f - s : f + s;
      grad[f] = kind[nb] == FaceKind::Unknown || kind[nb] == FaceKind::Outflow ? grad[nb] : 0.0;
    }
    for (std::size_t f = 0; f < g.padded_size; ++f)
      if (kind[f] == FaceKind::Periodic) grad[f] = grad[g.canonical_face(f, a)];
  }
  // Ghost layers: copies of the inner value (the boundary face itself is kept).
  for (int a = 0; a < 3; ++a)
    g.for_each_ghost(a, [&](std::size_t ghost, std::size_t inner, bool high) {
      for (int b = 0; b < 3; ++b)
        if (b != a || high) gradient_[std::size_t(b)][ghost] = gradient_[std::size_t(b)][inner];
    });
}

void GasSolver::apply_inflow_schedules(double t) {
  for (std::size_t k = 0; k < grid_.scheduled_inflows.size(); ++k) {
    const ScheduledInflow& in = grid_.scheduled_inflows[k];
    double speed = in.schedule.table.at(t);
    if (in.schedule.mass_flow)
      speed = in.area_m2 > 0.0 ? speed / (config_.density_kg_per_m3 * in.area_m2) : 0.0;
    const double before = inflow_speed_[k];
    if (speed == before) continue;
    for (const ScaledFaceValue& v : in.velocity) {
      const std::size_t au = std::size_t(v.axis);
      grid_.fixed_value[au][v.face] = v.per_unit * speed;
      velocity_[au][v.face] = v.per_unit * speed;
    }
    // The jet's momentum deficit grows with the square of its speed.
    const double squared = speed * std::abs(speed), squared_before = before * std::abs(before);
    for (const ScaledFaceValue& v : in.force)
      grid_.jet_force_n_per_m3[std::size_t(v.axis)][v.face] +=
          v.per_unit * (squared - squared_before);
    if (in.jet >= 0) {
      grid_.jet_flow_m3_per_s[std::size_t(in.jet)] = in.area_m2 * speed;
      grid_.jet_momentum_deficit_n[std::size_t(in.jet)] = in.momentum_deficit_per_unit * squared;
    }
    inflow_speed_[k] = speed;
  }
}

double GasSolver::jet_speed_m_per_s(std::size_t jet) const {
  for (std::size_t k = 0; k < inflow_speed_.size(); ++k)
    if (grid_.scheduled_inflows[k].jet == int(jet)) return inflow_speed_[k];
  return config_.jets[jet].speed_m_per_s;
}

Vec3 GasSolver::inlet_velocity_m_per_s(std::size_t patch) const {
  const GasBoundaryPatch& p = config_.boundaries[patch];
  if (p.kind != GasBoundaryKind::Inlet) return {};
  for (std::size_t k = 0; k < inflow_speed_.size(); ++k)
    if (grid_.scheduled_inflows[k].patch == int(patch)) {
      Vec3 v;
      v[p.face / 2] = p.face % 2 == 0 ? inflow_speed_[k] : -inflow_speed_[k];
      return v;
    }
  return p.velocity_m_per_s;
}

std::optional<std::string> GasSolver::advance(double dt) {
  const GasGrid& g = grid_;
  // The inflow the projection holds at the end of the step.
  if (!inflow_speed_.empty()) apply_inflow_schedules(time_s_ + dt);
  predictor(dt);
  if (!solve_pressure(dt))
    return concat("the gas pressure solve did not converge in ", pressure_solver_.iterations(),
                  " iterations (relative residual ", pressure_solver_.residual(), ", tolerance ",
                  config_.pressure_tolerance,
                  "); raise /gas/max_pressure_iterations or check the boundaries for a closed "
                  "region without an outlet");
  correct(dt);
  // Impulse given by the particle source, and the continuity check.
  const double volume = g.cell_volume_m3();
  for (int a = 0; a < 3; ++a)
    for (std::size_t f = 0; f < g.padded_size; ++f)
      if (source_[std::size_t(a)][f] != 0.0)
        received_impulse_[a] += source_[std::size_t(a)][f] * volume * dt;
  continuity_error_ = 0.0;
  for (std::size_t c : cell_of_row_) {
    double div = volume * (fraction_[c] - previous_fraction_[c]) / dt;
    for (int a = 0; a < 3; ++a) {
      const std::size_t au = std::size_t(a);
      const std::size_t down = g.canonical_face(c - g.stride[au], a);
      div += g.face_area_m2(a) * (face_fraction_[au][c] * velocity_[au][c] -
                                  face_fraction_[au][down] * velocity_[au][down]);
    }
    if (!std::isfinite(div))
      return concat("the gas velocity became non-finite in cell ", g.coords(c)[0], ",",
                    g.coords(c)[1], ",", g.coords(c)[2], " at t = ", time_s_,
                    " s; lower /gas/courant or set a smaller /gas/step_s");
    continuity_error_ = std::max(continuity_error_, std::abs(div));
  }
  previous_fraction_ = fraction_;
  time_s_ += dt;
  ++stats_.steps;
  return std::nullopt;
}

// Trilinear interpolation of a staggered field: `face_axis` is the component's axis (its nodes
// sit on faces along it, at cell centres along the others), or −1 for a cell-centred field.
double GasSolver::interpolate(const std::vector<double>& field, const Vec3& x,
                              int face_axis) const {
  const GasGrid& g = grid_;
  const GridCorner corner = lower_corner(g, x, face_axis);
  const std::array<int, 3>& i0 = corner.index;
  const std::array<double, 3>& w = corner.weight;
  double sum = 0.0;
  for (int dk = 0; dk < 2; ++dk)
    for (int dj = 0; dj < 2; ++dj)
      for (int di = 0; di < 2; ++di) {
        const double weight =
            (di ? w[0] : 1.0 - w[0]) * (dj ? w[1] : 1.0 - w[1]) * (dk ? w[2] : 1.0 - w[2]);
        sum += weight * field[g.index(i0[0] + di, i0[1] + dj, i0[2] + dk)];
      }
  return sum;
}

Vec3 GasSolver::velocity_at(const Vec3& x) const {
  return {interpolate(velocity_[0], x, 0), interpolate(velocity_[1], x, 1),
          interpolate(velocity_[2], x, 2)};
}

Vec3 GasSolver::superficial_velocity_at(const Vec3& x) const {
  Vec3 u;
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    const std::vector<FaceKind>& kind = grid_.face[au];
    const Stencil s = make_stencil(grid_, x, a, [&](std::size_t f) {
      return kind[f] != FaceKind::Solid && kind[f] != FaceKind::None;
    });
    for (int k = 0; k < s.count; ++k)
      u[a] += s.weight[k] * face_fraction_[au][s.node[k]] * velocity_[au][s.node[k]];
  }
  return u;
}

Vec3 GasSolver::pressure_gradient_at(const Vec3& x) const {
  return Vec3{interpolate(gradient_[0], x, 0), interpolate(gradient_[1], x, 1),
              interpolate(gradient_[2], x, 2)} +
         background_gradient_pa_per_m_;
}

double GasSolver::volume_fraction_at(const Vec3& x) const {
  return interpolate(fraction_, x, -1);
}

Vec3 GasSolver::vorticity_at(const Vec3& x) const {
  return vorticity_by_central_differences(grid_, x,
                                          [this](const Vec3& y) { return velocity_at(y); });
}

}  // namespace millsim
