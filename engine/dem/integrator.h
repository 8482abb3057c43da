// Velocity Verlet in kick–drift–kick form for translation and rotation of spheres, with the
// velocity-dependent forces (damping, friction) evaluated at a predicted full-step velocity:
//   kick_drift:  v½ = v + ½ a dt;  x += v½ dt;  v ← v½ + ½ a dt      (prediction of v(n+1))
//   (forces, from x(n+1) and the predicted velocity; the old forces are kept)
//   kick:        v ← v + ½ dt (a_new − a_old)   (= v½ + ½ a_new dt, velocity Verlet)
// Positions follow velocity Verlet exactly (symplectic for conservative forces). Evaluating the
// damping at v(n+½) instead lags it by half a step, an O(dt) error in the rebound and the
// maximum overlap; the prediction makes it O(dt²) (tests/physics/overlap_sweep_test.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "dem/box.h"
#include "dem/motion_frame.h"

#include "core/vec3.h"
#include "parallel/slot_shares.h"
#include "parallel/thread_team.h"
#include "particles/particle_store.h"

namespace millsim {

// Both kick-drift passes also write the next force pass's starting forces (gravity m·g, no
// torque) into previous_load, which begin_force_pass() then swaps in: the pass is already at
// each particle, so clearing costs no pass over memory of its own.

// Slots per block for the speed report of the kick-drift passes.
inline constexpr std::size_t kSpeedBlockSlots = 4096;

// The chunk size of slot_chunks: the owner shares' unit when they fit, else `chunk`.
inline std::size_t slot_chunk_size(std::size_t n, const SlotShares* shares, std::size_t chunk) {
  return shares && shares->fit(n, std::size_t(thread_count())) ? shares->unit : chunk;
}

// Runs `body(begin, end, c)` over the slots [0, n) in chunks of slot_chunk_size(n, shares,
// chunk): on the owner shares when they fit n and the team (each thread on its own from the
// front, then from the back of the others'), else on the team when n is worth threads.
template <class Body>
void slot_chunks(std::size_t n, const SlotShares* shares, std::size_t chunk, Body&& body) {
  const std::size_t threads = std::size_t(thread_count());
  if (!shares || !shares->fit(n, threads)) return parallel_ranges(n, chunk, body);
  chunk = shares->unit;
  const std::size_t chunks = (n + chunk - 1) / chunk;
  // (Named here, on the calling thread: inside the loop a thread_local would be the worker's.)
  static thread_local std::vector<std::size_t> calling_thread_bounds;
  std::vector<std::size_t>& bounds = calling_thread_bounds;
  shares->unit_bounds(chunks, bounds);
  parallel_blocks_in_shares(chunks, bounds.data(), [&](std::size_t c) {
    const std::size_t begin = c * chunk;
    body(begin, std::min(n, begin + chunk), c);
  });
}

// Runs `kick_particle(i)`, which kicks and drifts particle i and returns |v½|², over every slot,
// in chunks (a block of kSpeedBlockSlots, or a part of one: parallel/thread_team.h,
// block_items; or the owner shares' units) spread over the engine's threads; stores each block's
// largest drift speed and returns the largest of all (maxima: the same for any thread count).
template <class KickParticle>
double kick_in_blocks(std::size_t n, const SlotShares* shares,
                      std::vector<double>& block_max_speed_m_per_s, KickParticle&& kick_particle) {
  const std::size_t blocks = (n + kSpeedBlockSlots - 1) / kSpeedBlockSlots;
  // (Named here, on the calling thread: inside the loop a thread_local would be the worker's.)
  static thread_local std::vector<double> calling_thread_chunk_max;
  std::vector<double>& chunk_max2 = calling_thread_chunk_max;
  const std::size_t chunk = slot_chunk_size(n, shares, block_items(kSpeedBlockSlots));
  chunk_max2.resize((n + chunk - 1) / chunk);
  slot_chunks(n, shares, chunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
    double speed2 = 0.0;
    for (std::size_t i = begin; i < end; ++i) speed2 = std::max(speed2, kick_particle(i));
    chunk_max2[c] = speed2;
  });
  const std::size_t chunks_per_block = kSpeedBlockSlots / chunk;
  block_max_speed_m_per_s.assign(blocks, 0.0);
  double max_speed2 = 0.0;
  for (std::size_t c = 0; c < chunk_max2.size(); ++c) {
    double& block = block_max_speed_m_per_s[c / chunks_per_block];
    block = std::max(block, chunk_max2[c]);
    max_speed2 = std::max(max_speed2, chunk_max2[c]);
  }
  for (double& v : block_max_speed_m_per_s) v = std::sqrt(v);
  return std::sqrt(max_speed2);
}

