#include "dust/dust_ledger.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/lanes.h"
#include "gas/drag.h"
#include "parallel/thread_team.h"

namespace millsim {

std::vector<DustClass> dust_classes(const std::vector<double>& edges, double threshold,
                                    double density, double viscosity, double mean_free_path) {
  const auto with_tau = [&](double d) {
    const double slip = mean_free_path > 0.0 ? cunningham_correction(d, mean_free_path) : 1.0;
    return DustClass{d, density * d * d * slip / (18.0 * viscosity)};
  };
  std::vector<DustClass> classes;
  const double first = edges.front();
  const double width = edges.size() > 1 ? edges[1] / edges[0] : 2.0;
  classes.push_back(with_tau(std::min(first, threshold) / std::sqrt(width)));
  for (std::size_t k = 0; k + 1 < edges.size() && edges[k] < threshold; ++k)
    classes.push_back(with_tau(std::sqrt(edges[k] * std::min(edges[k + 1], threshold))));
  return classes;
}

double dust_mean_free_path_m(const GasConfig& gas) {
  if (gas.model != GasModel::Compressible || !gas.slip_correction) return 0.0;
  const CompressibleGasConfig& state = gas.compressible;
  return mean_free_path_m(
      gas.viscosity_pa_s, state.initial_pressure_pa,
      state.gas.density_kg_per_m3(state.initial_pressure_pa, state.initial_temperature_k));
}

int dust_class_of(const std::vector<double>& edges, int class_count, double d) {
  if (d < edges.front()) return 0;
  const int bin = int(std::upper_bound(edges.begin(), edges.end(), d) - edges.begin()) - 1;
  return std::min(bin + 1, class_count - 1);
}

DustLedger::DustLedger(const GasGrid& grid, std::vector<DustClass> classes,
                       const Vec3& gravity_m_per_s2, DustFaceLayout layout)
    : grid_(&grid), classes_(std::move(classes)), gravity_m_per_s2_(gravity_m_per_s2) {
  mass_.assign(classes_.size(), std::vector<double>(grid.padded_size, 0.0));
  outflow_kg_.assign(classes_.size(), 0.0);
  velocity_.assign(grid.padded_size, Vec3{});
  previous_velocity_ = velocity_;
  stats_.max_slip_m_per_s.assign(classes_.size(), 0.0);
  stats_.speed_bounded_cells.assign(classes_.size(), 0);
  build_faces(layout);
}

// Every face the dust may cross: between two fluid cells (across a periodic boundary too), or an
// outflow face with fluid on one side. Walls, inlets and solids are left out: they pass nothing.
// The interior faces of an axis without periodic wrap become its rows (RowAxis); the others are
// listed.
void DustLedger::build_faces(DustFaceLayout layout) {
  const GasGrid& g = *grid_;
  // A fluid cell's neighbours lie inside the padded grid; padded_size marks one not fluid.
  const auto fluid_or_none = [&](std::size_t c) { return g.fluid[c] ? c : g.padded_size; };
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a), s = g.stride[au];
    RowAxis& row = rows_[au];
    row.on = layout == DustFaceLayout::Rows && !g.periodic[au] && g.padded_size > 3 * s;
    if (row.on) {
      // An interior face's cells lie inside the ghost layers, so c − s and c + 2s exist.
      row.stride = s;
      row.begin = s;
      row.end = g.padded_size - 2 * s;
      row.interior.assign(g.padded_size, 0);
      row.slope_plus.assign(g.padded_size, 0);
      row.slope_minus.assign(g.padded_size, 0);
      row.gas_speed.assign(g.padded_size, 0.0);
    }
    for (std::size_t f = 0; f + s < g.padded_size; ++f) {
      const FaceKind kind = g.face[au][f];
      if (kind == FaceKind::None || kind == FaceKind::Periodic || kind == FaceKind::Solid) continue;
      const std::size_t low = g.wrap_cell(f, a), high = g.wrap_cell(f + s, a);
      const bool fluid_low = g.fluid[low] != 0, fluid_high = g.fluid[high] != 0;
      if (fluid_low && fluid_high && row.on) {
        row.interior[f] = 1;
        row.slope_plus[f] = g.fluid[f - s];
        row.slope_minus[f] = g.fluid[f + 2 * s];
      } else if (fluid_low && fluid_high) {
        // The cells beyond each side, for the limited slope (none beyond a wall or an outlet).
        faces_.push_back({f, low, high, fluid_or_none(g.wrap_cell(low - s, a)),
                          fluid_or_none(g.wrap_cell(high + s, a)), a, false, false});
      } else if (kind == FaceKind::Outflow && (fluid_low || fluid_high)) {
        faces_.push_back({f, low, high, g.padded_size, g.padded_size, a, fluid_low, fluid_high});
      }
    }
  }
  gas_face_speed_.assign(faces_.size(), 0.0);
  // The interior faces first, then the outflow faces (the passes treat them apart), each in the
  // grid's order; the passes' copy holds 32-bit cells.
  if (g.padded_size + 1 >= std::size_t(kNoSlot))
    throw std::length_error("dust ledger: the gas grid has too many cells for 32-bit indices");
  std::stable_partition(faces_.begin(), faces_.end(),
                        [](const Face& face) { return !face.outflow_low && !face.outflow_high; });
  for (const Face& face : faces_) {
    pass_faces_.push_back({std::uint32_t(face.low), std::uint32_t(face.high),
                           std::uint32_t(face.below), std::uint32_t(face.above)});
    if (!face.outflow_low && !face.outflow_high) ++interior_faces_;
  }
  // Each axis's listed interior faces, one run (they were found axis by axis).
  for (std::size_t f = 0; f < interior_faces_; ++f) {
    const std::size_t a = std::size_t(faces_[f].axis);
    if (listed_end_[a] == 0) listed_begin_[a] = f;
    listed_end_[a] = f + 1;
  }
  fluid_slot_.assign(g.padded_size, kNoSlot);
  for (std::size_t c = 0; c < g.padded_size; ++c)
    if (g.fluid[c]) {
      fluid_slot_[c] = std::uint32_t(fluid_cells_.size());
      fluid_cells_.push_back(c);
    }
  slip_terms_.assign(fluid_cells_.size(), SlipTerms{});
}

