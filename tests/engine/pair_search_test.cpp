// The grid search with the half-shell sweep and proximity check must return exactly the pair
// set of the O(N²) all-pairs reference (compared as sorted sets), for polydisperse sets, dilute
// and dense, walled and periodic boxes, tiny periodic boxes (full-shell fallback), and with a skin.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "search/pair_search.h"

namespace millsim {
namespace {

using Pairs = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

Pairs sorted_pairs(const PairList& list) {
  Pairs out;
  for (std::size_t k = 0; k < list.size(); ++k)
    out.emplace_back(std::min(list.first[k], list.second[k]),
                     std::max(list.first[k], list.second[k]));
  std::sort(out.begin(), out.end());
  return out;
}

struct Cloud {
  std::vector<Vec3> x;
  std::vector<double> r;
  PeriodicBox box;
};

// Radii log-uniform in [r_max/ratio, r_max]; positions uniform (dense: overlaps are common).
Cloud random_cloud(std::size_t n, double size_ratio, double box_length, bool periodic,
                   unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud c;
  c.box = {{0, 0, 0}, {box_length, box_length, box_length}, {periodic, periodic, periodic}};
  const double r_max = 0.05;
  for (std::size_t i = 0; i < n; ++i) {
    c.x.push_back({u(rng) * box_length, u(rng) * box_length, u(rng) * box_length});
    c.r.push_back(r_max * std::pow(size_ratio, -u(rng)));
  }
  return c;
}

void expect_same_pairs(const Cloud& c, double skin, std::optional<double> min_cell = std::nullopt) {
  PairList reference, grid;
  find_pairs_all_pairs(c.x, c.r, c.box, skin, reference);
  SearchStats stats;
  find_pairs_grid(c.x, c.r, c.box, skin, min_cell, grid, stats);
  const Pairs expected = sorted_pairs(reference), found = sorted_pairs(grid);
  ASSERT_EQ(found.size(), expected.size());
  const auto diff = std::mismatch(found.begin(), found.end(), expected.begin());
  EXPECT_TRUE(diff.first == found.end())
      << "first difference: grid (" << diff.first->first << "," << diff.first->second
      << ") vs all-pairs (" << diff.second->first << "," << diff.second->second << ")";
  EXPECT_EQ(std::adjacent_find(found.begin(), found.end()), found.end())
      << "a pair was found twice";
}

class GridMatchesAllPairs
    : public testing::TestWithParam<std::tuple<double, double, bool, unsigned>> {};

TEST_P(GridMatchesAllPairs, SameContactSet) {
  const auto [size_ratio, box_length, periodic, seed] = GetParam();
  const Cloud c = random_cloud(1500, size_ratio, box_length, periodic, seed);
  expect_same_pairs(c, 0.0);
  expect_same_pairs(c, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Sets, GridMatchesAllPairs,
                         testing::Combine(testing::Values(1.0, 10.0, 100.0),
                                          testing::Values(0.25, 1.0,
                                                          4.0),  // tiny periodic: < 3 cells
                                          testing::Bool(), testing::Values(1u, 2u)));

TEST(GridSearch, ZeroAndOneParticleGiveNoPairs) {
  PairList out;
  SearchStats stats;
  const PeriodicBox box{{0, 0, 0}, {1, 1, 1}, {true, true, true}};
  find_pairs_grid({}, {}, box, 0.0, std::nullopt, out, stats);
  EXPECT_EQ(out.size(), 0u);
  find_pairs_grid({{0.5, 0.5, 0.5}}, {0.1}, box, 0.0, std::nullopt, out, stats);
  EXPECT_EQ(out.size(), 0u);
}

TEST(GridSearch, ParticlesOnCellFacesAndAcrossThePeriodicSeam) {
  // A 16³ lattice of spacing 1/16 in a unit periodic box with cells of exactly 1/8: every other
  // lattice plane lies exactly on cell faces. Spheres of radius just over half the spacing touch
  // their 6 lattice neighbours and nothing else, including across the wrap.
  Cloud c;
  c.box = {{0, 0, 0}, {1, 1, 1}, {true, true, true}};
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 16; ++j)
      for (int k = 0; k < 16; ++k) {
        c.x.push_back({0.0625 * i, 0.0625 * j, 0.0625 * k});
        c.r.push_back(0.03126);
      }
  expect_same_pairs(c, 0.0, 0.125);
  PairList grid;
  SearchStats stats;
  find_pairs_grid(c.x, c.r, c.box, 0.0, 0.125, grid, stats);
  EXPECT_EQ(stats.cells_per_axis[0], 8);
  EXPECT_EQ(grid.size(), 3u * 4096u) << "each lattice site touches 6 neighbours";
}

TEST(GridSearch, EverythingInOneCell) {
  Cloud c = random_cloud(300, 1.0, 0.05, false, 9);
  expect_same_pairs(c, 0.0);
}

}  // namespace
}  // namespace millsim
