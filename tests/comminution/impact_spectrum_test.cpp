// The impact-energy spectrum (process/impact_spectrum.h, issue 32 item 6) on cases counted by
// hand: N equal impacts at a known speed land in the one bin that holds v²/2, with N counts, in
// the size class of the particles that met them; a pair impact counts once for each particle;
// the intervals add up to the run's counts; result.json and run.h5 hold the same numbers; and
// breakage events are logged with the energy that broke them.
#include "process/impact_spectrum.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>

#include "sim/run.h"
#include "sim/simulation.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

// The bin of e among the edges: e_k <= e < e_k+1.
std::size_t bin_of(const std::vector<double>& edges, double e) {
  for (std::size_t k = 0; k + 1 < edges.size(); ++k)
    if (e >= edges[k] && e < edges[k + 1]) return k;
  return edges.size();
}

TEST(ImpactSpectrum, EqualImpactsLandInTheirBinAndSizeClass) {
  ImpactSpectrum s({1e-5, 1e-4, 1e-3}, 1e-4, 1e6, 5);
  ASSERT_EQ(s.energy_bins(), 50u);
  EXPECT_NEAR(s.energy_edges_j_per_kg()[5], 1e-3, 1e-15);  // five bins per decade
  const double v = 7.0, u = 1.5;                           // 24.5 and 1.125 J/kg
  for (int k = 0; k < 13; ++k) s.add({0, 0, 0}, 5e-4, v, u);
  ASSERT_EQ(s.groups().size(), 1u);
  const std::vector<std::uint64_t>& n = s.normal_counts(0);
  const std::vector<std::uint64_t>& t = s.tangential_counts(0);
  const std::size_t bins = s.energy_bins();
  const std::size_t nb = bin_of(s.energy_edges_j_per_kg(), 0.5 * v * v),
                    tb = bin_of(s.energy_edges_j_per_kg(), 0.5 * u * u);
  for (std::size_t c = 0; c < n.size(); ++c) {
    EXPECT_EQ(n[c], c == bins + nb ? 13u : 0u) << "class " << c / bins << " bin " << c % bins;
    EXPECT_EQ(t[c], c == bins + tb ? 13u : 0u) << "class " << c / bins << " bin " << c % bins;
  }
  // An energy exactly on an edge belongs to the bin above; 0 to the first; beyond the range to
  // the last; a particle outside the size classes to the nearest one.
  s.add({1, 0, 2}, 2e-6, std::sqrt(2.0 * s.energy_edges_j_per_kg()[20]), 0.0);
  s.add({1, 0, 2}, 1.0, 1e5, 0.0);
  s.add({1, 0, 2}, 1.0, std::numeric_limits<double>::infinity(), 0.0);  // a blow-up's speed
  ASSERT_EQ(s.groups().size(), 2u);
  EXPECT_EQ(s.normal_counts(1)[20], 1u);
  EXPECT_EQ(s.tangential_counts(1)[0], 1u);
  EXPECT_EQ(s.normal_counts(1)[bins + bins - 1], 2u);
  EXPECT_EQ(s.impacts(), 16u);
}

TEST(ImpactSpectrum, IntervalsAddUpToTheRun) {
  ImpactSpectrum s({1e-5, 1e-3}, 1e-4, 1e6, 5);
  s.add({0, 0, 0}, 1e-4, 1.0, 0.0);
  s.close_interval(1.0);
  s.add({1, 0, 0}, 1e-4, 10.0, 0.0);  // a group that appears in the second interval
  s.add({0, 0, 0}, 1e-4, 1.0, 0.0);
  s.add({0, 0, 0}, 1e-4, 1.0, 0.0);
  s.close_interval(2.0);
  for (std::size_t g = 0; g < 2; ++g) {
    std::vector<std::uint64_t> sum(s.normal_counts(g).size(), 0);
    for (std::size_t k = 0; k < 2; ++k) {
      const std::vector<std::uint64_t> part = s.interval_normal_counts(k, g);
      for (std::size_t c = 0; c < sum.size(); ++c) sum[c] += part[c];
    }
    EXPECT_EQ(sum, s.normal_counts(g)) << "group " << g;
  }
  const auto first = s.interval_normal_counts(0, 0), second = s.interval_normal_counts(1, 0);
  EXPECT_EQ(std::accumulate(first.begin(), first.end(), 0ull), 1u);
  EXPECT_EQ(std::accumulate(second.begin(), second.end(), 0ull), 2u);
  const auto absent = s.interval_normal_counts(0, 1);
  EXPECT_EQ(std::accumulate(absent.begin(), absent.end(), 0ull), 0u);
}

