#include "parallel/slot_shares.h"

#include <algorithm>
#include <cmath>

namespace millsim {

void split_by_weight(const std::vector<double>& unit_weight, std::size_t slots, std::size_t unit,
                     std::size_t threads, SlotShares& shares) {
  const std::size_t units = unit_weight.size();
  shares.slots = slots, shares.unit = unit;
  shares.bound.assign(threads + 1, slots);
  shares.bound[0] = 0;
  double total = 0.0;
  for (const double w : unit_weight) total += w;
  if (!(total > 0.0)) {
    for (std::size_t t = 1; t < threads; ++t)
      shares.bound[t] = std::min(slots, (units * t / threads) * unit);
    return;
  }
  std::size_t u = 0;
  double below = 0.0;  // weight of units [0, u)
  for (std::size_t t = 1; t < threads; ++t) {
    // The first u with below·threads ≥ total·t.
    while (u < units && below * double(threads) < total * double(t)) below += unit_weight[u++];
    shares.bound[t] = std::min(slots, u * unit);
  }
}

void ShareBalancer::split(const std::vector<std::uint64_t>& candidates, std::size_t slots,
                          std::size_t unit, std::size_t threads, SlotShares& shares) {
  const std::size_t units = candidates.size();
  if (cost_s_.size() != units) cost_s_.assign(units, 0.0);
  double known = 0.0, known_candidates = 0.0;
  for (std::size_t u = 0; u < units; ++u)
    if (cost_s_[u] > 0.0)
      known += cost_s_[u] * double(candidates[u]), known_candidates += double(candidates[u]);
  const double unknown_cost = known_candidates > 0.0 ? known / known_candidates : 1.0;
  weight_.resize(units);
  double total = 0.0;
  for (std::size_t u = 0; u < units; ++u) {
    weight_[u] = double(candidates[u]) * (cost_s_[u] > 0.0 ? cost_s_[u] : unknown_cost);
    total += weight_[u];
  }
  if (shares.fit(slots, threads) && shares.unit == unit && total > 0.0) {
    double worst = 0.0;
    for (std::size_t t = 0; t < threads; ++t) {
      const auto [begin, end] = shares.unit_range(t, units);
      double w = 0.0;
      for (std::size_t u = begin; u < end; ++u) w += weight_[u];
      worst = std::max(worst, std::abs(w * double(threads) / total - 1.0));
    }
    if (worst <= kKeepImbalance) return;
  }
  split_by_weight(weight_, slots, unit, threads, shares);
}

void ShareBalancer::learn(const SlotShares& shares, const std::vector<std::uint64_t>& candidates,
                          const std::vector<double>& work_s) {
  const std::size_t units = candidates.size(), threads = shares.threads();
  if (cost_s_.size() != units || work_s.size() != threads) return;
  if (total_work_s_.size() != threads) total_work_s_.assign(threads, 0.0);
  for (std::size_t t = 0; t < threads; ++t) total_work_s_[t] += work_s[t];
  for (std::size_t t = 0; t < threads; ++t) {
    const auto [begin, end] = shares.unit_range(t, units);
    std::uint64_t count = 0;
    for (std::size_t u = begin; u < end; ++u) count += candidates[u];
    if (count == 0 || !(work_s[t] > 0.0)) continue;
    const double rate = work_s[t] / double(count);
    for (std::size_t u = begin; u < end; ++u)
      cost_s_[u] = cost_s_[u] > 0.0 ? (1.0 - kLearnRate) * cost_s_[u] + kLearnRate * rate : rate;
  }
}

}  // namespace millsim
