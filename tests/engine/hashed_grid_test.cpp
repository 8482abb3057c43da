// The hashed NBS grid with the sub-grid must return exactly the pair set of the O(N²) all-pairs
// reference (compared as sorted sets, each pair once), for size ratios 1, 10, 100 and 1000,
// dilute and clustered sets, walled and periodic boxes (including boxes of fewer than 3 cells),
// every sub-cell division k from 1 to 8 with 2 to 4 grid levels, and with a skin. The
// conventional dense NBS (search/nbs_grid.h), the baseline of the acceleration chain, is held to
// the same reference on the same sets.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "search/hashed_grid.h"
#include "search/nbs_grid.h"

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

// Radii log-uniform in [r_max/ratio, r_max] with n(d) weighted to fines; positions uniform, or
// gathered in a few tight clusters (`clustered`) inside a large, mostly empty box.
Cloud random_cloud(std::size_t n, double size_ratio, double box_length, bool periodic,
                   bool clustered, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud c;
  c.box = {{0, 0, 0}, {box_length, box_length, box_length}, {periodic, periodic, periodic}};
  const double r_max = 0.05;
  std::vector<Vec3> centres;
  for (int k = 0; k < 4; ++k)
    centres.push_back({u(rng) * box_length, u(rng) * box_length, u(rng) * box_length});
  for (std::size_t i = 0; i < n; ++i) {
    const double t = u(rng);
    c.r.push_back(r_max * std::pow(size_ratio, -std::sqrt(t)));  // skewed towards fines
    Vec3 p{u(rng) * box_length, u(rng) * box_length, u(rng) * box_length};
    if (clustered) {
      const Vec3& centre = centres[i % centres.size()];
      p = centre + Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * 0.2;
      c.box.wrap(p);
      if (!periodic)
        for (int a = 0; a < 3; ++a) p[a] = std::clamp(p[a], 0.0, box_length);
    }
    c.x.push_back(p);
  }
  return c;
}

void expect_same_pairs(const Cloud& c, double skin, int k, int levels = 2) {
  PairList reference, grid;
  find_pairs_all_pairs(c.x, c.r, c.box, skin, reference);
  HashedGrid hashed;
  hashed.find_pairs(c.x, c.r, c.box, {skin, k, levels, std::nullopt}, grid);
  const Pairs expected = sorted_pairs(reference), found = sorted_pairs(grid);
  EXPECT_EQ(std::adjacent_find(found.begin(), found.end()), found.end())
      << "a pair was found twice";
  ASSERT_EQ(found.size(), expected.size())
      << "k = " << k << ", levels = " << levels << ", skin = " << skin;
  const auto diff = std::mismatch(found.begin(), found.end(), expected.begin());
  EXPECT_TRUE(diff.first == found.end())
      << "first difference: grid (" << diff.first->first << "," << diff.first->second
      << ") vs all-pairs (" << diff.second->first << "," << diff.second->second << ")";
}

void expect_nbs_same_pairs(const Cloud& c, double skin) {
  PairList reference, found_list;
  find_pairs_all_pairs(c.x, c.r, c.box, skin, reference);
  NbsGrid nbs;
  nbs.find_pairs(c.x, c.r, c.box, skin, found_list);
  const Pairs expected = sorted_pairs(reference), found = sorted_pairs(found_list);
  EXPECT_EQ(std::adjacent_find(found.begin(), found.end()), found.end())
      << "a pair was found twice";
  EXPECT_EQ(found, expected) << "skin = " << skin << ", " << nbs.stats().cells << " cells";
}

class HashedGridMatchesAllPairs
    : public testing::TestWithParam<std::tuple<double, double, bool, bool, int>> {};

TEST_P(HashedGridMatchesAllPairs, SameContactSet) {
  const auto [size_ratio, box_length, periodic, clustered, k] = GetParam();
  const Cloud c = random_cloud(1200, size_ratio, box_length, periodic, clustered, 7u + unsigned(k));
  for (int levels = 2; levels <= kMaxGridLevels; ++levels) {
    expect_same_pairs(c, 0.0, k, levels);
    expect_same_pairs(c, 0.004, k, levels);
  }
}

class NbsMatchesAllPairs : public testing::TestWithParam<std::tuple<double, double, bool, bool>> {};

TEST_P(NbsMatchesAllPairs, SameContactSet) {
  const auto [size_ratio, box_length, periodic, clustered] = GetParam();
  const Cloud c = random_cloud(1200, size_ratio, box_length, periodic, clustered, 11u);
  expect_nbs_same_pairs(c, 0.0);
  expect_nbs_same_pairs(c, 0.004);
}

