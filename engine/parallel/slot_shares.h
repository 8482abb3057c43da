// Owner shares of the particle slots: thread t of the team owns slots [bound[t], bound[t + 1]).
// The threaded force pass runs each thread on the candidates listed at its own slots and lets it
// alone add to its own particles' loads; the next kick-drift runs each thread on its own slots
// again, so that the loads, positions and velocities a thread wrote stay in its core's caches
// (docs/threads.md). Shares move from pass to pass (the force pass balances them by its work);
// no result depends on them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace millsim {

// Owner shares are cut at multiples of this many slots: a divisor of the kick-drift's speed
// blocks (dem/integrator.h), so that a share's chunks fill whole parts of them.
inline constexpr std::size_t kOwnerUnitSlots = 1024;

struct SlotShares {
  std::size_t slots = 0;           // the population they were made for
  std::size_t unit = 1;            // every bound but the last is a multiple of it
  std::vector<std::size_t> bound;  // threads + 1 entries: 0, ..., slots

  std::size_t threads() const { return bound.empty() ? 0 : bound.size() - 1; }
  // Owner t's units of `unit` slots, [first, second), of `units` in all.
  std::pair<std::size_t, std::size_t> unit_range(std::size_t t, std::size_t units) const {
    return {bound[t] / unit, t + 1 == threads() ? units : bound[t + 1] / unit};
  }
  // Each owner's first unit, then `units`, the end (threads + 1 entries): the shares of a loop
  // over `units` units of `unit` slots (parallel_blocks_in_shares).
  void unit_bounds(std::size_t units, std::vector<std::size_t>& out) const {
    out.resize(threads() + 1);
    for (std::size_t t = 0; t < threads(); ++t) out[t] = bound[t] / unit;
    out[threads()] = units;
  }
  // Whether they were made for `n` slots and `threads` threads.
  bool fit(std::size_t n, std::size_t threads) const {
    return slots == n && this->threads() == threads && threads > 1;
  }
  void clear() { slots = 0, bound.clear(); }
};

// Shares of `slots` slots at multiples of `unit` for `threads` owners, each with about the same
// sum of `unit_weight` (one entry per unit of slots, the last unit possibly short): owner t's
// share begins at the first unit boundary where the weight below reaches t/threads of the total.
// With no weight at all, equal shares of units.
void split_by_weight(const std::vector<double>& unit_weight, std::size_t slots, std::size_t unit,
                     std::size_t threads, SlotShares& shares);

// What a force-pass candidate costs where, learnt from the passes' measured seconds per owner:
// the owner shares then follow the work, not just the candidate count (a share holding the
// periodic images' pairs, or the crowded contacts, costs more per candidate). Nothing computed
// depends on it, only which thread computes what.
class ShareBalancer {
 public:
  // Shares kept while every share's estimated work stays within this part of an even split.
  static constexpr double kKeepImbalance = 0.05;
  // Weight given to a pass's measurement in a unit's cost.
  static constexpr double kLearnRate = 0.25;

  // Owner shares for a pass with `candidates` per unit of slots, split by the costs learnt so far
  // (by candidate count alone where nothing is known); `shares` is kept when it fits and stays
  // within kKeepImbalance.
  void split(const std::vector<std::uint64_t>& candidates, std::size_t slots, std::size_t unit,
             std::size_t threads, SlotShares& shares);
  // A pass on `shares` over `candidates` took work_s[t] seconds on owner t (its waits left out).
  void learn(const SlotShares& shares, const std::vector<std::uint64_t>& candidates,
             const std::vector<double>& work_s);
  // Each owner's seconds of work over every pass learnt from (a benchmark's view of the
  // balance: bench/bench_step).
  const std::vector<double>& total_work_s() const { return total_work_s_; }

 private:
  std::vector<double> cost_s_;  // per unit: seconds per candidate, smoothed; 0 where unknown
  std::vector<double> total_work_s_;
  std::vector<double> weight_;
};

}  // namespace millsim
