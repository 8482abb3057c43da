// Candidate pairs: every unordered pair (i, j) with |x_i − x_j| < r_i + r_j + skin under the
// periodic box, as a PairList. This file holds the O(N²) all-pairs reference that the tests hold
// the hashed grid (search/hashed_grid.h) to. With skin = 0 the result is the exact contact set.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/vec3.h"
#include "dem/box.h"

namespace millsim {

struct PairList {
  std::vector<std::uint32_t> first, second;  // slot indices, first != second
  std::size_t size() const { return first.size(); }
  void clear() { first.clear(), second.clear(); }
  void push(std::uint32_t i, std::uint32_t j) { first.push_back(i), second.push_back(j); }
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, first, second);
  }
};

// O(N²) reference.
void find_pairs_all_pairs(const std::vector<Vec3>& position_m, const std::vector<double>& radius_m,
                          const PeriodicBox& box, double skin_m, PairList& out);

}  // namespace millsim