std::size_t DustLedger::containing_cell(const Vec3& x) const {
  const GasGrid& g = *grid_;
  int idx[3];
  for (int a = 0; a < 3; ++a)
    idx[a] = std::clamp(int(std::floor((x[a] - g.origin_m[a]) / g.h_m[a])) + 1, 1, g.n[a]);
  return g.index(idx[0], idx[1], idx[2]);
}

// The nearest fluid cell by centre distance: within two cells of x's cell, else anywhere.
std::size_t DustLedger::nearest_fluid_cell(const Vec3& x) const {
  const GasGrid& g = *grid_;
  const std::array<int, 3> home = g.coords(containing_cell(x));
  std::size_t best = g.padded_size;
  double best_d2 = std::numeric_limits<double>::infinity();
  const auto consider = [&](int i, int j, int k) {
    const std::size_t n = g.index(i, j, k);
    if (!g.fluid[n]) return;
    const double d2 = norm2(g.cell_center(i, j, k) - x);
    if (d2 < best_d2) best_d2 = d2, best = n;
  };
  for (int reach : {2, std::max({g.n[0], g.n[1], g.n[2]})}) {
    for (int k = std::max(1, home[2] - reach); k <= std::min(g.n[2], home[2] + reach); ++k)
      for (int j = std::max(1, home[1] - reach); j <= std::min(g.n[1], home[1] + reach); ++j)
        for (int i = std::max(1, home[0] - reach); i <= std::min(g.n[0], home[0] + reach); ++i)
          consider(i, j, k);
    if (best != g.padded_size) break;
  }
  return best;
}

