#include "gas/compressible/compressible_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "gas/gas_stencil.h"
#include "parallel/thread_team.h"

namespace millsim {
namespace {

// What a padded cell is to the fluid cell next to it.
enum CellRole : std::uint8_t {
  kFluid,     // an interior fluid cell
  kSolid,     // an interior solid cell: a no-slip wall at rest
  kWall,      // a ghost of a no-slip domain wall (it may move tangentially)
  kSlipWall,  // a ghost of a slip wall
  kOpen,      // a ghost of an inlet or outlet: holds the boundary state
  kPeriodic,  // a ghost of a periodic axis: holds a copy of its image
};

bool is_wall(std::uint8_t role) {
  return role == kSolid || role == kWall || role == kSlipWall;
}

// A cell-step of the scheme (two stages of reconstruction, fluxes and updates) costs about as much
// as this many particle-steps of the DEM's passes, so a grid runs on the engine's threads from
// kMinItemsForThreads / kCellWeight cells (4096), the same work per loop as a particle population
// at the threads' minimum. Every pass writes per cell, or per slab of cells, so the state is the
// same bits on any thread count.
constexpr std::size_t kCellWeight = 8;

// body(c) for every padded cell c, in blocks on the engine's threads when `on_team`.
template <class Body>
void for_cells(std::size_t cells, bool on_team, const Body& body) {
  parallel_ranges_if(on_team, cells, block_items(4096),
                     [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t c = begin; c < end; ++c) body(c);
                     });
}

// Primitive state of one face side: ρ, u, v, w, p.
using Primitive = std::array<double, 5>;
using Flux = std::array<double, 5>;

double van_leer(double left_difference, double right_difference) {
  const double product = left_difference * right_difference;
  return product > 0.0 ? 2.0 * product / (left_difference + right_difference) : 0.0;
}

// The mirror of a state across a wall normal to axis a (slip: only the normal velocity flips).
Primitive mirrored(Primitive w, int a) {
  w[std::size_t(1 + a)] = -w[std::size_t(1 + a)];
  return w;
}

// The physical flux of the Euler equations along axis a, and the conserved state.
void euler_flux(const IdealGas& gas, const Primitive& w, int a, Flux& flux, Flux& conserved) {
  const double rho = w[0], p = w[4], un = w[std::size_t(1 + a)];
  const double speed2 = w[1] * w[1] + w[2] * w[2] + w[3] * w[3];
  const double energy = gas.total_energy_j_per_m3(rho, speed2, p);
  conserved = {rho, rho * w[1], rho * w[2], rho * w[3], energy};
  flux = {rho * un, rho * un * w[1], rho * un * w[2], rho * un * w[3], un * (energy + p)};
  flux[std::size_t(1 + a)] += p;
}

// Thornber et al.'s low-Mach correction (J. Comput. Phys. 227 (2008) 4873): the velocity jump
// between two reconstructed face states is scaled by z = min(1, max(M_left, M_right)) about
// its mean. Without it an upwind-type flux dissipates kinetic energy at the sound speed
// (numerical viscosity ~ c h instead of ~ |u| h), which at Mach 0.01–0.1 swamps the physical
// viscosity of a mill's vortex; with it the dissipation scales with the flow's own speed.
// Density and pressure are left as they are, so shocks are captured as before.
// c_left and c_right are the states' sound speeds (the correction leaves ρ and p, so they hold
// after it too).
void low_mach_correction(Primitive& left, Primitive& right, double c_left, double c_right) {
  double m_left = 0.0, m_right = 0.0;
  for (std::size_t b = 1; b <= 3; ++b) m_left += left[b] * left[b], m_right += right[b] * right[b];
  m_left = std::sqrt(m_left) / c_left;
  m_right = std::sqrt(m_right) / c_right;
  const double z = std::min(1.0, std::max(m_left, m_right));
  if (z >= 1.0) return;
  for (std::size_t b = 1; b <= 3; ++b) {
    const double mean = 0.5 * (left[b] + right[b]), half_jump = 0.5 * (right[b] - left[b]);
    left[b] = mean - z * half_jump;
    right[b] = mean + z * half_jump;
  }
}

// Kurganov–Noelle–Petrova central-upwind flux along axis a between face states left and right,
// whose sound speeds are c_left and c_right.
Flux central_upwind_flux(const IdealGas& gas, const Primitive& left, const Primitive& right, int a,
                         double c_left, double c_right) {
  const double u_left = left[std::size_t(1 + a)], u_right = right[std::size_t(1 + a)];
  const double a_plus = std::max({u_left + c_left, u_right + c_right, 0.0});
  const double a_minus = std::min({u_left - c_left, u_right - c_right, 0.0});
  Flux f_left, f_right, u_l, u_r, flux;
  euler_flux(gas, left, a, f_left, u_l);
  euler_flux(gas, right, a, f_right, u_r);
  const double inverse = 1.0 / (a_plus - a_minus);  // > 0: the sound speeds are positive
  for (std::size_t v = 0; v < 5; ++v)
    flux[v] = (a_plus * f_left[v] - a_minus * f_right[v] + a_plus * a_minus * (u_r[v] - u_l[v])) *
              inverse;
  return flux;
}

Flux central_upwind_flux(const IdealGas& gas, const Primitive& left, const Primitive& right,
                         int a) {
  return central_upwind_flux(gas, left, right, a, gas.sound_speed_m_per_s(left[0], left[4]),
                             gas.sound_speed_m_per_s(right[0], right[4]));
}

}  // namespace