// Returns the largest drift speed |v½| of the step as `report` counts it (dem/motion_frame.h:
// relative to the list's frame at the position before the drift, scaled per slot), which bounds
// every particle's displacement in that frame in units of its share of the skin, and the largest
// of each block of kSpeedBlockSlots slots in `block_max_speed_m_per_s`, which bounds that block's
// (search/neighbor_list.h). Positions are not wrapped here: the neighbour list wraps
// them when it rebuilds and keeps each pair's periodic image until then.
// `shares`: the last force pass's owner shares (NeighborList::owner_shares), or null.
inline double kick_drift(ParticleStore& p, double dt, const Vec3& gravity,
                         std::vector<double>& block_max_speed_m_per_s, const SpeedReport& report,
                         const SlotShares* shares = nullptr) {
  const double half = 0.5 * dt;
  Vec3* x = p.position_m.data();
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  Load* previous_load = p.previous_load.data();
  const FrameSpeed frame_speed(report);
  return kick_in_blocks(p.size(), shares, block_max_speed_m_per_s, [&](std::size_t i) {
    const Motion m = motion[i];
    const Load l = load[i];
    previous_load[i] = {gravity * p.mass_kg[i], {}};
    const Vec3 dv = l.force_n * (half * p.inv_mass_per_kg[i]);
    const Vec3 v_half = m.velocity_m_per_s + dv;
    const double speed2 = frame_speed.speed2(i, x[i], v_half);
    x[i] += v_half * dt;
    motion[i] = {v_half + dv,
                 m.angular_velocity_rad_per_s + l.torque_n_m * (dt * p.inv_inertia_per_kg_m2[i])};
    return speed2;
  });
}

