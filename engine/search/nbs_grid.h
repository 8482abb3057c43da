// The conventional no-binary-search (NBS) contact detection of Munjiza & Andrews (1998): the
// baseline the paper's accelerations are measured against (scene key search.method = "nbs").
//
// A uniform array of cubic cells, at least 2 r_max + skin wide, covers the domain box. Every
// cell is stored, empty or not (no hashing), and holds a linked list of its particles. Each
// cell is swept in turn: its particles test the later members of their own cell and every
// member of the 13 half-shell neighbour cells, with no proximity check and no sub-grid, so one
// coarse particle sets the cell size for all the fines. The result equals the all-pairs search
// (tests/engine/hashed_grid_test.cpp); only the cost differs.
#pragma once

#include <cstdint>
#include <vector>

#include "core/vec3.h"
#include "dem/box.h"
#include "search/pair_search.h"

namespace millsim {

struct NbsStats {
  std::uint64_t distance_tests = 0;
  std::uint64_t cells = 0;  // all cells of the array, empty ones included
  double cell_m = 0.0;
};

// The array never holds more cells than this; past it the cell edge grows (still exact).
inline constexpr std::uint64_t kMaxNbsCells = 1ULL << 27;

class NbsGrid {
 public:
  void find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r, const PeriodicBox& box,
                  double skin_m, PairList& out);
  const NbsStats& stats() const { return stats_; }

 private:
  std::vector<std::int32_t> head_;  // per cell: first particle, −1 = empty
  std::vector<std::int32_t> next_;  // per particle: next in its cell, −1 = last
  NbsStats stats_;
};

}  // namespace millsim