CompressibleSolver::CompressibleSolver(const GasConfig& config, GasGrid grid,
                                       const Vec3& gravity_m_per_s2)
    : grid_(std::move(grid)),
      gas_(config.compressible.gas),
      viscosity_pa_s_(config.viscosity_pa_s),
      gravity_m_per_s2_(gravity_m_per_s2),
      patches_(config.boundaries) {
  const std::size_t size = grid_.padded_size;
  role_.assign(size, kSolid);
  for (std::size_t c = 0; c < size; ++c)
    if (grid_.fluid[c]) role_[c] = kFluid;
  for (int a = 0; a < 3; ++a)
    grid_.for_each_ghost(a, [&](std::size_t ghost, std::size_t, bool) {
      if (grid_.periodic[std::size_t(a)]) {
        role_[ghost] = kPeriodic;
        return;
      }
      switch (grid_.ghost[ghost].kind) {
        case GasBoundaryKind::Wall:
          role_[ghost] = kWall;
          break;
        case GasBoundaryKind::Slip:
          role_[ghost] = kSlipWall;
          break;
        case GasBoundaryKind::Inlet:
        case GasBoundaryKind::Outlet:
          role_[ghost] = kOpen;
          break;
      }
    });
  density_.assign(size, 0.0);
  for (auto& m : momentum_) m.assign(size, 0.0);
  energy_.assign(size, 0.0);
  for (auto& v : start_) v.assign(size, 0.0);
  for (auto& v : residual_) v.assign(size, 0.0);
  for (auto& v : primitive_) v.assign(size, 0.0);
  for (auto& v : slope_) v.assign(size, 0.0);
  if (viscosity_pa_s_ > 0.0)
    for (auto& v : velocity_gradient_) v.assign(size, 0.0);
  patch_inflow_.assign(patches_.size(), 0.0);
  jet_config_ = config.jets;
  jet_exit_.assign(jet_config_.size(), NozzleExit{});
  jet_inflow_.assign(jet_config_.size(), 0.0);
  fraction_.assign(size, 1.0);
  energy_source_.assign(size, 0.0);
  for (int a = 0; a < 3; ++a) {
    source_[std::size_t(a)].assign(size, 0.0);
    gradient_[std::size_t(a)].assign(size, 0.0);
  }

  const CompressibleGasConfig& initial = config.compressible;
  const double rho =
      gas_.density_kg_per_m3(initial.initial_pressure_pa, initial.initial_temperature_k);
  for (std::size_t c = 0; c < size; ++c)
    if (grid_.fluid[c])
      set_state(c, rho, config.initial_velocity_m_per_s, initial.initial_pressure_pa);
  update_pressure_gradient();
}

void CompressibleSolver::set_state(std::size_t c, double density, const Vec3& velocity,
                                   double pressure) {
  density_[c] = density;
  for (int a = 0; a < 3; ++a) momentum_[std::size_t(a)][c] = density * velocity[a];
  energy_[c] = gas_.total_energy_j_per_m3(density, norm2(velocity), pressure);
}

Vec3 CompressibleSolver::velocity_m_per_s(std::size_t c) const {
  const double inverse = 1.0 / density_[c];
  return {momentum_[0][c] * inverse, momentum_[1][c] * inverse, momentum_[2][c] * inverse};
}

double CompressibleSolver::pressure_pa(std::size_t c) const {
  const double m2 = momentum_[0][c] * momentum_[0][c] + momentum_[1][c] * momentum_[1][c] +
                    momentum_[2][c] * momentum_[2][c];
  return gas_.pressure_pa(density_[c], m2, energy_[c]);
}