void DustLedger::deposit(const Vec3& x, int k, double mass_kg) {
  std::size_t c = containing_cell(x);
  ++stats_.deposits;
  if (!grid_->fluid[c]) {
    c = nearest_fluid_cell(x);
    ++stats_.displaced_deposits;
    if (c == grid_->padded_size) {  // a grid without a fluid cell: nothing can hold it
      unplaced_kg_ += mass_kg;
      return;
    }
  }
  mass_[std::size_t(k)][c] += mass_kg;
}

void DustLedger::move_between_classes(std::size_t c, int k, double kg,
                                      const std::vector<double>& shares) {
  mass_[std::size_t(k)][c] -= kg;
  for (std::size_t j = 0; j < shares.size(); ++j)
    if (shares[j] > 0.0) mass_[j][c] += kg * shares[j];
}

void DustLedger::update_acceleration(const GasView& gas, double now_s) {
  const GasGrid& g = *grid_;
  double fastest2 = 0.0;
  for (const std::size_t c : fluid_cells_) {
    velocity_[c] = gas.cell_velocity_m_per_s(c);
    fastest2 = std::max(fastest2, norm2(velocity_[c]));
  }
  max_gas_speed_m_per_s_ = std::sqrt(fastest2);
  const double dt = now_s - previous_time_s_;
  const bool unsteady = have_previous_ && dt > 0.0;
  for (std::size_t slot = 0; slot < fluid_cells_.size(); ++slot) {
    const std::size_t c = fluid_cells_[slot];
    const Vec3& u = velocity_[c];
    // (u·∇)u by central differences, one-sided next to a wall, 0 across a cell with no fluid
    // on either side.
    Vec3 convective;
    std::array<Vec3, 3> gradient{};  // column a: ∂u/∂x_a
    for (int a = 0; a < 3; ++a) {
      const std::size_t s = g.stride[std::size_t(a)];
      const std::size_t lo = g.wrap_cell(c - s, a), hi = g.wrap_cell(c + s, a);
      const bool has_lo = g.fluid[lo] != 0, has_hi = g.fluid[hi] != 0;
      if (!has_lo && !has_hi) continue;
      const Vec3& u_lo = has_lo ? velocity_[lo] : u;
      const Vec3& u_hi = has_hi ? velocity_[hi] : u;
      const double span = (has_lo && has_hi ? 2.0 : 1.0) * g.h_m[a];
      gradient[std::size_t(a)] = (u_hi - u_lo) * (1.0 / span);
      convective += gradient[std::size_t(a)] * u[a];
    }
    Vec3 du_dt = convective;
    if (unsteady) du_dt += (u - previous_velocity_[c]) * (1.0 / dt);
    slip_terms_[slot] = slip_terms(gravity_m_per_s2_ - du_dt, gradient);
    slip_terms_[slot].slip_bound = norm(u) + max_gas_speed_m_per_s_;
  }
  previous_velocity_ = velocity_;
  previous_time_s_ = now_s;
  have_previous_ = true;
}

