#include "sim/multi_rate.h"

#include <algorithm>
#include <cmath>

#include "dem/integrator.h"

namespace millsim {

namespace {

// Appends candidates [begin, end) to `ranges`, joining it to the last range where they touch.
void add_range(std::vector<NeighborList::PairRange>& ranges, std::size_t begin, std::size_t end) {
  if (!ranges.empty() && ranges.back().end == begin)
    ranges.back().end = end;
  else
    ranges.push_back({begin, end});
}

// The sets from the flags; the wall candidates' ranges too when the list is `fresh` (just
// rebuilt: after a population change and before its rebuild they refer to old slots).
void list_slots(const ParticleStore& p, const NeighborList& neighbors, bool fresh, MultiRate& m) {
  m.stepping.clear();
  m.waiting.clear();
  for (RiderLevel& level : m.riders) {
    level.slots.clear();
    level.wall_ranges.clear();
    level.touching_walls = 0;
    level.fluid_refreshed_step = -1;
  }
  m.stepping_wall_ranges.clear();
  for (std::uint32_t i = 0; i < std::uint32_t(p.size()); ++i) {
    const std::uint8_t flag = p.free_flight[i];
    if (flag == kSteps)
      m.stepping.push_back(i);
    else if (flag == kInFreeFlight)
      m.waiting.push_back(i);
    else
      m.riders[flag - kRidesWalls - 1].slots.push_back(i);
  }
  m.rider_ranges_valid = fresh;
  if (m.riders_on && fresh) {
    // A particle's wall candidates lie together (the rebuild lists them by slot, then wall).
    const std::vector<std::uint32_t>& owner = neighbors.wall_particle;
    for (std::size_t k = 0; k < owner.size();) {
      std::size_t end = k + 1;
      while (end < owner.size() && owner[end] == owner[k]) ++end;
      const std::uint8_t flag = p.free_flight[owner[k]];
      add_range(
          flag == kSteps ? m.stepping_wall_ranges : m.riders[flag - kRidesWalls - 1].wall_ranges, k,
          end);
      k = end;
    }
  }
  m.lists_version = p.population_version;
  m.speeds_valid = false;
}

// The largest speed² per slot block of `slots`, each |v| + ½ max_wait dt |F| / m, with v as
// `report` counts it (relative to the list's frame, scaled per slot; the other terms unscaled,
// which only widens the bound). In a turning frame one lumped step of h ≤ max_wait dt also cuts the
// frame's arc over h, ½ (Ω h)² ρ_max (dem/motion_frame.h): over its h that is at most ½ Ω² max_wait
// dt ρ_max of speed. (The displacement the frame carries round is the list's own term,
// note_motion.)
double bound_speeds(const ParticleStore& p, const std::vector<std::uint32_t>& slots, double dt,
                    const MultiRate& m, const SpeedReport& report,
                    std::vector<double>& block_speed2) {
  const double credit_s = 0.5 * double(m.max_wait_steps) * dt;
  const double chord_speed = report.frame.omega_rad_per_s * report.frame.omega_rad_per_s *
                             credit_s * report.frame.radius_bound_m;
  const FrameSpeed frame_speed(report);
  block_speed2.assign((p.size() + kSpeedBlockSlots - 1) / kSpeedBlockSlots, 0.0);
  return for_listed_speeds(slots, block_speed2, [&](std::uint32_t i) {
    const double speed =
        std::sqrt(frame_speed.speed2(i, p.position_m[i], p.motion[i].velocity_m_per_s)) +
        credit_s * norm(p.load[i].force_n) * p.inv_mass_per_kg[i] + chord_speed;
    return speed * speed;
  });
}

// waiting_block_speed2 and waiting_max_speed2 from the free-flight and rider bounds.
void combine_waiting_bounds(MultiRate& m) {
  m.waiting_block_speed2 = m.free_block_speed2;
  m.waiting_max_speed2 = m.free_max_speed2;
  for (const RiderLevel& level : m.riders) {
    if (level.slots.empty()) continue;
    for (std::size_t b = 0; b < m.waiting_block_speed2.size(); ++b)
      m.waiting_block_speed2[b] = std::max(m.waiting_block_speed2[b], level.block_speed2[b]);
    m.waiting_max_speed2 = std::max(m.waiting_max_speed2, level.max_speed2);
  }
}

}  // namespace

double own_step_bound_s(const ParticleStore& p, std::size_t i, const MaterialTable& materials,
                        const RiderRule& rule) {
  // A wall is fixed: the rider meets one at most at its own speed, which drag and gravity change
  // over their relaxation times, far longer than a list's life. Twice it, at least 1 m/s.
  const double speed =
      std::min(rule.impact_speed_m_per_s, std::max(1.0, 2.0 * norm(p.motion[i].velocity_m_per_s)));
  const ParticleStepTimes t = particle_step_times(p, i, materials, rule.wall, speed);
  return contact_step_bound_s(t.rayleigh_s, t.wall_contact_s,
                              rule.penetration_limit * 2.0 * p.radius_m[i] / speed,
                              rule.safety_factor, rule.steps_per_contact);
}

int rider_level(const ParticleStore& p, std::size_t i, const MaterialTable& materials,
                const RiderRule& rule) {
  const double ratio = own_step_bound_s(p, i, materials, rule) / rule.run_bound_s;
  int level = 0;
  while (level < rule.max_level && double(std::int64_t(2) << level) <= ratio) ++level;
  return level;
}

void mark_free_flight(ParticleStore& p, const NeighborList& neighbors, MultiRate& m,
                      const RiderRule* riders, const MaterialTable* materials) {
  std::uint8_t* flag = p.free_flight.data();
  std::fill(p.free_flight.begin(), p.free_flight.end(), kInFreeFlight);
  constexpr std::uint8_t kWallsOnly = 0xff;  // until its level is known
  for (const std::uint32_t i : neighbors.wall_particle) flag[i] = kWallsOnly;
  for (std::size_t k = 0; k < neighbors.pairs.size(); ++k)
    flag[neighbors.pairs.first[k]] = flag[neighbors.pairs.second[k]] = kSteps;
  m.riders_on = riders != nullptr;
  m.riders.resize(riders ? std::size_t(kMaxRiderLevel) : 0);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (flag[i] == kWallsOnly) {
      const int level = riders ? rider_level(p, i, *materials, *riders) : 0;
      flag[i] = level == 0 ? kSteps : std::uint8_t(kRidesWalls + level);
    }
  list_slots(p, neighbors, true, m);
  m.marked_rebuilds = neighbors.stats().rebuilds;
}

void relist_if_moved(const ParticleStore& p, const NeighborList& neighbors, MultiRate& m) {
  if (m.lists_version != p.population_version) list_slots(p, neighbors, false, m);
}

std::int64_t max_wait_steps(double dt, double relaxation_s) {
  const double steps = std::floor(kMaxWaitPerRelaxationTime * relaxation_s / dt);
  return std::clamp<std::int64_t>(std::int64_t(std::min(steps, 1e9)), 1, kMaxFreeFlightSteps);
}

void bound_waiting_speeds(const ParticleStore& p, double dt, const SpeedReport& report,
                          MultiRate& m) {
  m.free_max_speed2 = bound_speeds(p, m.waiting, dt, m, report, m.free_block_speed2);
  for (RiderLevel& level : m.riders)
    if (!level.slots.empty())
      level.max_speed2 = bound_speeds(p, level.slots, dt, m, report, level.block_speed2);
  combine_waiting_bounds(m);
  m.speeds_valid = true;
}

void bound_rider_speeds(const ParticleStore& p, double dt, int level, const SpeedReport& report,
                        MultiRate& m) {
  RiderLevel& l = m.riders[std::size_t(level - 1)];
  l.max_speed2 = bound_speeds(p, l.slots, dt, m, report, l.block_speed2);
  combine_waiting_bounds(m);
}

double kick_drift_keeping_fluid(ParticleStore& p, const std::vector<std::uint32_t>& slots,
                                double dt, const Vec3& gravity,
                                std::vector<double>& block_max_speed2, const SpeedReport& report,
                                bool kick_first, const SlotShares* shares) {
  const double* mass = p.mass_kg.data();
  const Vec3* held = p.fluid_held_force_n.data();
  return kick_drift_listed(
      p, slots, dt, block_max_speed2, report,
      [&](std::uint32_t i) {
        return Load{gravity * mass[i] + held[i], {}};
      },
      kick_first, shares);
}

Vec3 book_held_exchange(ParticleStore& p, const std::vector<std::uint32_t>& slots, double held_s) {
  const Vec3* exchange = p.fluid_held_exchange_n.data();
  Vec3* impulse = p.fluid_impulse_n_s.data();
  const std::size_t piece = block_items(kListPieceEntries);
  static thread_local std::vector<Vec3> calling_thread_piece_sums;
  std::vector<Vec3>& piece_sums = calling_thread_piece_sums;
  piece_sums.assign((slots.size() + piece - 1) / piece, Vec3{});
  parallel_ranges(slots.size(), piece, [&](std::size_t begin, std::size_t end, std::size_t q) {
    Vec3 sum;
    for (std::size_t k = begin; k < end; ++k) {
      const Vec3 booked = exchange[slots[k]] * held_s;
      impulse[slots[k]] += booked;
      sum += booked;
    }
    piece_sums[q] = sum;
  });
  Vec3 total;
  for (const Vec3& sum : piece_sums) total += sum;
  return total;
}

}  // namespace millsim