double CompressibleSolver::temperature_k(std::size_t c) const {
  return gas_.temperature_k(density_[c], pressure_pa(c));
}

double CompressibleSolver::mach(std::size_t c) const {
  return norm(velocity_m_per_s(c)) / gas_.sound_speed_m_per_s(density_[c], pressure_pa(c));
}

double CompressibleSolver::total_mass_kg() const {
  double sum = 0.0;
  for (std::size_t c = 0; c < grid_.padded_size; ++c)
    if (role_[c] == kFluid) sum += density_[c];
  return sum * grid_.cell_volume_m3();
}

double CompressibleSolver::total_energy_j() const {
  double sum = 0.0;
  for (std::size_t c = 0; c < grid_.padded_size; ++c)
    if (role_[c] == kFluid) sum += energy_[c];
  return sum * grid_.cell_volume_m3();
}

Vec3 CompressibleSolver::total_momentum_n_s() const {
  Vec3 sum;
  for (std::size_t c = 0; c < grid_.padded_size; ++c)
    if (role_[c] == kFluid) sum += Vec3{momentum_[0][c], momentum_[1][c], momentum_[2][c]};
  return sum * grid_.cell_volume_m3();
}

double CompressibleSolver::stable_step_s(double courant) const {
  const double diffusivity_factor = 2.0 * std::max(4.0 / 3.0, gas_.gamma / gas_.prandtl);
  double inverse_h2 = 0.0;
  for (int a = 0; a < 3; ++a) inverse_h2 += 1.0 / (grid_.h_m[a] * grid_.h_m[a]);
  // The largest rate per block of cells, then over the blocks (a maximum: exact in any order).
  const std::size_t block = block_items(4096), blocks = (grid_.padded_size + block - 1) / block;
  std::vector<double> block_rate(blocks, 0.0);
  parallel_ranges_if(
      on_team(), grid_.padded_size, block, [&](std::size_t begin, std::size_t end, std::size_t b) {
        double rate = 0.0;
        for (std::size_t c = begin; c < end; ++c) {
          if (role_[c] != kFluid) continue;
          const Vec3 u = velocity_m_per_s(c);
          const double sound = gas_.sound_speed_m_per_s(density_[c], pressure_pa(c));
          double cell_rate = 0.0;
          for (int a = 0; a < 3; ++a) cell_rate += (std::abs(u[a]) + sound) / grid_.h_m[a];
          cell_rate += diffusivity_factor * viscosity_pa_s_ / density_[c] * inverse_h2;
          rate = std::max(rate, cell_rate);
        }
        block_rate[b] = rate;
      });
  const double rate = blocks > 0 ? *std::max_element(block_rate.begin(), block_rate.end()) : 0.0;
  return rate > 0.0 ? courant / rate : std::numeric_limits<double>::infinity();
}

bool CompressibleSolver::on_team() const {
  return worth_threads(grid_.padded_size * kCellWeight);
}

void CompressibleSolver::compute_primitives() {
  for_cells(grid_.padded_size, on_team(), [&](std::size_t c) {
    if (role_[c] != kFluid) return;
    const double inverse = 1.0 / density_[c];
    primitive_[0][c] = density_[c];
    for (std::size_t a = 0; a < 3; ++a) primitive_[1 + a][c] = momentum_[a][c] * inverse;
    primitive_[4][c] = pressure_pa(c);
  });
}

void CompressibleSolver::fill_ghosts() {
  for (int a = 0; a < 3; ++a)
    grid_.for_each_ghost(a, [&](std::size_t ghost, std::size_t inner, bool high) {
      if (role_[ghost] == kPeriodic) {
        for (auto& q : primitive_) q[ghost] = q[inner];
        return;
      }
      if (role_[ghost] != kOpen || role_[inner] != kFluid) return;
      const GhostBoundary& bc = grid_.ghost[ghost];
      const double inner_pressure = primitive_[4][inner];
      const double inward = high ? -1.0 : 1.0;
      Primitive w{};
      if (bc.kind == GasBoundaryKind::Outlet) {
        for (std::size_t v = 0; v < 5; ++v) w[v] = primitive_[v][inner];
        const double outward_speed = -inward * w[std::size_t(1 + a)];
        const double sound = gas_.sound_speed_m_per_s(w[0], w[4]);
        if (outward_speed < sound) w[4] = bc.pressure_pa;  // subsonic: the outlet sets p
      } else {
        const GasBoundaryPatch& patch = patches_[std::size_t(bc.patch)];
        if (patch.supply_pressure_pa) {
          const double p0 = *patch.supply_pressure_pa;
          const double m = isentropic_mach(gas_, inner_pressure, p0);
          const IsentropicState s = isentropic_state(gas_, p0, patch.supply_temperature_k, m);
          w = {s.density_kg_per_m3, 0.0, 0.0, 0.0, s.pressure_pa};
          w[std::size_t(1 + a)] = inward * s.speed_m_per_s;
        } else {
          w = {gas_.density_kg_per_m3(inner_pressure, patch.supply_temperature_k),
               bc.velocity_m_per_s.x, bc.velocity_m_per_s.y, bc.velocity_m_per_s.z, inner_pressure};
        }
      }
      for (std::size_t v = 0; v < 5; ++v) primitive_[v][ghost] = w[v];
    });
}

