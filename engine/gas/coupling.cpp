#include "gas/coupling.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "gas/drag.h"
#include "gas/gas_stencil.h"
#include "gas/mach_drag.h"
#include "parallel/thread_team.h"

namespace millsim {
namespace {

constexpr long kCellBias = 1L << 20;  // packed cell coordinates are offset to stay positive

std::uint64_t pack_cell(long i, long j, long k) {
  return (std::uint64_t(i + kCellBias) << 42) | (std::uint64_t(j + kCellBias) << 21) |
         std::uint64_t(k + kCellBias);
}

// ⌊t⌋ without a call into libm (the baseline x86-64 target has no rounding instruction).
inline long floor_to_long(double t) {
  const long i = long(t);
  return i - long(t < double(i));
}

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finaliser
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

DemCellFluidTable::DemCellFluidTable(const Vec3& cell_m, const Vec3& origin_m)
    : cell_m_(cell_m),
      origin_m_(origin_m),
      inverse_cell_{1.0 / cell_m.x, 1.0 / cell_m.y, 1.0 / cell_m.z} {
  keys_.assign(1024, 0);
  slot_state_.assign(1024, 0);
}

void DemCellFluidTable::clear() {
  if (states_.empty()) return;
  std::fill(keys_.begin(), keys_.end(), 0);
  states_.clear();
  last_key_ = 0;
  ++generation_;
}

void DemCellFluidTable::grow() {
  std::vector<std::uint64_t> old_keys = std::move(keys_);
  std::vector<std::uint32_t> old_slots = std::move(slot_state_);
  keys_.assign(old_keys.size() * 2, 0);
  slot_state_.assign(old_keys.size() * 2, 0);
  const std::size_t mask = keys_.size() - 1;
  for (std::size_t s = 0; s < old_keys.size(); ++s) {
    if (!old_keys[s]) continue;
    std::size_t h = mix(old_keys[s]) & mask;
    while (keys_[h]) h = (h + 1) & mask;
    keys_[h] = old_keys[s];
    slot_state_[h] = old_slots[s];
  }
}

namespace {

// ε over the box [low, low + edge]: the fluid cells' ε weighted by the volume each shares with
// the box (the cells' ε is a cell mean, so this is the box's own void fraction to the grid's
// resolution); −1 when the box overlaps no fluid cell.
double box_volume_fraction(const GasView& gas, const Vec3& low, const Vec3& edge_m) {
  const GasGrid& g = gas.grid();
  std::array<std::array<int, 2>, 3> first_last{};  // per axis: first cell, last cell
  for (int b = 0; b < 3; ++b) {
    const std::size_t bu = std::size_t(b);
    first_last[bu][0] = int(floor_to_long((low[b] - g.origin_m[b]) / g.h_m[b])) + 1;
    first_last[bu][1] = int(floor_to_long((low[b] + edge_m[b] - g.origin_m[b]) / g.h_m[b])) + 1;
  }
  const auto overlap = [&](int b, int i) {  // of cell i (unwrapped) with the box along b
    const double lo = g.origin_m[b] + double(i - 1) * g.h_m[b];
    return std::max(0.0, std::min(lo + g.h_m[b], low[b] + edge_m[b]) - std::max(lo, low[b]));
  };
  const auto wrap = [&](int b, int i) {  // −1: off a non-periodic end
    const int n = g.n[std::size_t(b)];
    if (g.periodic[std::size_t(b)]) return ((i - 1) % n + n) % n + 1;
    return i < 1 || i > n ? -1 : i;
  };
  double open = 0.0, voids = 0.0;
  for (int k = first_last[2][0]; k <= first_last[2][1]; ++k) {
    const int kw = wrap(2, k);
    const double lz = overlap(2, k);
    if (kw < 0 || lz <= 0.0) continue;
    for (int j = first_last[1][0]; j <= first_last[1][1]; ++j) {
      const int jw = wrap(1, j);
      const double ly = overlap(1, j);
      if (jw < 0 || ly <= 0.0) continue;
      for (int i = first_last[0][0]; i <= first_last[0][1]; ++i) {
        const int iw = wrap(0, i);
        const double lx = overlap(0, i);
        if (iw < 0 || lx <= 0.0) continue;
        const std::size_t c = g.index(iw, jw, kw);
        if (!g.fluid[c]) continue;
        const double w = lx * ly * lz;
        open += w;
        voids += w * gas.cell_volume_fraction(c);
      }
    }
  }
  return open > 0.0 ? voids / open : -1.0;
}

}  // namespace

// The mean over the DEM cell. ε is the cell's own: the fluid cells' ε weighted by the volume
// they share with it (box_volume_fraction; the coupling's DEM cells lie inside one gas cell, so
// that is the gas cell's). The incompressible gas's velocity is its superficial velocity ε u
// (continuous across a bed's end) at the DEM cell's centre over that ε, so a particle at a bed's
// end sees the bed's interstitial speed; the other fields are the trilinear samples there. A
// DEM cell larger than a gas cell along some axis (tests may build one) averages the samples at
// s³ points no further apart than half a gas cell. A DEM cell that overlaps no fluid cell (in a
// solid) takes the trilinear ε and velocity instead.
FluidCellState DemCellFluidTable::average(long i, long j, long k, const GasView& gas,
                                          bool with_vorticity) const {
  const GasGrid& g = gas.grid();
  int s = 1;
  for (int b = 0; b < 3; ++b)
    s = std::max(s, int(std::ceil(2.0 * cell_m_[b] / g.h_m[b] - 1e-9)) / 2);
  FluidCellState st;
  const Vec3 corner =
      origin_m_ + Vec3{double(i) * cell_m_.x, double(j) * cell_m_.y, double(k) * cell_m_.z};
  double fraction = box_volume_fraction(gas, corner, cell_m_);
  if (fraction <= 0.0) {  // a DEM cell in a solid cell: the fluid cells around its centre
    const Vec3 centre = corner + cell_m_ * 0.5;
    const Stencil around =
        make_stencil(g, centre, -1, [&](std::size_t c) { return g.fluid[c] != 0; });
    if (around.count > 0) {
      fraction = 0.0;
      for (int n = 0; n < around.count; ++n)
        fraction += around.weight[n] * gas.cell_volume_fraction(around.node[n]);
    }
  }
  const bool superficial = fraction > 0.0 && gas.incompressible;
  const double inv = 1.0 / double(s * s * s);
  st.volume_fraction = 0.0;
  double pressure = 0.0;
  for (int c = 0; c < s; ++c)
    for (int b = 0; b < s; ++b)
      for (int a = 0; a < s; ++a) {
        const Vec3 x =
            corner +
            Vec3{(a + 0.5) * cell_m_.x, (b + 0.5) * cell_m_.y, (c + 0.5) * cell_m_.z} * (1.0 / s);
        st.velocity_m_per_s +=
            (superficial ? gas.incompressible->superficial_velocity_at(x) : gas.velocity_at(x)) *
            inv;
        st.pressure_gradient_pa_per_m += gas.pressure_gradient_at(x) * inv;
        if (fraction <= 0.0) st.volume_fraction += gas.volume_fraction_at(x) * inv;
        if (with_vorticity) st.vorticity_per_s += gas.vorticity_at(x) * inv;
        if (gas.compressible) {
          st.density_kg_per_m3 += gas.compressible->density_at(x) * inv;
          pressure += gas.compressible->pressure_at(x) * inv;
        }
      }
  if (fraction > 0.0) st.volume_fraction = fraction;
  if (superficial) st.velocity_m_per_s = st.velocity_m_per_s * (1.0 / fraction);
  st.viscosity_pa_s = gas.viscosity_pa_s();
  if (gas.compressible) {
    if (st.density_kg_per_m3 > 0.0 && pressure > 0.0) {
      st.mean_free_path_m = mean_free_path_m(st.viscosity_pa_s, pressure, st.density_kg_per_m3);
      st.sound_speed_m_per_s =
          gas.compressible->gas().sound_speed_m_per_s(st.density_kg_per_m3, pressure);
    }
  } else {
    st.density_kg_per_m3 = gas.incompressible->density_kg_per_m3();
  }
  return st;
}

std::uint64_t DemCellFluidTable::key_of(const Vec3& x, long& i, long& j, long& k) const {
  i = floor_to_long((x.x - origin_m_.x) * inverse_cell_.x);
  j = floor_to_long((x.y - origin_m_.y) * inverse_cell_.y);
  k = floor_to_long((x.z - origin_m_.z) * inverse_cell_.z);
  return pack_cell(i, j, k) + 1;
}

std::uint32_t DemCellFluidTable::find_or_insert(std::uint64_t key, bool& inserted) {
  inserted = false;
  // Particles are kept in space-filling order, so the next one is often in the same cell.
  if (key == last_key_) return last_state_;
  const std::size_t mask = keys_.size() - 1;
  std::size_t h = mix(key) & mask;
  while (keys_[h]) {
    if (keys_[h] == key) {
      last_key_ = key, last_state_ = slot_state_[h];
      return last_state_;
    }
    h = (h + 1) & mask;
  }
  keys_[h] = key;
  slot_state_[h] = std::uint32_t(states_.size());
  states_.emplace_back();
  ++fills_;
  inserted = true;
  last_key_ = key, last_state_ = std::uint32_t(states_.size() - 1);
  if (2 * states_.size() > keys_.size()) grow();
  return last_state_;
}

std::uint32_t DemCellFluidTable::find_or_fill(std::uint64_t key, long i, long j, long k,
                                              const GasView& gas, bool with_vorticity) {
  bool inserted = false;
  const std::uint32_t state = find_or_insert(key, inserted);
  if (inserted) states_[state] = average(i, j, k, gas, with_vorticity);
  return state;
}

void DemCellFluidTable::reserve(const Vec3& x, FluidCellRef& hint) {
  long i, j, k;
  const std::uint64_t key = key_of(x, i, j, k);
  if (key == hint.key && hint.generation == generation_) return;
  bool inserted = false;
  hint = {key, find_or_insert(key, inserted), generation_};
  if (inserted) pending_.push_back({hint.state, i, j, k});
}

// A DEM cell's average samples the gas at one point or more (velocity, pressure and its gradient,
// density: a few hundred operations), the work of about this many particles in a particle loop.
constexpr std::size_t kCellAverageWeight = 64;

void DemCellFluidTable::fill_pending(const GasView& gas, bool with_vorticity) {
  parallel_ranges_if(worth_threads(pending_.size() * kCellAverageWeight), pending_.size(),
                     block_items(256), [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t n = begin; n < end; ++n) {
                         const PendingCell& c = pending_[n];
                         states_[c.state] = average(c.i, c.j, c.k, gas, with_vorticity);
                       }
                     });
  pending_.clear();
}

const FluidCellState* DemCellFluidTable::find(const Vec3& x, FluidCellRef& hint,
                                              FluidCellRef& last) const {
  long i, j, k;
  const std::uint64_t key = key_of(x, i, j, k);
  if (key == hint.key && hint.generation == generation_) return &states_[hint.state];
  if (!(key == last.key && last.generation == generation_)) {
    const std::size_t mask = keys_.size() - 1;
    std::size_t h = mix(key) & mask;
    while (keys_[h] != key) {
      if (!keys_[h]) return nullptr;
      h = (h + 1) & mask;
    }
    last = {key, slot_state_[h], generation_};
  }
  hint = last;
  return &states_[last.state];
}

const FluidCellState& DemCellFluidTable::at(const Vec3& x, const GasView& gas,
                                            bool with_vorticity) {
  long i, j, k;
  const std::uint64_t key = key_of(x, i, j, k);
  return states_[find_or_fill(key, i, j, k, gas, with_vorticity)];
}

const FluidCellState& DemCellFluidTable::at(const Vec3& x, const GasView& gas, bool with_vorticity,
                                            FluidCellRef& hint) {
  long i, j, k;
  const std::uint64_t key = key_of(x, i, j, k);
  if (key == hint.key && hint.generation == generation_) return states_[hint.state];
  hint = {key, find_or_fill(key, i, j, k, gas, with_vorticity), generation_};
  return states_[hint.state];
}

GasCoupling::GasCoupling(const GasConfig& config, const PeriodicBox& box,
                         const Vec3& gravity_m_per_s2, double dem_cell_m)
    : config_(config), box_(box) {
  GasGrid grid = build_gas_grid(config, box.min_m, box.max_m, box.periodic);
  Vec3 cell_m;
  for (int a = 0; a < 3; ++a)
    cell_m[a] = grid.h_m[a] / std::max(1.0, std::floor(grid.h_m[a] / dem_cell_m * (1 + 1e-12)));
  table_ = DemCellFluidTable(cell_m, box.min_m);
  if (config.model == GasModel::Compressible)
    compressible_.emplace(config, std::move(grid), gravity_m_per_s2);
  else
    incompressible_.emplace(config, std::move(grid), gravity_m_per_s2);
  solid_volume_.assign(this->grid().padded_size, 0.0);
  if (compressible_) exchange_per_cell_.assign(solid_volume_.size(), 0.0);
}

const FluidCellState& GasCoupling::fluid_at(const Vec3& x) {
  Vec3 w = x;
  box_.wrap(w);
  return table_.at(w, view(), config_.saffman_lift);
}

void GasCoupling::release(const ParticleStore& p, std::size_t slot) {
  if (!config_.two_way || !p.has_fluid_state) return;
  const Vec3& j = p.fluid_impulse_n_s[slot];
  if (j.x != 0.0 || j.y != 0.0 || j.z != 0.0)
    released_.push_back({p.position_m[slot], j, p.motion[slot].velocity_m_per_s});
}

// From the gas's CFL limit and drag_courant · ε ρ / B (a margin: the drag itself is implicit,
// the volume fraction and the pressure-gradient force are not; docs/gas.md); growing at most
// twofold per CFD step.
int GasCoupling::choose_steps(double dem_step_s) const {
  if (config_.step_s) return std::max(1, int(std::lround(*config_.step_s / dem_step_s)));
  const double stable =
      compressible_
          ? std::min(gas_stable_step_s(), 0.5 / std::max(1e-300, max_exchange_rate_per_s_))
          : std::min(gas_stable_step_s(),
                     config_.drag_courant /
                         std::max(1e-300, incompressible_->max_exchange_rate_per_s()));
  int steps = int(std::clamp(std::floor(stable / dem_step_s), 1.0, 1e6));
  if (last_steps_ > 0) steps = std::min(steps, 2 * last_steps_);
  return steps;
}

// The implicit drag coefficient a particle lends the gas: its β, but never more than m / Δt, so
// the impulse handed back after the step cannot overshoot the gas's velocity change.
static double effective_beta(const ParticleStore& p, std::size_t i, double cfd_step_s) {
  return std::min(std::max(0.0, p.fluid_coefficient_kg_per_s[i]), p.mass_kg[i] / cfd_step_s);
}

double GasCoupling::gas_stable_step_s() const {
  return compressible_ ? compressible_->stable_step_s(config_.courant)
                       : incompressible_->stable_step_s();
}

std::optional<std::string> GasCoupling::advance_gas(double dt) {
  return compressible_ ? compressible_->advance(dt) : incompressible_->advance(dt);
}

// A particle's volume onto the fluid cells it overlaps (sphere_overlap_stencil). One wholly inside
// cells the staircase counts as solid (next to a curved wall) goes to the fluid cells among the
// eight around its centre, trilinear; one with none there either is counted and left out.
static Stencil solid_volume_stencil(const GasGrid& g, const Vec3& wrapped_x, double radius_m) {
  const auto fluid_cell = [&](std::size_t c) { return g.fluid[c] != 0; };
  Stencil s = sphere_overlap_stencil(g, wrapped_x, radius_m, fluid_cell);
  if (s.count == 0) s = make_stencil(g, wrapped_x, -1, fluid_cell);
  return s;
}

void GasCoupling::add_solid_volume(const Stencil& s, double radius_m) {
  if (s.count == 0) ++stats_.unplaced_deposits;
  const double volume_m3 = 4.0 / 3.0 * std::numbers::pi * radius_m * radius_m * radius_m;
  for (int k = 0; k < s.count; ++k) solid_volume_[s.node[k]] += volume_m3 * s.weight[k];
}

void GasCoupling::deposit_solid_volume(const GasGrid& g, const Vec3& wrapped_x, double radius_m) {
  add_solid_volume(solid_volume_stencil(g, wrapped_x, radius_m), radius_m);
}

// ε = 1 − solids volume / cell volume per fluid cell, floored at min_volume_fraction (each floored
// cell counted); the run's lowest ε kept. A fluid cell a wall cuts keeps its whole volume: the
// gas flows through all of it (the grid is a staircase), so the part beyond the wall is open gas.
void GasCoupling::update_volume_fraction(const GasGrid& g, std::vector<double>& fraction) {
  const double volume = g.cell_volume_m3();
  double min_fraction = 1.0;
  for (std::size_t c = 0; c < g.padded_size; ++c) {
    if (!g.fluid[c]) continue;
    double eps = 1.0 - solid_volume_[c] / volume;
    if (eps < config_.min_volume_fraction)
      eps = config_.min_volume_fraction, ++stats_.clamped_cells;
    fraction[c] = eps;
    min_fraction = std::min(min_fraction, eps);
  }
  stats_.min_volume_fraction = std::min(stats_.min_volume_fraction, min_fraction);
}

// A particle's two deposit stencils cost about this many particles' work in a particle loop.
constexpr std::size_t kDepositWeight = 8;

// The compressible model: solids volume → ε per cell (for the drag laws), and the impulse the
// particles took since the last CFD step → a momentum source per cell, with the work the drag
// did on them (impulse · velocity) as the gas's energy loss, so the drag's dissipation stays in
// the gas as heat. B / ρ per cell bounds the next CFD step (the exchange is explicit).
void GasCoupling::deposit_compressible(const ParticleStore& p, double interval_s) {
  CompressibleSolver& gas = *compressible_;
  const GasGrid& g = gas.grid();
  std::array<std::vector<double>, 3>& source = gas.momentum_source();
  std::vector<double>& energy = gas.energy_source();
  std::vector<double>& exchange = exchange_per_cell_;
  std::fill(solid_volume_.begin(), solid_volume_.end(), 0.0);
  std::fill(exchange.begin(), exchange.end(), 0.0);
  for (std::vector<double>& s : source) std::fill(s.begin(), s.end(), 0.0);
  std::fill(energy.begin(), energy.end(), 0.0);
  const double volume = g.cell_volume_m3();
  const auto fluid_cell = [&](std::size_t c) { return g.fluid[c] != 0; };
  const auto add = [&](const Stencil& s, const Vec3& impulse, const Vec3& velocity, double beta) {
    const double work = dot(impulse, velocity);
    for (int k = 0; k < s.count; ++k) {
      const std::size_t c = s.node[k];
      const double w = s.weight[k];
      for (int a = 0; a < 3; ++a)
        source[std::size_t(a)][c] -= impulse[a] * w / (volume * interval_s);
      energy[c] -= work * w / (volume * interval_s);
      exchange[c] += beta * w / volume;
      stats_.deposited_impulse_n_s -= impulse * w;
    }
  };
  // Each particle's two stencils (the cells its volume overlaps, the cells around its centre) on
  // the engine's threads, then added in slot order: the sums of one thread, on any number.
  deposit_stencils_.resize(2 * p.size());
  parallel_ranges_if(worth_threads(p.size() * kDepositWeight), p.size(), block_items(4096),
                     [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t i = begin; i < end; ++i) {
                         Vec3 x = p.position_m[i];
                         box_.wrap(x);
                         deposit_stencils_[2 * i] = p.radius_m[i] > 0.0
                                                        ? solid_volume_stencil(g, x, p.radius_m[i])
                                                        : Stencil{};
                         deposit_stencils_[2 * i + 1] = make_stencil(g, x, -1, fluid_cell);
                       }
                     });
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.radius_m[i] > 0.0) add_solid_volume(deposit_stencils_[2 * i], p.radius_m[i]);
    add(deposit_stencils_[2 * i + 1], p.fluid_impulse_n_s[i], p.motion[i].velocity_m_per_s,
        std::max(0.0, p.fluid_coefficient_kg_per_s[i]));
  }
  for (const Released& r : released_) {
    Vec3 x = r.position_m;
    box_.wrap(x);
    add(make_stencil(g, x, -1, fluid_cell), r.impulse_n_s, r.velocity_m_per_s, 0.0);
  }
  released_.clear();
  update_volume_fraction(g, gas.volume_fraction());
  double rate = 0.0;
  for (std::size_t c = 0; c < g.padded_size; ++c)
    if (g.fluid[c]) rate = std::max(rate, exchange[c] / gas.density_kg_per_m3(c));
  max_exchange_rate_per_s_ = rate;
}