// G's invariants and the vectors the slip of any τ is made of. With M = I + τ G, Cayley–Hamilton
// gives det M = 1 + τ tr G + τ² c₂ + τ³ det G (c₂ the sum of G's principal 2 × 2 minors) and
// adj M = (1 + τ tr G + τ² c₂) I − τ (1 + τ tr G) G + τ² G², so M⁻¹ a needs only a, G a and G² a.
DustLedger::SlipTerms DustLedger::slip_terms(const Vec3& acceleration,
                                             const std::array<Vec3, 3>& gradient) {
  // G_ij = ∂u_i/∂x_j = gradient[j][i].
  const auto G = [&](int i, int j) { return gradient[std::size_t(j)][i]; };
  const auto times_g = [&](const Vec3& v) {
    return gradient[0] * v[0] + gradient[1] * v[1] + gradient[2] * v[2];
  };
  SlipTerms t;
  t.a = acceleration;
  t.ga = times_g(acceleration);
  t.gga = times_g(t.ga);
  t.trace = G(0, 0) + G(1, 1) + G(2, 2);
  t.minors = G(0, 0) * G(1, 1) - G(0, 1) * G(1, 0) + G(0, 0) * G(2, 2) - G(0, 2) * G(2, 0) +
             G(1, 1) * G(2, 2) - G(1, 2) * G(2, 1);
  t.det = G(0, 0) * (G(1, 1) * G(2, 2) - G(1, 2) * G(2, 1)) -
          G(0, 1) * (G(1, 0) * G(2, 2) - G(1, 2) * G(2, 0)) +
          G(0, 2) * (G(1, 0) * G(2, 1) - G(1, 1) * G(2, 0));
  t.norm = std::sqrt(norm2(gradient[0]) + norm2(gradient[1]) + norm2(gradient[2]));
  return t;
}

// The slip w of class τ: (I + τ ∇u) w = τ (g − Du/Dt), the locally implicit equilibrium
// velocity (Ferry, Rani & Balachandar 2003), from the cell's invariants above. Where I + τ ∇u is
// near singular (det ≤ 0.1: a strong compression at large τ), w = τ a / (1 + τ |∇u|). Never
// longer than the explicit slip τ |a|: near that singularity the implicit form amplifies it
// (2.3 km/s for the mill's 8.9 µm dust before this bound).
Vec3 DustLedger::slip_of(const SlipTerms& t, double tau) {
  const Vec3 rhs = t.a * tau;
  const double first = 1.0 + tau * t.trace, second = first + tau * tau * t.minors;
  const double det = second + tau * tau * tau * t.det;
  if (!(det > 0.1)) return rhs * (1.0 / (1.0 + tau * t.norm));
  Vec3 w = (t.a * second - t.ga * (tau * first) + t.gga * (tau * tau)) * (tau / det);
  const double explicit2 = norm2(rhs), implicit2 = norm2(w);
  if (implicit2 > explicit2) w *= std::sqrt(explicit2 / implicit2);
  return w;
}

Vec3 DustLedger::bounded_slip(std::size_t slot, double tau, bool& bounded) const {
  const SlipTerms& terms = slip_terms_[slot];
  const Vec3 w = slip_of(terms, tau);
  const double bound = terms.slip_bound + tau * norm(gravity_m_per_s2_), w2 = norm2(w);
  if (!(w2 > bound * bound)) return w;
  bounded = true;
  return w * (bound / std::sqrt(w2));
}

Vec3 DustLedger::slip_m_per_s(std::size_t c, double tau) const {
  const std::uint32_t slot = fluid_slot_[c];
  bool bounded = false;
  return slot == kNoSlot || !(tau > 0.0) ? Vec3{} : bounded_slip(slot, tau, bounded);
}

void DustLedger::advance(const GasView& gas, double dt_s) {
  ++stats_.advances;
  update_acceleration(gas, gas.time_s());
  // The gas's own speed through each face, the same for every class.
  for (std::size_t f = 0; f < faces_.size(); ++f) {
    const Face& face = faces_[f];
    gas_face_speed_[f] = gas.face_velocity_m_per_s(face.axis, face.face, face.low, face.high);
  }
  for (int a = 0; a < 3; ++a) {
    RowAxis& row = rows_[std::size_t(a)];
    if (!row.on) continue;
    for (std::size_t c = row.begin; c < row.end; ++c)
      if (row.interior[c]) row.gas_speed[c] = gas.face_velocity_m_per_s(a, c, c, c + row.stride);
  }
  // The classes are carried independently, each by one thread into its own mass, outflow and
  // counters, so the result is the same on any thread count.
  class_substeps_.assign(classes_.size(), 0);
  class_fastest_rate_.assign(classes_.size(), 0.0);
  parallel_blocks_if(worth_threads(classes_.size() * fluid_cells_.size()), classes_.size(),
                     [&](std::size_t k) {
                       static thread_local ClassScratch scratch;  // the running thread's own
                       carry_class(k, dt_s, scratch);
                     });
  for (const std::uint64_t n : class_substeps_) stats_.substeps += n;
  fastest_rate_per_s_ = 0.0;
  for (const double rate : class_fastest_rate_)
    fastest_rate_per_s_ = std::max(fastest_rate_per_s_, rate);
}