INSTANTIATE_TEST_SUITE_P(Sets, NbsMatchesAllPairs,
                         testing::Combine(testing::Values(1.0, 10.0, 100.0, 1000.0),
                                          testing::Values(0.25, 1.5),  // 0.25: < 3 cells per axis
                                          testing::Bool(), testing::Bool()));

TEST(NbsGrid, StoresEveryCellOfTheBoxAndSizesThemByTheLargestParticle) {
  // A dilute box: the dense array holds every cell, occupied or not, each 2 r_max + skin wide.
  const Cloud dilute = random_cloud(500, 10.0, 20.0, true, false, 4);
  NbsGrid nbs;
  PairList out;
  nbs.find_pairs(dilute.x, dilute.r, dilute.box, 0.01, out);
  const double r_max = *std::max_element(dilute.r.begin(), dilute.r.end());
  const long per_axis = long(20.0 / (2.0 * r_max + 0.01));
  EXPECT_EQ(nbs.stats().cells, std::uint64_t(per_axis * per_axis * per_axis));
  EXPECT_GE(nbs.stats().cell_m, 2.0 * r_max + 0.01);
  expect_nbs_same_pairs(dilute, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Sets, HashedGridMatchesAllPairs,
                         testing::Combine(testing::Values(1.0, 10.0, 100.0, 1000.0),
                                          testing::Values(0.25, 1.5),  // 0.25: < 3 cells per axis
                                          testing::Bool(), testing::Bool(), testing::Range(1, 9)));

TEST(HashedGrid, ZeroAndOneParticleGiveNoPairs) {
  PairList out;
  HashedGrid grid;
  const PeriodicBox box{{0, 0, 0}, {1, 1, 1}, {true, true, true}};
  grid.find_pairs({}, {}, box, {0.0, 4, 2, std::nullopt}, out);
  EXPECT_EQ(out.size(), 0u);
  grid.find_pairs({{0.5, 0.5, 0.5}}, {0.1}, box, {0.0, 4, 2, std::nullopt}, out);
  EXPECT_EQ(out.size(), 0u);
}

TEST(HashedGrid, ParticlesExactlyOnCellFacesAcrossTheSeam) {
  // A 16³ lattice of spacing 1/16 in a unit periodic box, cells of exactly 1/8 (sub-cells 1/16
  // with k = 2): lattice planes lie exactly on cell and sub-cell faces. Radii just over half the
  // spacing: every site touches its 6 neighbours, including across the wrap.
  Cloud c;
  c.box = {{0, 0, 0}, {1, 1, 1}, {true, true, true}};
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 16; ++j)
      for (int k = 0; k < 16; ++k) {
        c.x.push_back({0.0625 * i, 0.0625 * j, 0.0625 * k});
        c.r.push_back(i == 0 && j == 0 && k == 0 ? 0.06 : 0.03126);  // one coarser particle
      }
  for (int k : {1, 2, 4}) {
    PairList grid, reference;
    HashedGrid hashed;
    hashed.find_pairs(c.x, c.r, c.box, {0.0, k, 3, 0.125}, grid);
    find_pairs_all_pairs(c.x, c.r, c.box, 0.0, reference);
    EXPECT_EQ(sorted_pairs(grid), sorted_pairs(reference)) << "k = " << k;
  }
}

TEST(HashedGrid, EverythingInOneCellAndDiluteDomains) {
  expect_same_pairs(random_cloud(400, 10.0, 0.05, false, false, 3), 0.0, 3);
  // Dilute: 500 particles in a box of 10⁶ cells' volume; only occupied cells are stored.
  const Cloud dilute = random_cloud(500, 10.0, 20.0, true, false, 4);
  expect_same_pairs(dilute, 0.0, 2);
  HashedGrid grid;
  PairList out;
  grid.find_pairs(dilute.x, dilute.r, dilute.box, {0.0, 1, 1, std::nullopt}, out);
  EXPECT_LE(grid.stats().cells, 500u);
}

// Measured work of one search: distance tests plus cell probes weighted as the cost model
// weighs them (a probe ≈ kLookupCostTests tests).
double measured_work(const Cloud& c, double skin, GridDivision division) {
  HashedGrid grid;
  PairList out;
  grid.find_pairs(c.x, c.r, c.box, {skin, division.subcells_per_axis, division.levels, {}}, out);
  return double(grid.stats().distance_tests) + kLookupCostTests * double(grid.stats().cell_lookups);
}

