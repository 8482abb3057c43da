// Candidate-pair search: every unordered pair (i, j) with |x_i − x_j| < r_i + r_j + skin, under
// the periodic box. Two implementations with one output type: the O(N²) all-pairs reference
// (tests, tiny scenes) and the uniform cell grid with the half-shell sweep and the proximity
// check of §2.1. With skin = 0 the result is the exact contact set.
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
};

struct SearchStats {
  std::uint64_t distance_tests = 0;  // pair distance evaluations
  std::uint64_t cells = 0;           // cells in the grid
  int cells_per_axis[3] = {0, 0, 0};
  bool half_shell = true;  // false when a periodic axis has < 3 cells (full shell, deduplicated)
};

// O(N²) reference.
void find_pairs_all_pairs(const std::vector<Vec3>& position_m, const std::vector<double>& radius_m,
                          const PeriodicBox& box, double skin_m, PairList& out);

// Uniform grid over the particles' bounding box (domain extent on periodic axes); cells are at
// least 2 r_max + skin wide, enlarged when there would be more cells than ~2 per particle.
void find_pairs_grid(const std::vector<Vec3>& position_m, const std::vector<double>& radius_m,
                     const PeriodicBox& box, double skin_m, std::optional<double> min_cell_m,
                     PairList& out, SearchStats& stats);

}  // namespace millsim