// Class k over dt_s: its slip per cell, its speed through each face, the sub-steps its fastest
// cell needs, and Heun's method over them. `scratch` holds nothing between calls.
//
// Every sum over a cell's faces runs in the order of the faces' list before the rows existed:
// axis by axis, within an axis by face (the face below a cell before the face above it), the
// outflow faces last. A row face that is not interior adds 0, which changes no sum, so the
// result is the same to the bit.
void DustLedger::carry_class(std::size_t k, double dt_s, ClassScratch& scratch) {
  const GasGrid& g = *grid_;
  const double tau = classes_[k].relaxation_time_s;
  for (std::vector<double>& component : scratch.slip) component.resize(g.padded_size);
  scratch.face_rate.resize(faces_.size());
  // Per cell: Σ outgoing speed / h, for the step bound.
  scratch.outgoing_rate.assign(g.padded_size, 0.0);
  double max_slip2 = 0.0;  // (the largest |w|², its root taken once: the same as the largest |w|)
  std::uint64_t bounded_cells = 0;
  for (std::size_t slot = 0; slot < fluid_cells_.size(); ++slot) {
    bool bounded = false;
    const Vec3 w = tau > 0.0 ? bounded_slip(slot, tau, bounded) : Vec3{};
    const std::size_t c = fluid_cells_[slot];
    for (int a = 0; a < 3; ++a) scratch.slip[std::size_t(a)][c] = w[a];
    max_slip2 = std::max(max_slip2, norm2(w));
    bounded_cells += bounded ? 1 : 0;
  }
  stats_.speed_bounded_cells[k] += bounded_cells;
  double& max_slip = stats_.max_slip_m_per_s[k];
  max_slip = std::max(max_slip, std::sqrt(max_slip2));
  const double inverse_h[3] = {1.0 / g.h_m[0], 1.0 / g.h_m[1], 1.0 / g.h_m[2]};
  double* outgoing = scratch.outgoing_rate.data();
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    const RowAxis& row = rows_[au];
    if (row.on) {
      // Outside its faces a row's rate and transfer are 0 (the scratch may have served another
      // grid before).
      std::vector<double>& rate = scratch.row_rate[au];
      for (std::vector<double>* v : {&rate, &scratch.row_transfer[au]}) {
        v->resize(g.padded_size);
        std::fill(v->begin(), v->begin() + std::ptrdiff_t(row.begin), 0.0);
        std::fill(v->begin() + std::ptrdiff_t(row.end), v->end(), 0.0);
      }
      const std::size_t s = row.stride;
      const std::uint8_t* interior = row.interior.data();
      const double* gas_speed = row.gas_speed.data();
      const double* slip = scratch.slip[au].data();
      double* r = rate.data();
      const Lanes half = splat_lanes(0.5), per_h = splat_lanes(inverse_h[a]), zero{};
      std::size_t c = row.begin;
      for (; c + kLanes <= row.end; c += kLanes) {
        const Lanes speed =
            load_lanes(gas_speed + c) + half * (load_lanes(slip + c) + load_lanes(slip + c + s));
        store_lanes(r + c, select_lanes(load_flag_lanes(interior + c), speed * per_h, zero));
      }
      for (; c < row.end; ++c) {
        const double speed = gas_speed[c] + 0.5 * (slip[c] + slip[c + s]);
        r[c] = interior[c] ? speed * inverse_h[a] : 0.0;  // 1/s, signed as the speed
      }
      // A cell's outgoing rate: through the face below it (flow along −), then the one above.
      c = s;
      for (; c + kLanes + s <= g.padded_size; c += kLanes) {
        const Lanes below = load_lanes(r + c - s), above = load_lanes(r + c);
        const Lanes gained = load_lanes(outgoing + c) + select_lanes(below > zero, zero, -below);
        store_lanes(outgoing + c, gained + select_lanes(above > zero, above, zero));
      }
      for (; c + s < g.padded_size; ++c) {
        outgoing[c] += r[c - s] > 0.0 ? 0.0 : -r[c - s];
        outgoing[c] += r[c] > 0.0 ? r[c] : 0.0;
      }
      continue;
    }
    for (std::size_t f = listed_begin_[au]; f < listed_end_[au]; ++f) {
      const Face& face = faces_[f];
      const double speed =
          gas_face_speed_[f] + 0.5 * (scratch.slip[au][face.low] + scratch.slip[au][face.high]);
      const double rate = speed * inverse_h[a];  // 1/s, signed as the speed
      scratch.face_rate[f] = rate;
      outgoing[speed > 0.0 ? face.low : face.high] += std::abs(rate);
    }
  }
  for (std::size_t f = interior_faces_; f < faces_.size(); ++f) {  // outflow: fluid on one side
    const Face& face = faces_[f];
    const int a = face.axis;
    double speed =
        gas_face_speed_[f] + scratch.slip[std::size_t(a)][face.outflow_low ? face.low : face.high];
    // An outflow face carries dust out only.
    if (face.outflow_low && speed < 0.0) speed = 0.0;
    if (face.outflow_high && speed > 0.0) speed = 0.0;
    const double rate = speed * inverse_h[a];
    scratch.face_rate[f] = rate;
    outgoing[speed > 0.0 ? face.low : face.high] += std::abs(rate);
  }
  double fastest = 0.0;  // 1/s: the largest share of a cell's mass leaving per second
  for (const std::size_t c : fluid_cells_) fastest = std::max(fastest, outgoing[c]);
  const int substeps = std::max(1, int(std::ceil(dt_s * fastest / 0.5 - 1e-12)));
  const double h = dt_s / substeps;
  class_substeps_[k] = std::uint64_t(substeps);
  class_fastest_rate_[k] = fastest;
  // Heun's method (SSP-RK2): each stage a conservative, positive flux pass, their mean the
  // step, so what left is the mean of the stages' outflows. Cells without fluid hold nothing.
  std::vector<double>& m = mass_[k];
  for (int step = 0; step < substeps; ++step) {
    scratch.start = m;
    const double out_first = flux_pass(scratch, scratch.start, m, h);
    scratch.stage = m;
    const double out_second = flux_pass(scratch, scratch.stage, m, h);
    mean_into(scratch.start, m);
    outflow_kg_[k] += 0.5 * (out_first + out_second);
  }
}