// Particles at solids fraction 0.2 in a periodic box: diameters with n(d) ∝ d^−2.5 between
// d_max/ratio and d_max (as the shared r100 scene), or all equal.
Cloud packing(std::size_t n, double ratio, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud c;
  double volume = 0.0;
  const double d_max = 100e-6, d_min = d_max / ratio;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = std::pow(d_min, -1.5), b = std::pow(d_max, -1.5);
    const double d = ratio == 1.0 ? d_max : std::pow(a - u(rng) * (a - b), -1.0 / 1.5);
    c.r.push_back(0.5 * d);
    volume += std::acos(-1.0) / 6.0 * d * d * d;
  }
  const double length = std::cbrt(volume / 0.2);
  c.box = {{0, 0, 0}, {length, length, length}, {true, true, true}};
  for (std::size_t i = 0; i < n; ++i)
    c.x.push_back({u(rng) * length, u(rng) * length, u(rng) * length});
  return c;
}

TEST(HashedGrid, AutomaticDivisionIsNearTheMeasuredBest) {
  // Independent expectation: the work actually counted by the grid for every division. The
  // estimate (uniform density, binned sizes) must pick one within 30 % of the best, and no
  // sub-grid for equal sizes (paper §2.2, Fig. 3).
  for (const double ratio : {1.0, 10.0, 100.0}) {
    const Cloud c = packing(20000, ratio, 11);
    const double d_min = 2.0 * *std::min_element(c.r.begin(), c.r.end());
    const double skin = 0.5 * d_min, volume = std::pow(c.box.length(0), 3);
    const GridDivision chosen = choose_grid_division(c.r, skin, volume);
    if (ratio == 1.0) {
      EXPECT_EQ(chosen, (GridDivision{1, 1}));
    }
    double best = measured_work(c, skin, {1, 1});
    for (int k = 2; k <= 8; ++k)
      for (int levels = 2; levels <= kMaxGridLevels; ++levels)
        best = std::min(best, measured_work(c, skin, {k, levels}));
    EXPECT_LE(measured_work(c, skin, chosen), 1.3 * best)
        << "ratio " << ratio << ": chose k = " << chosen.subcells_per_axis
        << ", levels = " << chosen.levels;
  }
}

TEST(HashedGrid, GivenDivisionIsKept) {
  const std::vector<double> r(100, 1e-6);
  EXPECT_EQ(choose_grid_division(r, 0.0, 1e-12, 5), (GridDivision{5, 2})) << "k alone: two levels";
  EXPECT_EQ(choose_grid_division(r, 0.0, 1e-12, 5, 3), (GridDivision{5, 3}));
  EXPECT_EQ(choose_grid_division(r, 0.0, 1e-12, 1, 3), (GridDivision{1, 1}));
  EXPECT_EQ(choose_grid_division(r, 0.0, 1e-12, {}, 1), (GridDivision{1, 1}));
}

// Multi-rate stepping orders the particles that step first: with flags, the order is the plain
// Morton order with the flagged particles moved behind the others, each part keeping its Morton
// order (a stable partition of the plain order), and without any flag set it is the plain order.
TEST(SpatialOrder, FlaggedParticlesComeBehindEachPartInMortonOrder) {
  const Cloud c = random_cloud(5000, 10.0, 1e-2, false, true, 11);
  SortScratch scratch;
  std::vector<std::uint32_t> plain, partitioned;
  spatial_order(c.x, c.box, plain, scratch);
  std::vector<std::uint8_t> flag(c.x.size(), 0);
  spatial_order(c.x, c.box, partitioned, scratch, flag.data());
  EXPECT_EQ(partitioned, plain);
  std::mt19937_64 rng(3);
  for (std::uint8_t& f : flag) f = std::uint8_t(rng() % 3);  // 1 and 2 both mean behind
  spatial_order(c.x, c.box, partitioned, scratch, flag.data());
  std::vector<std::uint32_t> expected = plain;
  std::stable_partition(expected.begin(), expected.end(),
                        [&](std::uint32_t i) { return flag[i] == 0; });
  EXPECT_EQ(partitioned, expected);
  // Every particle once.
  std::vector<std::uint32_t> sorted = plain;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 0; k < sorted.size(); ++k) ASSERT_EQ(sorted[k], k);
}

}  // namespace
}  // namespace millsim