Vec3 CompressibleSolver::neighbour_velocity(std::size_t c, std::size_t n, int a) const {
  Vec3 u;
  for (int b = 0; b < 3; ++b) {
    const double own = primitive_[std::size_t(1 + b)][c];
    switch (role_[n]) {
      case kSolid:
        u[b] = -own;
        break;
      case kWall:
        u[b] = 2.0 * grid_.ghost[n].velocity_m_per_s[b] - own;
        break;
      case kSlipWall:
        u[b] = b == a ? -own : own;
        break;
      default:
        u[b] = primitive_[std::size_t(1 + b)][n];
    }
  }
  return u;
}

void CompressibleSolver::compute_velocity_gradients() {
  if (velocity_gradient_[0].size() != grid_.padded_size)
    for (auto& v : velocity_gradient_) v.assign(grid_.padded_size, 0.0);
  for_cells(grid_.padded_size, on_team(), [&](std::size_t c) {
    if (role_[c] != kFluid) return;
    for (int d = 0; d < 3; ++d) {
      const std::size_t s = grid_.stride[std::size_t(d)];
      const Vec3 below = neighbour_velocity(c, c - s, d), above = neighbour_velocity(c, c + s, d);
      for (std::size_t b = 0; b < 3; ++b)
        velocity_gradient_[3 * b + std::size_t(d)][c] =
            (above[int(b)] - below[int(b)]) / (2.0 * grid_.h_m[d]);
    }
  });
}

// A wall neighbour stands for the wall's ghost: density and pressure mirrored, the velocity as
// the viscous stress sees it (no slip: 2 u_wall − u, so the slope next to a wall follows the
// boundary layer instead of being clipped to zero, which left a first-order numerical viscosity
// of about |u| h / 4 in the wall cells); an inviscid flow's walls mirror only the normal velocity
// (slip). The slope is a cell's own, whichever face it is read for.
void CompressibleSolver::compute_slopes(int a) {
  const bool viscous = viscosity_pa_s_ > 0.0;
  const std::size_t s = grid_.stride[std::size_t(a)];
  for_cells(grid_.padded_size, on_team(), [&](std::size_t c) {
    if (role_[c] != kFluid) return;
    const std::array<std::size_t, 2> n{c - s, c + s};
    std::array<Vec3, 2> wall_velocity{};
    for (std::size_t k = 0; k < 2; ++k)
      if (is_wall(role_[n[k]])) {
        wall_velocity[k] = viscous ? neighbour_velocity(c, n[k], a)
                                   : Vec3{primitive_[1][c], primitive_[2][c], primitive_[3][c]};
        if (!viscous) wall_velocity[k][a] = -wall_velocity[k][a];
      }
    for (std::size_t v = 0; v < 5; ++v) {
      const double own = primitive_[v][c];
      double neighbour[2];
      for (std::size_t k = 0; k < 2; ++k) {
        if (!is_wall(role_[n[k]]))
          neighbour[k] = primitive_[v][n[k]];
        else
          neighbour[k] = v >= 1 && v <= 3 ? wall_velocity[k][int(v - 1)] : own;
      }
      slope_[v][c] = van_leer(own - neighbour[0], neighbour[1] - own);
    }
  });
}