// Solids volume → ε per cell; the impulse the particles took since the last CFD step → the
// gas's momentum source over the next one; the implicit drag coefficient B per face and the
// face velocity it acts from (the gas's velocity now, so the response is zero in a steady state
// and each particle's drag is the one it computed from its own reading of the gas).
void GasCoupling::deposit(const ParticleStore& p, double interval_s) {
  if (compressible_) return deposit_compressible(p, interval_s);
  GasSolver& gas = *incompressible_;
  GasGrid const& g = gas.grid();
  std::array<std::vector<double>, 3>& source = gas.momentum_source();
  std::array<std::vector<double>, 3>& exchange = gas.exchange_coefficient();
  std::array<std::vector<double>, 3>& seen = gas.exchange_momentum();
  const std::array<std::vector<double>, 3>& velocity = gas.velocity();
  std::fill(solid_volume_.begin(), solid_volume_.end(), 0.0);
  for (int a = 0; a < 3; ++a) {
    std::fill(source[std::size_t(a)].begin(), source[std::size_t(a)].end(), 0.0);
    std::fill(exchange[std::size_t(a)].begin(), exchange[std::size_t(a)].end(), 0.0);
    std::fill(seen[std::size_t(a)].begin(), seen[std::size_t(a)].end(), 0.0);
    drag_fraction_[std::size_t(a)].assign(g.padded_size, 0.0);
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    Vec3 x = p.position_m[i];
    box_.wrap(x);
    deposit_solid_volume(g, x, p.radius_m[i]);
  }
  update_volume_fraction(g, gas.volume_fraction());
  gas.volume_fraction_changed();
  const double volume = g.cell_volume_m3();
  // response: where a dragging particle's entries go (return_drag_response reads them back).
  const auto push = [&](const Vec3& x_raw, const Vec3& impulse, double beta, double read_fraction,
                        ResponseStencil* response) {
    Vec3 x = x_raw;
    box_.wrap(x);
    for (int a = 0; a < 3; ++a) {
      const Stencil s = face_stencil(x, a);
      const std::size_t au = std::size_t(a);
      for (int k = 0; k < s.count; ++k) {
        const std::size_t f = s.node[k];
        source[au][f] -= impulse[a] * s.weight[k] / (volume * interval_s);
        stats_.deposited_impulse_n_s[a] -= impulse[a] * s.weight[k];
        if (beta <= 0.0) continue;
        const double coefficient = beta * s.weight[k] * response_gain(a, f, read_fraction);
        const double b = coefficient / volume;
        exchange[au][f] += b;
        seen[au][f] += b * velocity[au][f];
        drag_fraction_[au][f] += b * read_fraction;
        response_face_.push_back(std::uint32_t(f));
        response_coefficient_.push_back(coefficient);
      }
      if (response) response->count[au] = std::uint8_t(beta > 0.0 ? s.count : 0);
    }
  };
  response_stencil_.assign(p.size(), ResponseStencil{});
  response_face_.clear(), response_coefficient_.clear();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double beta = effective_beta(p, i, interval_s);
    const double read_fraction = beta > 0.0 ? fluid_at(p.position_m[i]).volume_fraction : 1.0;
    response_stencil_[i].begin = std::uint32_t(response_face_.size());
    push(p.position_m[i], p.fluid_impulse_n_s[i], beta, read_fraction, &response_stencil_[i]);
  }
  for (const Released& r : released_) push(r.position_m, r.impulse_n_s, 0.0, 1.0, nullptr);
  released_.clear();
  // A solved face the particles drag on takes the ε they computed their drag at (weighted as B
  // is): the gas's pressure then falls by the drag over that ε, as in the bed itself. The mean of
  // the two cells would be a bed's end face's 0.71 where its particles sit at 0.42, and the drop
  // over that face would lose 40 % of its drag's share (docs/gas.md).
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    for (std::size_t f = 0; f < g.padded_size; ++f)
      if (exchange[au][f] > 0.0 && g.face[au][f] == FaceKind::Unknown)
        gas.set_face_fraction(a, f, drag_fraction_[au][f] / exchange[au][f]);
  }
}