// m = ½ (start + m) in every padded cell: a cell without fluid holds the same in both (no face
// moves its mass), and ½ (x + x) is x exactly.
void DustLedger::mean_into(const std::vector<double>& start, std::vector<double>& m) {
  const Lanes half = splat_lanes(0.5);
  std::size_t c = 0;
  for (; c + kLanes <= m.size(); c += kLanes)
    store_lanes(m.data() + c, half * (load_lanes(start.data() + c) + load_lanes(m.data() + c)));
  for (; c < m.size(); ++c) m[c] = 0.5 * (start[c] + m[c]);
}

// Each face carries the mass of its upwind cell, reconstructed to the face with van Leer's
// limited slope (first order at outlets and where the cell beyond is not fluid). Van Leer's
// φ(r) = (r + |r|)/(1 + |r|), r the ratio of the upwind to the downwind difference, adds
// ½ φ(r) × (downwind difference) to the upwind value: in its harmonic-mean form, u d / (u + d)
// where the differences u and d have one sign, else 0 (at an extremum). The face value lies in
// [0, 2 m_upwind], so with the outgoing Courant sum ≤ 0.5 no cell gives more than it holds.
//
// A row's transfers, from `from` alone, without a branch on the flow's direction: a face's
// upwind, downwind and beyond cells are chosen by the sign of its rate.
void DustLedger::row_transfers(const RowAxis& row, const std::vector<double>& rate,
                               std::vector<double>& transfer, const std::vector<double>& from,
                               double dt_s) const {
  const std::size_t s = row.stride;
  const double* m = from.data();
  const double* r = rate.data();
  const std::uint8_t* slope_plus = row.slope_plus.data();
  const std::uint8_t* slope_minus = row.slope_minus.data();
  double* t = transfer.data();
  std::size_t c = row.begin;
  const Lanes zero{}, step = splat_lanes(dt_s);
  for (; c + kLanes <= row.end; c += kLanes) {
    const Lanes face_rate = load_lanes(r + c);
    const LaneMask forward = face_rate > zero;
    const Lanes low = load_lanes(m + c), high = load_lanes(m + c + s);
    const Lanes up = select_lanes(forward, low, high), down = select_lanes(forward, high, low);
    const Lanes beyond = select_lanes(forward, load_lanes(m + c - s), load_lanes(m + c + 2 * s));
    const LaneMask sloped =
        select_masks(forward, load_flag_lanes(slope_plus + c), load_flag_lanes(slope_minus + c));
    const Lanes upwind_difference = up - beyond, downwind_difference = down - up;
    const Lanes product = upwind_difference * downwind_difference;
    const Lanes value = select_lanes(sloped & (product > zero),
                                     up + product / (upwind_difference + downwind_difference), up);
    store_lanes(t + c, value * (face_rate * step));  // kg from c to c + s
  }
  for (; c < row.end; ++c) {  // the same operations, one face at a time
    const bool forward = r[c] > 0.0;
    const double up = forward ? m[c] : m[c + s], down = forward ? m[c + s] : m[c];
    const double beyond = forward ? m[c - s] : m[c + 2 * s];
    const bool sloped = (forward ? slope_plus[c] : slope_minus[c]) != 0;
    const double upwind_difference = up - beyond, downwind_difference = down - up;
    const double product = upwind_difference * downwind_difference;
    const double value =
        sloped && product > 0.0 ? up + product / (upwind_difference + downwind_difference) : up;
    t[c] = value * (r[c] * dt_s);
  }
}