std::pair<Vec3, double> CompressibleSolver::compute_residual(double stage_weight) {
  compute_primitives();
  fill_ghosts();
  const bool viscous = viscosity_pa_s_ > 0.0;
  if (viscous) compute_velocity_gradients();
  for (auto& r : residual_) std::fill(r.begin(), r.end(), 0.0);
  const double conductivity = viscosity_pa_s_ * gas_.heat_capacity_p_j_per_kg_k() / gas_.prandtl;

  // The face state of fluid cell c on its side `sign` (±1) along the faces' axis, from its
  // slope (compute_slopes).
  const auto reconstruct = [&](std::size_t c, double sign) {
    Primitive w;
    for (std::size_t v = 0; v < 5; ++v) w[v] = primitive_[v][c] + 0.5 * sign * slope_[v][c];
    return w;
  };
  // The faces normal to axis a, slab by slab across the third axis: a face writes only the two
  // cells beside it, which lie in its slab, so the slabs run on the engine's threads and every
  // cell receives its faces' fluxes in the order one thread adds them. A slab's inflows through
  // open faces are kept in order and added to the patches' sums after, slab by slab.
  const bool team = on_team();
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a), s = grid_.stride[au];
    const double inverse_h = 1.0 / grid_.h_m[a], area = grid_.face_area_m2(a);
    const int b_axis = (a + 1) % 3, c_axis = (a + 2) % 3;
    const int first = grid_.periodic[au] ? 1 : 0;
    compute_slopes(a);
    const std::size_t slabs = std::size_t(grid_.n[std::size_t(c_axis)]);
    if (slab_inflow_.size() < slabs) slab_inflow_.resize(slabs);
    parallel_blocks_if(team, slabs, [&](std::size_t slab) {
      const int kc = int(slab) + 1;
      std::vector<std::pair<int, double>>& inflow = slab_inflow_[slab];
      inflow.clear();
      for (int kb = 1; kb <= grid_.n[std::size_t(b_axis)]; ++kb)
        for (int ka = first; ka <= grid_.n[au]; ++ka) {
          std::array<int, 3> ijk{};
          ijk[au] = ka;
          ijk[std::size_t(b_axis)] = kb;
          ijk[std::size_t(c_axis)] = kc;
          const std::size_t left = grid_.index(ijk[0], ijk[1], ijk[2]);
          std::size_t right = left + s;
          if (role_[right] == kPeriodic) right = grid_.wrap_cell(right, a);
          const std::uint8_t role_l = role_[left], role_r = role_[right];
          const bool fluid_l = role_l == kFluid, fluid_r = role_r == kFluid;
          if (!fluid_l && !fluid_r) continue;

          Flux flux;
          if (fluid_l && fluid_r) {
            Primitive w_left = reconstruct(left, 1.0), w_right = reconstruct(right, -1.0);
            const double c_left = gas_.sound_speed_m_per_s(w_left[0], w_left[4]);
            const double c_right = gas_.sound_speed_m_per_s(w_right[0], w_right[4]);
            low_mach_correction(w_left, w_right, c_left, c_right);
            flux = central_upwind_flux(gas_, w_left, w_right, a, c_left, c_right);
          } else if (is_wall(role_l) || is_wall(role_r)) {
            const Primitive inside = fluid_l ? reconstruct(left, 1.0) : reconstruct(right, -1.0);
            flux = fluid_l ? central_upwind_flux(gas_, inside, mirrored(inside, a), a)
                           : central_upwind_flux(gas_, mirrored(inside, a), inside, a);
            flux[0] = flux[4] = 0.0;  // nothing crosses a wall (exactly 0 already, by symmetry)
          } else {                    // an open boundary
            const std::size_t ghost = fluid_l ? right : left;
            Primitive outside;
            for (std::size_t v = 0; v < 5; ++v) outside[v] = primitive_[v][ghost];
            flux = fluid_l ? central_upwind_flux(gas_, reconstruct(left, 1.0), outside, a)
                           : central_upwind_flux(gas_, outside, reconstruct(right, -1.0), a);
            const int patch = grid_.ghost[ghost].patch;
            if (patch >= 0)
              inflow.emplace_back(patch, stage_weight * (fluid_l ? -flux[0] : flux[0]) * area);
          }

          if (viscous) {
            // Velocities and temperatures on both sides, gradients along the face from the
            // fluid cells.
            double t_l, t_r;
            const std::size_t own = fluid_l ? left : right;
            const Vec3 u_l =
                fluid_l ? neighbour_velocity(left, left, a) : neighbour_velocity(right, left, a);
            const Vec3 u_r =
                fluid_r ? neighbour_velocity(right, right, a) : neighbour_velocity(left, right, a);
            const double t_own = gas_.temperature_k(primitive_[0][own], primitive_[4][own]);
            t_l = is_wall(role_l) ? t_own
                                  : gas_.temperature_k(primitive_[0][left], primitive_[4][left]);
            t_r = is_wall(role_r) ? t_own
                                  : gas_.temperature_k(primitive_[0][right], primitive_[4][right]);
            std::array<double, 9> grad{};
            for (std::size_t b = 0; b < 3; ++b)
              for (std::size_t d = 0; d < 3; ++d) {
                if (int(d) == a) {
                  grad[3 * b + d] = (u_r[int(b)] - u_l[int(b)]) * inverse_h;
                } else {
                  const std::vector<double>& g = velocity_gradient_[3 * b + d];
                  grad[3 * b + d] = fluid_l && fluid_r ? 0.5 * (g[left] + g[right]) : g[own];
                }
              }
            const double divergence = grad[0] + grad[4] + grad[8];
            const Vec3 u_face = 0.5 * (u_l + u_r);
            double work = 0.0;
            for (std::size_t b = 0; b < 3; ++b) {
              double tau = viscosity_pa_s_ * (grad[3 * b + au] + grad[3 * au + b]);
              if (b == au) tau -= 2.0 / 3.0 * viscosity_pa_s_ * divergence;
              flux[1 + b] -= tau;
              work += u_face[int(b)] * tau;
            }
            flux[4] -= work + conductivity * (t_r - t_l) * inverse_h;
          }

          for (std::size_t v = 0; v < 5; ++v) {
            if (fluid_l) residual_[v][left] -= flux[v] * inverse_h;
            if (fluid_r) residual_[v][right] += flux[v] * inverse_h;
          }
        }
    });
    for (std::size_t slab = 0; slab < slabs; ++slab)
      for (const auto& [patch, mass_flow] : slab_inflow_[slab])
        patch_inflow_[std::size_t(patch)] += mass_flow;
  }

  const bool gravity = norm2(gravity_m_per_s2_) > 0.0;
  for_cells(grid_.padded_size, team, [&](std::size_t c) {
    if (role_[c] != kFluid) return;
    if (gravity)
      for (std::size_t a = 0; a < 3; ++a) {
        residual_[1 + a][c] += density_[c] * gravity_m_per_s2_[int(a)];
        residual_[4][c] += momentum_[a][c] * gravity_m_per_s2_[int(a)];
      }
    for (std::size_t a = 0; a < 3; ++a) residual_[1 + a][c] += source_[a][c];
    residual_[4][c] += energy_source_[c];
  });
  add_jet_sources(stage_weight);
  return dusty() ? add_dust_reaction() : std::pair<Vec3, double>{};
}