// How strongly a particle's drag follows face f: its reading of the gas is the superficial
// velocity over its own ε, so a change δu on a face of fraction ε_f moves it by w ε_f/ε δu. The
// implicit response uses max(1, ε_f/ε): never weaker than that (so the exchange stays stable at
// any CFD step where ε jumps, a bed's end), and exactly 1 where the face and the particle share
// their ε. Both sides of the exchange use the same gain, so it conserves momentum whatever it is.
double GasCoupling::response_gain(int a, std::size_t f, double read_fraction) const {
  const double face = incompressible_->mean_face_fraction(a, f);
  return std::max(1.0, face / std::max(read_fraction, 1e-300));
}

// The trilinear stencil of component a's solved faces around x (wrapped). A particle whose
// stencil holds no solved face (inside a wall) exchanges nothing along a.
Stencil GasCoupling::face_stencil(const Vec3& x, int a) const {
  const GasGrid& g = grid();
  const std::size_t au = std::size_t(a);
  return make_stencil(g, x, a, [&](std::size_t f) { return g.face[au][f] == FaceKind::Unknown; });
}

// Gives each particle its share of the gas's implicit drag response: β_eff Σ w g Δ, g the
// response gain and Δ the summed dt (u_new − u_old) of the faces it deposited on; the gas took
// exactly the opposite. The faces and β w g are deposit()'s, read back (the particles have not
// moved since, nor has ε).
void GasCoupling::return_drag_response(ParticleStore& p) {
  if (!incompressible_) return;  // the compressible exchange is explicit
  const std::array<std::vector<double>, 3>& response = incompressible_->drag_response_m();
  const std::uint32_t* face = response_face_.data();
  const double* coefficient = response_coefficient_.data();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const ResponseStencil& stencil = response_stencil_[i];
    if (stencil.count[0] + stencil.count[1] + stencil.count[2] == 0) continue;  // β = 0
    std::uint32_t e = stencil.begin;
    Vec3 impulse;
    for (int a = 0; a < 3; ++a) {
      const double* r = response[std::size_t(a)].data();
      for (int k = 0; k < stencil.count[a]; ++k, ++e) impulse[a] += coefficient[e] * r[face[e]];
    }
    p.motion[i].velocity_m_per_s += impulse * p.inv_mass_per_kg[i];
    stats_.particle_impulse_n_s += impulse;
    stats_.deposited_impulse_n_s -= impulse;
  }
}