std::vector<std::uint64_t> read_counts(hid_t file, const char* path) {
  const hid_t set = H5Dopen2(file, path, H5P_DEFAULT);
  EXPECT_GE(set, 0) << path;
  const hid_t space = H5Dget_space(set);
  std::vector<std::uint64_t> v(std::size_t(H5Sget_simple_extent_npoints(space)));
  H5Dread(set, H5T_NATIVE_UINT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  H5Sclose(space);
  H5Dclose(set);
  return v;
}

// Twelve spheres far apart fly at a floor with the same velocity (normal 3 m/s, tangential
// 0.8 m/s, no spin), and two more meet head-on at 2 × 1.5 m/s: twelve particle-wall impacts in
// the bin of 4.5 J/kg (normal) and 0.32 J/kg (tangential), and two particle-particle counts in
// the bin of 4.5 J/kg, all in the class of the spheres' size.
TEST(ImpactSpectrum, ARunCountsEveryImpactOnceInResultAndRunH5) {
  SceneConfig scene = test::empty_scene({0, 0, 0}, {0.1, 0.02, 0.02}, test::table1_material(0.5));
  const double d = 1e-3;
  for (int k = 0; k < 12; ++k)
    test::add_particle(scene, {0.004 + 0.005 * k, 0.005, 0.0006}, {0.8, 0.0, -3.0}, d);
  test::add_particle(scene, {0.03, 0.015, 0.01}, {1.5, 0.0, 0.0}, d);
  test::add_particle(scene, {0.034, 0.015, 0.01}, {-1.5, 0.0, 0.0}, d);
  scene.gravity_m_per_s2 = {0, 0, 0};
  scene.output.impact_spectrum = true;
  scene.output.snapshot_interval_s = 1e-4;
  scene.time.end_s = 1.2e-3;  // long enough for both impacts, too short for a second one
  scene.psd.edges_m = {1e-4, 5e-4, 2e-3};
  scene.output.write_h5 = true;
  test::TempDir dir;
  Simulation sim(scene);
  RunOptions options;
  options.out_dir = dir.path();
  const RunOutcome outcome = run_simulation(sim, scene, options);
  ASSERT_FALSE(outcome.failure);

  const json& s = outcome.summary["impact_spectrum"];
  const std::vector<double> edges = s["energy_edges_j_per_kg"];
  EXPECT_EQ(s["impacts"], 14);
  ASSERT_EQ(s["groups"].size(), 2u);
  std::map<std::string, json> by_kind;
  for (const json& g : s["groups"]) by_kind[g["kind"].get<std::string>()] = g;
  ASSERT_TRUE(by_kind.count("particle-wall") && by_kind.count("particle-particle"));
  EXPECT_EQ(by_kind["particle-wall"]["partner"], "zmin");
  const auto expect_only = [&](const json& rows, std::size_t bin, std::uint64_t count) {
    ASSERT_EQ(rows.size(), 2u);  // two size classes
    for (std::size_t c = 0; c < 2; ++c)
      for (std::size_t b = 0; b < edges.size() - 1; ++b)
        EXPECT_EQ(rows[c][b].get<std::uint64_t>(), c == 1 && b == bin ? count : 0u)
            << "class " << c << " bin " << b;
  };
  expect_only(by_kind["particle-wall"]["normal_counts"], bin_of(edges, 4.5), 12);
  expect_only(by_kind["particle-wall"]["tangential_counts"], bin_of(edges, 0.32), 12);
  expect_only(by_kind["particle-particle"]["normal_counts"], bin_of(edges, 4.5), 2);
  expect_only(by_kind["particle-particle"]["tangential_counts"], 0, 2);
  // The intervals (one per snapshot after the first) add up to the run.
  const std::size_t intervals = s["interval_end_s"].size();
  EXPECT_EQ(intervals + 1, outcome.summary["outputs"]["snapshots"].get<std::size_t>());
  std::uint64_t wall_in_intervals = 0;
  for (const json& row : by_kind["particle-wall"]["interval_normal_counts"])
    for (const json& c : row) wall_in_intervals += c.get<std::uint64_t>();
  EXPECT_EQ(wall_in_intervals, 12u);

  // The plot beside result.json: both panels, a curve per group, named.
  ASSERT_EQ(outcome.summary["outputs"]["impact_spectrum_svg"], "impact_spectrum.svg");
  const std::string svg = test::read_file(dir.path() / "impact_spectrum.svg");
  EXPECT_NE(svg.find("normal impact energy"), std::string::npos);
  EXPECT_NE(svg.find("tangential impact energy"), std::string::npos);
  EXPECT_NE(svg.find(by_kind["particle-wall"]["name"].get<std::string>()), std::string::npos);
  EXPECT_NE(svg.find(by_kind["particle-particle"]["name"].get<std::string>()), std::string::npos);

  const hid_t file = H5Fopen((dir.path() / "run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const std::vector<std::uint64_t> normal = read_counts(file, "/impact_spectrum/normal_counts");
  const std::vector<std::uint64_t> interval =
      read_counts(file, "/impact_spectrum/interval_normal_counts");
  H5Fclose(file);
  const std::size_t bins = edges.size() - 1;
  ASSERT_EQ(normal.size(), 2 * 2 * bins);
  ASSERT_EQ(interval.size(), intervals * normal.size());
  std::vector<std::uint64_t> from_json;
  for (const json& g : s["groups"])
    for (const json& row : g["normal_counts"])
      for (const json& c : row) from_json.push_back(c.get<std::uint64_t>());
  EXPECT_EQ(normal, from_json);
  for (std::size_t c = 0; c < normal.size(); ++c) {
    std::uint64_t sum = 0;
    for (std::size_t k = 0; k < intervals; ++k) sum += interval[k * normal.size() + c];
    EXPECT_EQ(sum, normal[c]) << c;
  }
}

}  // namespace
}  // namespace millsim