// The gas's own acceleration without the dust, ρ (a* − g) = R_m − u R_ρ + ρ (u·∇)u − ρ g from the
// stage's residual (R_m holds every force and the convective flux; −u R_ρ + ρ (u·∇)u turns its
// ∂(ρu)/∂t into ρ Du/Dt), is shared with the dust: F = −c ρ (a* − g) / (ρ + c).
std::pair<Vec3, double> CompressibleSolver::add_dust_reaction() {
  if (dust_force_.size() != grid_.padded_size) dust_force_.assign(grid_.padded_size, Vec3{});
  for_cells(grid_.padded_size, on_team(), [&](std::size_t c) {
    dust_force_[c] = Vec3{};
    const double load = dust_density_[c];
    if (role_[c] != kFluid || !(load > 0.0)) return;
    const double rho = primitive_[0][c];
    const Vec3 u{primitive_[1][c], primitive_[2][c], primitive_[3][c]};
    // (u·∇)u by donor-cell differences, from the upwind neighbour along each axis. The gas
    // keeps ρ/(ρ + c) of its residual's convection and takes c/(ρ + c) of this one, so at a high
    // loading this is the convection it is left with: central differences there (no
    // dissipation, which Heun's method amplifies) let a ring of dust at c/ρ = 100 in a vortex
    // blow the gas up within 2 200 steps.
    Vec3 convective;
    for (int d = 0; d < 3; ++d) {
      const std::size_t s = grid_.stride[std::size_t(d)];
      const bool from_below = u[d] > 0.0;
      const Vec3 upwind = neighbour_velocity(c, from_below ? c - s : c + s, d);
      convective += (from_below ? u - upwind : upwind - u) * (u[d] / grid_.h_m[d]);
    }
    Vec3 force;
    for (std::size_t b = 0; b < 3; ++b) {
      const double own = residual_[1 + b][c] - u[int(b)] * residual_[0][c] +
                         rho * convective[int(b)] - rho * gravity_m_per_s2_[int(b)];
      force[int(b)] = -load * own / (rho + load);
    }
    dust_force_[c] = force;
    for (std::size_t b = 0; b < 3; ++b) residual_[1 + b][c] += force[int(b)];
    residual_[4][c] += dot(force, u);
  });
  Vec3 force_sum;
  double power_sum = 0.0;
  for (std::size_t c = 0; c < grid_.padded_size; ++c) {
    if (role_[c] != kFluid) continue;
    force_sum += dust_force_[c];
    power_sum += dot(dust_force_[c], Vec3{primitive_[1][c], primitive_[2][c], primitive_[3][c]});
  }
  return {force_sum, power_sum};
}