// What a row's transfers do to `to`: each cell gains what came through the face below it and
// loses what left through the face above (the order of the faces' list).
void DustLedger::apply_row(const RowAxis& row, const std::vector<double>& transfer,
                           std::vector<double>& to) const {
  const std::size_t s = row.stride, end = to.size() - s;
  const double* t = transfer.data();  // 0 outside [begin, end)
  double* m = to.data();
  std::size_t c = s;
  for (; c + kLanes <= end; c += kLanes)
    store_lanes(m + c, load_lanes(m + c) + load_lanes(t + c - s) - load_lanes(t + c));
  for (; c < end; ++c) m[c] = m[c] + t[c - s] - t[c];
}

// The listed faces' transfers (a periodic axis), each from `from` alone.
void DustLedger::listed_transfers(std::size_t begin, std::size_t end,
                                  const std::vector<double>& face_rate,
                                  std::vector<double>& transfer, const std::vector<double>& from,
                                  double dt_s) const {
  const std::uint32_t none = std::uint32_t(grid_->padded_size);
  for (std::size_t f = begin; f < end; ++f) {
    const double rate = face_rate[f];  // signed: > 0 from low to high
    const PassFace& face = pass_faces_[f];
    const bool forward = rate > 0.0;
    const std::uint32_t up = forward ? face.low : face.high;
    const std::uint32_t down = forward ? face.high : face.low;
    const std::uint32_t beyond = forward ? face.below : face.above;
    double value = from[up];
    if (beyond != none) {
      const double upwind_difference = value - from[beyond];
      const double downwind_difference = from[down] - value;
      if (upwind_difference * downwind_difference > 0.0)
        value +=
            upwind_difference * downwind_difference / (upwind_difference + downwind_difference);
    }
    transfer[f] = value * (rate * dt_s);  // kg from low to high
  }
}