std::optional<std::string> GasCoupling::advance(ParticleStore& p, double dem_step_s,
                                                std::int64_t step_index) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  // The gas catches up over the interval the particles just lived through, with the impulse
  // they took in it (the first call, before any interval, settles the initial pressure over
  // one DEM step).
  const bool first = stats_.cfd_steps == 0;
  const double interval_s = double(first ? 1 : step_index - last_cfd_step_) * dem_step_s;
  if (config_.two_way) deposit(p, interval_s);
  if (first && incompressible_)
    incompressible_->accept_volume_fraction();  // no ∂ε/∂t from the start state
  for (Vec3& j : p.fluid_impulse_n_s) j = {};
  if (incompressible_)
    for (std::vector<double>& r : incompressible_->drag_response_m())
      std::fill(r.begin(), r.end(), 0.0);
  const auto t1 = Clock::now();
  // The gas may need a smaller step than the interval (a CFL limit tightened by the interval's
  // particle exchange): sub-cycle it then.
  const double stable = config_.step_s && !compressible_ ? interval_s : gas_stable_step_s();
  const int substeps = std::max(1, int(std::ceil(interval_s / stable - 1e-9)));
  for (int k = 0; k < substeps; ++k)
    if (auto failure = advance_gas(interval_s / substeps)) return failure;
  const auto t2 = Clock::now();
  if (config_.two_way) return_drag_response(p);
  table_.clear();
  const int steps = choose_steps(dem_step_s);
  last_steps_ = steps;
  last_cfd_step_ = step_index;
  next_cfd_step_ = step_index + steps;
  stats_.cfd_steps += 1;
  stats_.gas_substeps += std::uint64_t(substeps);
  stats_.steps_per_cfd = steps;
  stats_.min_steps_per_cfd = std::min(stats_.min_steps_per_cfd, steps);
  stats_.max_steps_per_cfd = std::max(stats_.max_steps_per_cfd, steps);
  stats_.deposit_seconds += std::chrono::duration<double>(t1 - t0 + (Clock::now() - t2)).count();
  stats_.gas_seconds += std::chrono::duration<double>(t2 - t1).count();
  return std::nullopt;
}

