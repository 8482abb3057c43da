#include "parallel/slot_shares.h"

#include <algorithm>

namespace millsim {

void split_by_weight(const std::vector<std::uint64_t>& unit_weight, std::size_t slots,
                     std::size_t unit, std::size_t threads, SlotShares& shares) {
  const std::size_t units = unit_weight.size();
  shares.slots = slots, shares.unit = unit;
  shares.bound.assign(threads + 1, slots);
  shares.bound[0] = 0;
  std::uint64_t total = 0;
  for (const std::uint64_t w : unit_weight) total += w;
  if (total == 0) {
    for (std::size_t t = 1; t < threads; ++t)
      shares.bound[t] = std::min(slots, (units * t / threads) * unit);
    return;
  }
  std::size_t u = 0;
  std::uint64_t below = 0;  // weight of units [0, u)
  for (std::size_t t = 1; t < threads; ++t) {
    // The first u with below·threads ≥ total·t (exact in integers).
    const unsigned __int128 target = (unsigned __int128)total * t;
    while (u < units && (unsigned __int128)below * threads < target) below += unit_weight[u++];
    shares.bound[t] = std::min(slots, u * unit);
  }
}

}  // namespace millsim