// One forward-Euler pass over dt_s, axis by axis: the faces' transfers are found first, each
// from `from` alone, and then applied to `to` (applied as they are found, each face's update of
// a cell would wait for the one before it, a chain through the limiter's division). A row adds
// to each cell what came through the face below it, then takes what left through the face
// above: the order of the faces' list. Returns the mass that left through outflow faces.
double DustLedger::flux_pass(ClassScratch& scratch, const std::vector<double>& from,
                             std::vector<double>& to, double dt_s) const {
  scratch.transfer.resize(pass_faces_.size());
  for (std::size_t a = 0; a < 3; ++a) {
    const RowAxis& row = rows_[a];
    if (row.on) {
      row_transfers(row, scratch.row_rate[a], scratch.row_transfer[a], from, dt_s);
      apply_row(row, scratch.row_transfer[a], to);
      continue;
    }
    listed_transfers(listed_begin_[a], listed_end_[a], scratch.face_rate, scratch.transfer, from,
                     dt_s);
    for (std::size_t f = listed_begin_[a]; f < listed_end_[a]; ++f) {
      const PassFace& face = pass_faces_[f];
      to[face.low] -= scratch.transfer[f];
      to[face.high] += scratch.transfer[f];
    }
  }
  // Outflow faces, first order: out of the fluid side only (their rate points out or is 0).
  double left = 0.0;
  for (std::size_t f = interior_faces_; f < pass_faces_.size(); ++f) {
    const PassFace& face = pass_faces_[f];
    const double rate = scratch.face_rate[f];
    const std::uint32_t up = rate > 0.0 ? face.low : face.high;
    const double moved = from[up] * (std::abs(rate) * dt_s);
    to[up] -= moved;
    left += moved;
  }
  return left;
}

void DustLedger::density_kg_per_m3(std::vector<double>& out) const {
  out.assign(grid_->padded_size, 0.0);
  const double inverse_volume = 1.0 / grid_->cell_volume_m3();
  parallel_ranges_if(worth_threads(classes_.size() * fluid_cells_.size()), fluid_cells_.size(),
                     block_items(4096), [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t i = begin; i < end; ++i) {
                         const std::size_t c = fluid_cells_[i];
                         double sum = 0.0;
                         for (const std::vector<double>& m : mass_) sum += m[c];
                         out[c] = sum * inverse_volume;
                       }
                     });
}

double DustLedger::held_kg(int k) const {
  double sum = 0.0;
  for (double v : mass_[std::size_t(k)]) sum += v;
  return sum;
}

double DustLedger::scale_class(int k, double factor) {
  std::vector<double>& mass = mass_[std::size_t(k)];
  const double before = held_kg(k);
  for (double& v : mass) v *= factor;
  const double added = held_kg(k) - before;
  filled_kg_ += added;
  return added;
}

double DustLedger::held_kg() const {
  double sum = unplaced_kg_;
  for (int k = 0; k < class_count(); ++k) sum += held_kg(k);
  return sum;
}

double DustLedger::outflow_kg() const {
  double sum = 0.0;
  for (double v : outflow_kg_) sum += v;
  return sum;
}

}  // namespace millsim