std::optional<std::string> GasCoupling::spin_up(std::uint64_t max_steps) {
  double& done_s = stats_.spin_up_done_s;
  for (std::uint64_t k = 0; k < max_steps && done_s < config_.spin_up_s; ++k) {
    const double dt = std::min(gas_stable_step_s(), config_.spin_up_s - done_s);
    if (auto failure = advance_gas(dt)) return failure;
    done_s += dt;
    ++stats_.spin_up_steps;
  }
  return std::nullopt;
}

// Drag, lift and pressure-gradient force of the particles in slots slot_of(0 .. count−1), added to
// their loads; with `accumulate` each exchange's impulse over `dt` is kept for the gas. The
// settings are read once, before the loop: the table lookup is a call that could change them.
// Blocks of particles run on the engine's threads (parallel/thread_team.h) against the DEM-cell
// table as it stands; a particle whose cell is not filled yet waits. Then the waiting particles'
// cells are filled in slot order (the order one thread would have filled them in) and their
// blocks finish. Each block keeps its own counts and impulse sum; they are combined in block order.
template <class SlotOf>
void GasCoupling::fluid_pass(ParticleStore& p, std::size_t count, SlotOf&& slot_of, double dt,
                             bool accumulate) {
  const bool lift = config_.saffman_lift, pressure = config_.pressure_gradient_force;
  const bool store_force = config_.cache_store == DragCacheStore::Force;
  const double threshold = config_.cache_threshold, threshold2 = threshold * threshold;
  const bool keep = p.has_multi_rate_state;  // the kept force of multi-rate stepping
  const bool slip_correction = config_.slip_correction;
  const bool mach_correction = config_.mach_correction;
  const double gamma = config_.compressible.gas.gamma;
  const GasView gas = view();

  auto apply = [&](std::size_t i, const FluidCellState& st, FluidPassTally& tally) {
    const Vec3 slip = st.velocity_m_per_s - p.motion[i].velocity_m_per_s;
    const double d = 2.0 * p.radius_m[i];
    bool recompute = p.fluid_coefficient_kg_per_s[i] < 0.0 || threshold <= 0.0;
    if (!recompute) {
      // Fig. 5's test, per axis against the stored slip speed (squared: no root per step);
      // and, since the dense-flow laws depend on it as strongly, the same test on ε.
      const Vec3& stored = p.fluid_cached_slip_m_per_s[i];
      const double limit2 = threshold2 * norm2(stored);
      const Vec3 change = slip - stored;
      recompute = change.x * change.x > limit2 || change.y * change.y > limit2 ||
                  change.z * change.z > limit2 || (limit2 == 0.0 && norm2(change) > 0.0) ||
                  std::abs(st.volume_fraction - p.fluid_cached_fraction[i]) >
                      threshold * p.fluid_cached_fraction[i];
    }
    if (recompute) {
      const DragInput in{d, norm(slip), st.volume_fraction, st.density_kg_per_m3,
                         st.viscosity_pa_s};
      const double slip_factor =
          slip_correction ? 1.0 / cunningham_correction(d, st.mean_free_path_m) : 1.0;
      // Loth's correction from the slip Mach number (it changes with the slip: the slope below).
      auto mach_factor = [&](const DragInput& at) {
        return mach_correction && st.sound_speed_m_per_s > 0.0
                   ? loth_mach_factor(particle_reynolds(at),
                                      at.slip_speed_m_per_s / st.sound_speed_m_per_s,
                                      st.mean_free_path_m / d, gamma)
                   : 1.0;
      };
      const double factor = mach_factor(in);
      if (st.sound_speed_m_per_s > 0.0) {
        const double mach = in.slip_speed_m_per_s / st.sound_speed_m_per_s;
        tally.max_mach = std::max(tally.max_mach, mach);
        tally.max_knudsen = std::max(tally.max_knudsen, 2.0 * st.mean_free_path_m / d);
        tally.past_mach += mach > 0.3 ? 1 : 0;
        tally.max_mach_factor = std::max(tally.max_mach_factor, factor);
      }
      const double beta = drag_coefficient_kg_per_s(config_.drag, in) * slip_factor * factor;
      // β's slope in the squared slip speed, so the cached β follows the slip to first order
      // between evaluations (a second evaluation at 0.1 % more slip; only when caching).
      double slope = 0.0;
      if (threshold > 0.0 && !store_force && in.slip_speed_m_per_s > 0.0) {
        DragInput faster = in;
        faster.slip_speed_m_per_s *= 1.001;
        const double ds2 = norm2(slip) * (1.001 * 1.001 - 1.0);
        const double faster_beta =
            drag_coefficient_kg_per_s(config_.drag, faster) * slip_factor * mach_factor(faster);
        slope = (faster_beta - beta) / ds2;
      }
      p.fluid_coefficient_slope[i] = slope;
      const Vec3 lift_force = lift ? saffman_lift_n(d, slip, st.vorticity_per_s,
                                                    st.density_kg_per_m3, st.viscosity_pa_s)
                                   : Vec3{};
      p.fluid_coefficient_kg_per_s[i] = beta;
      p.fluid_cached_slip_m_per_s[i] = slip;
      p.fluid_cached_fraction[i] = st.volume_fraction;
      p.fluid_cached_force_n[i] = store_force ? slip * beta + lift_force : lift_force;
      ++tally.evaluations;
    }
    const double beta_now =
        p.fluid_coefficient_kg_per_s[i] +
        p.fluid_coefficient_slope[i] * (norm2(slip) - norm2(p.fluid_cached_slip_m_per_s[i]));
    const Vec3 exchange =
        store_force ? p.fluid_cached_force_n[i] : slip * beta_now + p.fluid_cached_force_n[i];
    Vec3 force = exchange;
    if (pressure) force -= st.pressure_gradient_pa_per_m * (std::numbers::pi / 6.0 * d * d * d);
    p.load[i].force_n += force;
    if (keep) p.fluid_held_force_n[i] = force, p.fluid_held_exchange_n[i] = exchange;
    if (accumulate) {
      p.fluid_impulse_n_s[i] += exchange * dt;
      tally.impulse_n_s += exchange * dt;
    }
  };
  auto wrapped_position = [&](std::size_t i) {
    Vec3 x = p.position_m[i];
    box_.wrap(x);
    return x;
  };

  const std::size_t block_size = block_items(4096);
  const std::size_t blocks = (count + block_size - 1) / block_size;
  pass_tally_.assign(blocks, {});
  pass_missed_.resize(count);
  const FluidPassTally start{
      0, 0, stats_.max_slip_mach, stats_.max_knudsen, stats_.max_mach_drag_factor, {}, 0};
  parallel_ranges(count, block_size, [&](std::size_t begin, std::size_t end, std::size_t block) {
    FluidPassTally tally = start;
    FluidCellRef last;
    for (std::size_t k = begin; k < end; ++k) {
      const std::size_t i = slot_of(k);
      const FluidCellState* st = table_.find(wrapped_position(i), p.fluid_cell[i], last);
      if (st)
        apply(i, *st, tally);
      else
        pass_missed_[begin + tally.missed++] = std::uint32_t(k);
    }
    pass_tally_[block] = tally;
  });
  // The missing cells take their places in slot order (the order one thread would have filled
  // them in), then their states are averaged on the threads.
  bool any_missed = false;
  for (std::size_t block = 0; block < blocks; ++block) {
    const std::uint32_t* missed = pass_missed_.data() + block * block_size;
    for (std::size_t m = 0; m < pass_tally_[block].missed; ++m) {
      const std::size_t i = slot_of(missed[m]);
      table_.reserve(wrapped_position(i), p.fluid_cell[i]);
      any_missed = true;
    }
  }
  if (any_missed) table_.fill_pending(gas, lift);
  auto finish_block = [&](std::size_t block) {
    const std::uint32_t* missed = pass_missed_.data() + block * block_size;
    for (std::size_t m = 0; m < pass_tally_[block].missed; ++m) {
      const std::size_t i = slot_of(missed[m]);
      apply(i, table_.state(p.fluid_cell[i].state), pass_tally_[block]);
    }
  };
  if (any_missed && worth_threads(count))
    parallel_blocks(blocks, finish_block);
  else if (any_missed)
    for (std::size_t block = 0; block < blocks; ++block) finish_block(block);

  std::uint64_t evaluations = 0;
  for (const FluidPassTally& t : pass_tally_) {
    evaluations += t.evaluations;
    stats_.drag_evaluations_past_mach_0_3 += t.past_mach;
    stats_.max_slip_mach = std::max(stats_.max_slip_mach, t.max_mach);
    stats_.max_knudsen = std::max(stats_.max_knudsen, t.max_knudsen);
    stats_.max_mach_drag_factor = std::max(stats_.max_mach_drag_factor, t.max_mach_factor);
    stats_.particle_impulse_n_s += t.impulse_n_s;
  }
  stats_.drag_evaluations += evaluations;
  stats_.drag_reuses += count - evaluations;
}

void GasCoupling::add_held_impulse(const Vec3& impulse_n_s) {
  stats_.particle_impulse_n_s += impulse_n_s;
}

void GasCoupling::add_fluid_forces(ParticleStore& p, double dt, bool accumulate) {
  fluid_pass(
      p, p.size(), [](std::size_t k) { return k; }, dt, accumulate);
}

void GasCoupling::add_fluid_forces(ParticleStore& p, const std::vector<std::uint32_t>& slots,
                                   double dt) {
  const std::uint32_t* slot = slots.data();
  fluid_pass(
      p, slots.size(), [slot](std::size_t k) { return std::size_t(slot[k]); }, dt, true);
}

}  // namespace millsim