// Each jet's mass flow, momentum and stagnation enthalpy into the fluid cells behind its faces,
// by each face's share of the jet's flow, at the mean pressure of those cells.
void CompressibleSolver::add_jet_sources(double stage_weight) {
  const double inverse_volume = 1.0 / grid_.cell_volume_m3();
  const double cp = gas_.heat_capacity_p_j_per_kg_k();
  for (std::size_t j = 0; j < jet_config_.size(); ++j) {
    const std::vector<JetFace>& faces = grid_.jet_face_list[j];
    if (faces.empty()) continue;
    const GasJetConfig& jet = jet_config_[j];
    double ambient_pa = 0.0;
    for (const JetFace& f : faces) ambient_pa += f.flow_share * primitive_[4][f.cell];
    const double area = std::numbers::pi * jet.radius_m * jet.radius_m;
    NozzleExit e;
    if (jet.supply_pressure_pa) {
      e = notional_nozzle(gas_, *jet.supply_pressure_pa, jet.supply_temperature_k, area,
                          ambient_pa);
    } else {
      e.speed_m_per_s = jet.speed_m_per_s;
      e.temperature_k = jet.supply_temperature_k - 0.5 * e.speed_m_per_s * e.speed_m_per_s / cp;
      e.density_kg_per_m3 = gas_.density_kg_per_m3(ambient_pa, e.temperature_k);
      e.area_m2 = area;
      e.mass_flow_kg_per_s = e.density_kg_per_m3 * e.speed_m_per_s * area;
      e.mach = e.speed_m_per_s / gas_.sound_speed_m_per_s(e.density_kg_per_m3, ambient_pa);
      e.stagnation_enthalpy_j_per_kg = cp * jet.supply_temperature_k;
    }
    jet_exit_[j] = e;
    jet_inflow_[j] += stage_weight * e.mass_flow_kg_per_s;
    for (const JetFace& f : faces) {
      const double mass = e.mass_flow_kg_per_s * f.flow_share * inverse_volume;
      residual_[0][f.cell] += mass;
      for (std::size_t a = 0; a < 3; ++a)
        residual_[1 + a][f.cell] += mass * e.speed_m_per_s * jet.direction[int(a)];
      residual_[4][f.cell] += mass * e.stagnation_enthalpy_j_per_kg;
    }
  }
}

// ∂p/∂x_a per fluid cell: central differences between fluid neighbours (periodic images
// included), one-sided where one side is a wall or an open boundary, 0 where both are.
void CompressibleSolver::update_pressure_gradient() {
  for_cells(grid_.padded_size, on_team(), [&](std::size_t c) {
    if (role_[c] != kFluid) return;
    const double own = pressure_pa(c);
    for (int a = 0; a < 3; ++a) {
      const std::size_t s = grid_.stride[std::size_t(a)];
      double sum = 0.0, span = 0.0;
      for (int side = -1; side <= 1; side += 2) {
        std::size_t n = side < 0 ? c - s : c + s;
        if (role_[n] == kPeriodic) n = grid_.wrap_cell(n, a);
        if (role_[n] != kFluid) continue;
        sum += side * (pressure_pa(n) - own);
        span += grid_.h_m[a];
      }
      gradient_[std::size_t(a)][c] = span > 0.0 ? sum / span : 0.0;
    }
  });
}

// Σ w value_of(cell) over the fluid cells of x's trilinear stencil (a number or a vector).
template <class Field>
auto CompressibleSolver::sample(const Field& value_of, const Vec3& x) const {
  const Stencil s = make_stencil(grid_, x, -1, [&](std::size_t n) { return role_[n] == kFluid; });
  decltype(value_of(std::size_t{})) v{};
  for (int k = 0; k < s.count; ++k) v += value_of(s.node[k]) * s.weight[k];
  return v;
}

Vec3 CompressibleSolver::velocity_at(const Vec3& x) const {
  return sample([&](std::size_t c) { return velocity_m_per_s(c); }, x);
}

double CompressibleSolver::density_at(const Vec3& x) const {
  return sample([&](std::size_t c) { return density_[c]; }, x);
}

double CompressibleSolver::pressure_at(const Vec3& x) const {
  return sample([&](std::size_t c) { return pressure_pa(c); }, x);
}