inline void kick(ParticleStore& p, double dt, const SlotShares* shares = nullptr) {
  const double half = 0.5 * dt;
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  const Load* previous_load = p.previous_load.data();
  slot_chunks(p.size(), shares, block_items(kSpeedBlockSlots),
              [&](std::size_t begin, std::size_t end, std::size_t) {
                for (std::size_t i = begin; i < end; ++i) {
                  const Load l = load[i], l_old = previous_load[i];
                  motion[i].velocity_m_per_s +=
                      (l.force_n - l_old.force_n) * (half * p.inv_mass_per_kg[i]);
                  motion[i].angular_velocity_rad_per_s +=
                      (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
                }
              });
}

// kick of one step and kick_drift of the next in one pass: per particle the same operations in
// the same order, so the same numbers, with the state read once (Simulation::advance). Written
// out rather than calling per-particle helpers shared with kick() and kick_drift(): through the
// store's arrays the compiler then reloads v and ω between the halves, and the pass took 20 %
// longer. tests/engine/determinism_test.cpp holds the two paths to the same bits.
inline double kick_then_kick_drift(ParticleStore& p, double dt, const Vec3& gravity,
                                   std::vector<double>& block_max_speed_m_per_s,
                                   const SpeedReport& report, const SlotShares* shares = nullptr) {
  const double half = 0.5 * dt;
  Vec3* x = p.position_m.data();
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  Load* previous_load = p.previous_load.data();
  const FrameSpeed frame_speed(report);
  return kick_in_blocks(p.size(), shares, block_max_speed_m_per_s, [&](std::size_t i) {
    const Motion m = motion[i];
    const Load l = load[i], l_old = previous_load[i];
    previous_load[i] = {gravity * p.mass_kg[i], {}};
    const double half_inv_mass = half * p.inv_mass_per_kg[i];
    const Vec3 v_end = m.velocity_m_per_s + (l.force_n - l_old.force_n) * half_inv_mass;
    const Vec3 w_end = m.angular_velocity_rad_per_s +
                       (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
    const Vec3 dv = l.force_n * half_inv_mass;
    const Vec3 v_half = v_end + dv;
    const double speed2 = frame_speed.speed2(i, x[i], v_half);
    x[i] += v_half * dt;
    motion[i] = {v_half + dv, w_end + l.torque_n_m * (dt * p.inv_inertia_per_kg_m2[i])};
    return speed2;
  });
}

// Multi-rate stepping (sim/multi_rate.h) advances a list of slots at a time, each list with its
// own step. Per particle these are the operations of kick_drift() and kick() in the same order,
// so a list that holds every slot gives the same numbers as the single-rate passes. The force
// bookkeeping differs: a listed kick-drift copies the particle's forces to previous_load and
// starts its next forces from gravity itself (no swap of whole arrays), so the particles left
// out keep their forces untouched while they wait.

// Entries of a slot list per piece: the unit the listed passes spread over the engine's threads,
// and in which they sum what they sum (so the sums are the same on any thread count).
inline constexpr std::size_t kListPieceEntries = 4096;

// Whether a listed pass runs on the owner shares: they fit `population` and the team, and the
// population is worth threads in the caller's scope (Simulation::min_items_for_threads around
// the stepping particles' passes; a catch-up of a few waiting or riding particles, outside it,
// is not worth a team call per level).
inline bool listed_on_shares(std::size_t population, const SlotShares* shares) {
  return shares && shares->fit(population, std::size_t(thread_count())) &&
         worth_threads(population);
}

// The listed entries of each unit of the owner shares (parallel/slot_shares.h): with `slots`
// ascending, fills entry_begin[u] with the first entry whose slot lies in unit u or above
// (units + 1 offsets, the last = slots.size()) and returns the number of units, or returns 0
// unless listed_on_shares (the caller then cuts the list its own way).
inline std::size_t listed_units(const std::vector<std::uint32_t>& slots, std::size_t population,
                                const SlotShares* shares, std::vector<std::size_t>& entry_begin) {
  if (slots.empty() || !listed_on_shares(population, shares)) return 0;
  const std::size_t units = (population + shares->unit - 1) / shares->unit;
  entry_begin.resize(units + 1);
  const std::uint32_t* first = slots.data();
  const std::uint32_t* last = first + slots.size();
  const std::uint32_t* at = first;
  for (std::size_t u = 0; u < units; ++u) {
    at = std::lower_bound(at, last, std::uint32_t(u * shares->unit));
    entry_begin[u] = std::size_t(at - first);
  }
  entry_begin[units] = slots.size();
  return units;
}

// Runs body(begin, end, piece) over the entries of a slot list (ascending) in pieces: on the
// owner shares' units when listed_on_shares (listed_units: thread t starts on the
// particles it owns in the force pass, so what it writes stays in its core's caches, then takes
// from the back of the others'), else in pieces of kListPieceEntries entries, on the team when
// the list is worth threads. Returns the number of pieces. Nothing done here may sum across
// pieces in an order that depends on the cut (the cut depends on the thread count).
template <class Body>
std::size_t listed_pieces(const std::vector<std::uint32_t>& slots, std::size_t population,
                          const SlotShares* shares, Body&& body);

// Runs speed2 = visit(i) for every listed slot i, in listed_pieces; raises
// block_max_speed2[i / kSpeedBlockSlots] to each speed2 and returns the largest. Maxima are
// exact in any order. Each piece keeps its maxima in registers and writes them once per slot
// block (the lists are in slot order) and once at its end: threads never write one cache line
// per particle.
template <class Visit>
double for_listed_speeds(const std::vector<std::uint32_t>& slots,
                         std::vector<double>& block_max_speed2, Visit&& visit,
                         std::size_t population = 0, const SlotShares* shares = nullptr) {
  const std::size_t n = slots.size();
  // One piece; block_out: its block maxima (raised, never lowered). Returns its largest speed2.
  auto run_piece = [&](std::size_t begin, std::size_t end, double* block_out) {
    double piece_max = 0.0, block_max = 0.0;
    std::size_t block = ~std::size_t(0);
    for (std::size_t k = begin; k < end; ++k) {
      const std::uint32_t i = slots[k];
      const double speed2 = visit(i);
      if (i / kSpeedBlockSlots != block) {
        if (block != ~std::size_t(0)) block_out[block] = std::max(block_out[block], block_max);
        block = i / kSpeedBlockSlots, block_max = 0.0;
      }
      block_max = std::max(block_max, speed2);
      piece_max = std::max(piece_max, speed2);
    }
    if (block != ~std::size_t(0)) block_out[block] = std::max(block_out[block], block_max);
    return piece_max;
  };
  const bool owners = listed_on_shares(population, shares);
  if (!owners && (n <= block_items(kListPieceEntries) || !worth_threads(n))) {
    double max_speed2 = 0.0;
    for (std::size_t begin = 0; begin < n; begin += block_items(kListPieceEntries))
      max_speed2 =
          std::max(max_speed2, run_piece(begin, std::min(n, begin + block_items(kListPieceEntries)),
                                         block_max_speed2.data()));
    return max_speed2;
  }
  const std::size_t blocks = block_max_speed2.size();
  const std::size_t stride = (blocks + 1 + 7) / 8 * 8;  // whole cache lines per piece
  // (Named here, on the calling thread: inside the loop a thread_local would be the worker's.)
  static thread_local std::vector<double> calling_thread_piece_maxima;
  std::vector<double>& piece_block = calling_thread_piece_maxima;
  // per piece: its blocks' maxima, then its own
  const std::size_t most_pieces =
      owners ? (population + shares->unit - 1) / shares->unit
             : (n + block_items(kListPieceEntries) - 1) / block_items(kListPieceEntries);
  piece_block.assign(most_pieces * stride, 0.0);
  const std::size_t pieces = listed_pieces(
      slots, population, shares, [&](std::size_t begin, std::size_t end, std::size_t piece) {
        double* mine = piece_block.data() + piece * stride;
        mine[blocks] = run_piece(begin, end, mine);
      });
  double max_speed2 = 0.0;
  for (std::size_t piece = 0; piece < pieces; ++piece) {
    const double* mine = piece_block.data() + piece * stride;
    for (std::size_t b = 0; b < blocks; ++b)
      block_max_speed2[b] = std::max(block_max_speed2[b], mine[b]);
    max_speed2 = std::max(max_speed2, mine[blocks]);
  }
  return max_speed2;
}

template <class Body>
std::size_t listed_pieces(const std::vector<std::uint32_t>& slots, std::size_t population,
                          const SlotShares* shares, Body&& body) {
  // (Named here, on the calling thread: inside the loop a thread_local would be the worker's.)
  static thread_local std::vector<std::size_t> calling_thread_entry_begin, calling_thread_bounds;
  std::vector<std::size_t>& entry_begin = calling_thread_entry_begin;
  const std::size_t units = listed_units(slots, population, shares, entry_begin);
  if (units == 0) {
    const std::size_t piece = block_items(kListPieceEntries);
    parallel_ranges(slots.size(), piece, body);
    return (slots.size() + piece - 1) / piece;
  }
  std::vector<std::size_t>& bounds = calling_thread_bounds;
  shares->unit_bounds(units, bounds);
  parallel_blocks_in_shares(units, bounds.data(), [&](std::size_t u) {
    if (entry_begin[u] < entry_begin[u + 1]) body(entry_begin[u], entry_begin[u + 1], u);
  });
  return units;
}

// Kick-drift of the listed slots by `dt`; returns the largest |v½|² as `report` counts it (as
// kick_drift) and raises block_max_speed2[slot / kSpeedBlockSlots] to each particle's. Each
// particle's next force pass starts from next_load(i) (gravity, plus what the caller keeps
// applied). With `kick_first`, each particle's closing kick of the last step (kick_listed, by the
// same `dt`) comes first in the same pass: per particle the operations of kick_listed and then of
// the kick-drift, in that order, so the same numbers with the state read once
// (Simulation::step_multi_rate carries the stepping particles' closing kick this way).
template <bool kKickFirst, class NextLoad>
double kick_drift_listed_as(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                            std::vector<double>& block_max_speed2, const SpeedReport& report,
                            NextLoad&& next_load, const SlotShares* shares) {
  const double half = 0.5 * dt;
  Vec3* x = p.position_m.data();
  Motion* motion = p.motion.data();
  Load* load = p.load.data();
  Load* previous_load = p.previous_load.data();
  const FrameSpeed frame_speed(report);
  auto kick_drift_one = [&](std::uint32_t i) {
    Motion m = motion[i];
    const Load l = load[i];
    if constexpr (kKickFirst) {
      const Load l_old = previous_load[i];
      m.velocity_m_per_s += (l.force_n - l_old.force_n) * (half * p.inv_mass_per_kg[i]);
      m.angular_velocity_rad_per_s +=
          (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
    }
    previous_load[i] = l;
    load[i] = next_load(i);
    const Vec3 dv = l.force_n * (half * p.inv_mass_per_kg[i]);
    const Vec3 v_half = m.velocity_m_per_s + dv;
    const double speed2 = frame_speed.speed2(i, x[i], v_half);
    x[i] += v_half * dt;
    motion[i] = {v_half + dv,
                 m.angular_velocity_rad_per_s + l.torque_n_m * (dt * p.inv_inertia_per_kg_m2[i])};
    return speed2;
  };
  return for_listed_speeds(slots, block_max_speed2, kick_drift_one, p.size(), shares);
}

// The same with kKickFirst = kick_first (the closing kick carried or not: one pass each).
// `shares`: the last force pass's owner shares (NeighborList::owner_shares), or null.
template <class NextLoad>
double kick_drift_listed(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                         std::vector<double>& block_max_speed2, const SpeedReport& report,
                         NextLoad&& next_load, bool kick_first = false,
                         const SlotShares* shares = nullptr) {
  return kick_first
             ? kick_drift_listed_as<true>(p, slots, dt, block_max_speed2, report, next_load, shares)
             : kick_drift_listed_as<false>(p, slots, dt, block_max_speed2, report, next_load,
                                           shares);
}

// The same, each next force pass starting from gravity, m·g.
inline double kick_drift_listed(ParticleStore& p, const std::vector<std::uint32_t>& slots,
                                double dt, const Vec3& gravity,
                                std::vector<double>& block_max_speed2, const SpeedReport& report,
                                bool kick_first = false, const SlotShares* shares = nullptr) {
  const double* mass = p.mass_kg.data();
  return kick_drift_listed(
      p, slots, dt, block_max_speed2, report,
      [&](std::uint32_t i) {
        return Load{gravity * mass[i], {}};
      },
      kick_first, shares);
}

// The closing kick of the listed slots by `dt`, in listed_pieces.
inline void kick_listed(ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                        const SlotShares* shares = nullptr) {
  const double half = 0.5 * dt;
  Motion* motion = p.motion.data();
  const Load* load = p.load.data();
  const Load* previous_load = p.previous_load.data();
  listed_pieces(slots, p.size(), shares, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t k = begin; k < end; ++k) {
      const std::uint32_t i = slots[k];
      const Load l = load[i], l_old = previous_load[i];
      motion[i].velocity_m_per_s += (l.force_n - l_old.force_n) * (half * p.inv_mass_per_kg[i]);
      motion[i].angular_velocity_rad_per_s +=
          (l.torque_n_m - l_old.torque_n_m) * (half * p.inv_inertia_per_kg_m2[i]);
    }
  });
}

// After a kick-drift pass: keeps the current forces as the previous ones, and starts from the
// forces that pass prepared (gravity only).
inline void begin_force_pass(ParticleStore& p) {
  std::swap(p.load, p.previous_load);
}

// Without a kick-drift pass before it (the first force pass, a refresh): keeps the current forces
// as the previous ones, then clears forces and torques and adds gravity, m·g.
inline void clear_forces(ParticleStore& p, const Vec3& gravity) {
  std::swap(p.load, p.previous_load);
  const std::size_t n = p.size();
  p.load.resize(n);
  for (std::size_t i = 0; i < n; ++i) p.load[i] = {gravity * p.mass_kg[i], {}};
}

}  // namespace millsim