Vec3 CompressibleSolver::pressure_gradient_at(const Vec3& x) const {
  return sample(
      [&](std::size_t c) {
        return Vec3{gradient_[0][c], gradient_[1][c], gradient_[2][c]};
      },
      x);
}

double CompressibleSolver::volume_fraction_at(const Vec3& x) const {
  return sample([&](std::size_t c) { return fraction_[c]; }, x);
}

Vec3 CompressibleSolver::vorticity_at(const Vec3& x) const {
  return vorticity_by_central_differences(grid_, x,
                                          [this](const Vec3& y) { return velocity_at(y); });
}

std::optional<std::string> CompressibleSolver::check_state() const {
  // The first cell with a bad state per block of cells, then the first of those: the cell a pass
  // in cell order reports.
  const std::size_t n = grid_.padded_size;
  const std::size_t c = first_index_where(on_team(), n, block_items(4096), [&](std::size_t cell) {
    if (role_[cell] != kFluid) return false;
    const double rho = density_[cell], p = pressure_pa(cell);
    return !(rho > 0.0) || !std::isfinite(rho) || !(p > 0.0) || !std::isfinite(p);
  });
  if (c < n) {
    const double rho = density_[c], p = pressure_pa(c);
    const bool density_bad = !(rho > 0.0) || !std::isfinite(rho);
    const std::array<int, 3> ijk = grid_.coords(c);
    const Vec3 x = grid_.cell_center(ijk[0], ijk[1], ijk[2]);
    std::ostringstream message;
    message << "compressible gas: the " << (density_bad ? "density" : "pressure") << " became "
            << (density_bad ? rho : p) << (density_bad ? " kg/m3" : " Pa") << " in gas cell ("
            << ijk[0] << ", " << ijk[1] << ", " << ijk[2] << ") at (" << x.x << ", " << x.y << ", "
            << x.z << ") m, t = " << time_s_
            << " s: the step is too large for this flow (gas.courant) or an inflow is too strong "
               "for the grid";
    if (dusty()) {
      // Dust piled past what a dilute phase is (its mass per volume a sizeable share of the
      // solid's density) is a cause too: say how much the gas was carrying.
      double most = 0.0;
      for (std::size_t cell = 0; cell < n; ++cell)
        if (role_[cell] == kFluid) most = std::max(most, dust_density_[cell]);
      message << ", or the dust it carries (dust.gas_coupling) piled up: " << dust_density_[c]
              << " kg/m3 of dust in this cell, at most " << most << " kg/m3 in any";
    }
    return message.str();
  }
  return std::nullopt;
}

std::optional<std::string> CompressibleSolver::advance(double dt) {
  std::fill(patch_inflow_.begin(), patch_inflow_.end(), 0.0);
  std::fill(jet_inflow_.begin(), jet_inflow_.end(), 0.0);
  Vec3 source_sum;
  for (std::size_t c = 0; c < grid_.padded_size; ++c)
    if (role_[c] == kFluid) source_sum += Vec3{source_[0][c], source_[1][c], source_[2][c]};
  received_impulse_ += source_sum * (grid_.cell_volume_m3() * dt);
  start_[0] = density_;
  for (std::size_t a = 0; a < 3; ++a) start_[1 + a] = momentum_[a];
  start_[4] = energy_;
  std::array<std::vector<double>*, kVariables> state{&density_, &momentum_[0], &momentum_[1],
                                                     &momentum_[2], &energy_};
  // Heun: U1 = U0 + dt L(U0), U = (U0 + U1 + dt L(U1)) / 2.
  const double volume = grid_.cell_volume_m3();
  for (int stage = 0; stage < 2; ++stage) {
    // The gas gives the dust what it loses, by Heun's weights.
    const auto [dust_force, dust_power] = compute_residual(0.5);
    dust_impulse_ -= dust_force * (0.5 * dt * volume);
    dust_work_j_ -= dust_power * (0.5 * dt * volume);
    for_cells(grid_.padded_size, on_team(), [&](std::size_t c) {
      if (role_[c] != kFluid) return;
      for (std::size_t v = 0; v < kVariables; ++v) {
        std::vector<double>& u = *state[v];
        const double u0 = start_[v][c], r = residual_[v][c];
        u[c] = stage == 0 ? u0 + dt * r : 0.5 * (u0 + u[c] + dt * r);
      }
    });
    if (auto failure = check_state()) return failure;
  }
  time_s_ += dt;
  ++steps_;
  update_pressure_gradient();
  return std::nullopt;
}

}  // namespace millsim
