// The turning frame the neighbour list measures motion in (dem/motion_frame.h), against
// independent expectations:
//   - the frame carries a point round its axis as a rotation does (quarter and third turns about
//     a vertical and a tilted axis), and a solid-body rotation at its rate is at rest in it;
//   - walls share an axis only when every one of them turns into itself about it (a mill's
//     chamber does; a box face, or a tube off the axis, does not);
//   - a spinning strand of particles inside a mill's chamber, stepped with the list measuring
//     motion in the turning frame, meets exactly the contacts, pair and wall, that a list searched
//     again every step meets (the brute-force reference), and rebuilds several times less often
//     than a list measuring motion in the lab frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "dem/motion_frame.h"
#include "geometry/mill.h"
#include "scene/mill_json.h"
#include "search/neighbor_list.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

constexpr double kPi = std::numbers::pi;

void expect_near(const Vec3& got, const Vec3& want, double tolerance) {
  EXPECT_NEAR(got.x, want.x, tolerance);
  EXPECT_NEAR(got.y, want.y, tolerance);
  EXPECT_NEAR(got.z, want.z, tolerance);
}

TEST(MotionFrame, CarriesPointsRoundItsAxisAndSeesASolidBodyRotationAtRest) {
  MotionFrame f;
  f.center_m = {1.0, 2.0, 0.0};
  f.omega_rad_per_s = 3.0;
  // A quarter turn counter-clockwise about +z: (c + x̂ + 5ẑ) → (c + ŷ + 5ẑ).
  expect_near(frame_carried(f, {2.0, 2.0, 5.0}, kPi / 6.0), {1.0, 3.0, 5.0}, 1e-14);
  // A third of a turn about the diagonal permutes the axes: x̂ → ŷ → ẑ.
  f.axis = Vec3{1.0, 1.0, 1.0} * (1.0 / std::sqrt(3.0));
  expect_near(frame_carried(f, f.center_m + Vec3{1, 0, 0}, 2.0 * kPi / 9.0),
              f.center_m + Vec3{0, 1, 0}, 1e-14);
  expect_near(frame_carried(f, f.center_m + Vec3{0, 1, 0}, 2.0 * kPi / 9.0),
              f.center_m + Vec3{0, 0, 1}, 1e-14);
  // Solid-body rotation at the frame's rate: at rest; in the lab frame the velocity itself.
  const Vec3 x{0.3, -0.7, 0.2}, offset = x - f.center_m;
  const Vec3 turning = cross(f.axis, offset) * 3.0;
  expect_near(frame_velocity(f, x, turning), {}, 1e-14);
  const MotionFrame lab;
  EXPECT_EQ(frame_speed2(lab, x, {1.0, 2.0, 3.0}), 14.0);
}

std::vector<Wall> walls_of(const std::vector<NamedSurface>& surfaces) {
  std::vector<Wall> walls;
  for (const NamedSurface& s : surfaces) walls.push_back({s.name, s.surface, 0});
  return walls;
}

TEST(MotionFrame, WallsShareAnAxisOnlyWhenEveryOneTurnsIntoItself) {
  const std::vector<Wall> mill = walls_of(mill_surfaces(test::small_mill_chamber()));
  const std::optional<MotionFrame> axis = common_wall_axis(mill);
  ASSERT_TRUE(axis.has_value());
  EXPECT_EQ(norm2(cross(axis->axis, Vec3{0, 0, 1})), 0.0);
  EXPECT_EQ(norm2(cross(axis->center_m - test::small_mill_chamber().axis_point_m, Vec3{0, 0, 1})),
            0.0);
  EXPECT_EQ(axis->omega_rad_per_s, 0.0);

  std::vector<Wall> with_lid = mill;  // a plane normal to the axis turns into itself
  with_lid.push_back({"lid", plane_surface({0, 0, 0.004}, {0, 0, -1}), 0});
  EXPECT_TRUE(common_wall_axis(with_lid).has_value());
  std::vector<Wall> with_face = mill;  // a box face does not
  with_face.push_back({"xmin", plane_surface({0, 0, 0}, {1, 0, 0}), 0});
  EXPECT_FALSE(common_wall_axis(with_face).has_value());
  std::vector<Wall> shifted = mill;  // nor a tube a micrometre off the axis
  shifted.back().surface.point_m.x += 1e-6;
  EXPECT_FALSE(common_wall_axis(shifted).has_value());
  // Planes alone fix no axis.
  EXPECT_FALSE(common_wall_axis({with_lid.back()}).has_value());
}

// A strand spinning round the chamber at 15 m/s, 15 % solids in a band at the mantle, each
// particle with a random 3 m/s of its own: it presses on the mantle and collides within itself.
// With `flyers`, as many particles start inside the strand and fly out into it at 20 m/s (across
// the turning frame: the fastest particles there, and in free flight until they reach it).
// `quiet`: instead a single layer pressed on the mantle, each particle with 0.3 m/s of its own.
SceneConfig spinning_strand(std::optional<double> skin, bool rotating_frame, int flyers = 0,
                            bool quiet = false) {
  SceneConfig s =
      test::empty_scene({0, 0, 0}, {0.02, 0.02, 0.004}, test::table1_material(0.5, 0.3));
  s.mill = test::small_mill_chamber();
  InputErrors errors;
  finish_mill_scene(s, errors);
  EXPECT_TRUE(errors.empty());
  s.gravity_m_per_s2 = {0, 0, 0};
  s.search.skin_m = skin;
  s.search.rotating_frame = rotating_frame;
  const Vec3 c = s.mill->axis_point_m;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0), jitter(-1.0, 1.0);
  std::vector<std::pair<Vec3, double>> placed;
  const double r_out = 0.01, band = quiet ? 0.0 : 0.00025, z_lo = 0.0015, z_hi = 0.0025;
  const double own_speed = quiet ? 0.3 : 3.0;
  while (placed.size() < 900) {
    const double d = 120e-6 + 80e-6 * unit(rng);
    const double rho = r_out - 0.5 * d - band * unit(rng), phi = 2.0 * kPi * unit(rng);
    const Vec3 x = c + Vec3{rho * std::cos(phi), rho * std::sin(phi),
                            z_lo + 0.5 * d + (z_hi - z_lo - d) * unit(rng)};
    bool clear = true;
    for (const auto& [y, dy] : placed) clear = clear && norm(x - y) > 0.5 * (d + dy);
    if (!clear) continue;
    placed.push_back({x, d});
    const Vec3 spin = Vec3{-std::sin(phi), std::cos(phi), 0.0} * 15.0;
    test::add_particle(s, x, spin + Vec3{jitter(rng), jitter(rng), jitter(rng)} * own_speed, d);
  }
  for (int k = 0; k < flyers;) {
    const double rho = 0.0093 + 0.00025 * unit(rng), phi = 2.0 * kPi * unit(rng);
    const Vec3 outwards{std::cos(phi), std::sin(phi), 0.0};
    const Vec3 x = c + outwards * rho + Vec3{0, 0, z_lo + (z_hi - z_lo) * unit(rng)};
    bool clear = true;
    for (const auto& [y, dy] : placed) clear = clear && norm(x - y) > 0.5 * (80e-6 + dy);
    if (!clear) continue;
    placed.push_back({x, 80e-6});
    ++k;
    const Vec3 spin = Vec3{-std::sin(phi), std::cos(phi), 0.0} * (15.0 * rho / r_out);
    test::add_particle(s, x, spin + outwards * 20.0, 80e-6);
  }
  return s;
}

constexpr double kSkin = 10e-6;

TEST(MotionFrame, ASpinningStrandMeetsEveryContactAndRebuildsLessOften) {
  // The same fixed skin in both frames, so that the rebuild counts compare the frames alone.
  Simulation turning(spinning_strand(kSkin, true));
  Simulation lab(spinning_strand(kSkin, false));
  Simulation every_step(spinning_strand(0.0, true));
  ASSERT_NE(turning.neighbors().motion_frame().omega_rad_per_s, 0.0);
  EXPECT_EQ(lab.neighbors().motion_frame().omega_rad_per_s, 0.0);
  std::uint64_t pair_steps = 0, wall_steps = 0;
  const int steps = 1500;
  for (int step = 0; step < steps; ++step) {
    ASSERT_FALSE(turning.step().has_value());
    ASSERT_FALSE(lab.step().has_value());
    ASSERT_FALSE(every_step.step().has_value());
    ASSERT_EQ(every_step.contact_stats().touching_pairs, turning.contact_stats().touching_pairs)
        << "step " << step;
    ASSERT_EQ(every_step.contact_stats().touching_walls, turning.contact_stats().touching_walls)
        << "step " << step;
    pair_steps += turning.contact_stats().touching_pairs > 0 ? 1 : 0;
    wall_steps += turning.contact_stats().touching_walls > 0 ? 1 : 0;
  }
  EXPECT_GT(pair_steps, std::uint64_t(steps / 2)) << "the strand must collide within itself";
  EXPECT_GT(wall_steps, std::uint64_t(steps / 2)) << "and press on the mantle";
  // The same physics: the kinetic energy to the rounding of sums in another order.
  const double ka = turning.energy().kinetic_j, kb = every_step.energy().kinetic_j;
  EXPECT_NEAR(ka, kb, 1e-9 * kb);
  // In the turning frame the strand moves at its own speed (at most 3√3 = 5.2 m/s at the start),
  // in the lab at 15 m/s more: about 4 times as fast, less what the mantle's bounces add to both
  // (116 rebuilds against 34 when written).
  const std::uint64_t turning_rebuilds = turning.neighbors().stats().rebuilds;
  const std::uint64_t lab_rebuilds = lab.neighbors().stats().rebuilds;
  EXPECT_LT(2 * turning_rebuilds, lab_rebuilds)
      << turning_rebuilds << " rebuilds turning, " << lab_rebuilds << " in the lab frame";
  EXPECT_GE(every_step.neighbors().stats().rebuilds, std::uint64_t(steps));
}

// Overlapping pairs among all pairs, by a sweep along x (brute force, no list).
std::uint64_t overlapping_pairs(const ParticleStore& p) {
  std::vector<std::size_t> order(p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return p.position_m[a].x < p.position_m[b].x; });
  const double r_max = *std::max_element(p.radius_m.begin(), p.radius_m.end());
  std::uint64_t overlapping = 0;
  for (std::size_t a = 0; a < order.size(); ++a)
    for (std::size_t b = a + 1; b < order.size(); ++b) {
      const std::size_t i = order[a], j = order[b];
      if (p.position_m[j].x - p.position_m[i].x > 2.0 * r_max) break;
      const double reach = p.radius_m[i] + p.radius_m[j];
      overlapping += norm2(p.position_m[i] - p.position_m[j]) < reach * reach ? 1 : 0;
    }
  return overlapping;
}

TEST(MotionFrame, UnderMultiRateSteppingEveryOverlapIsAContact) {
  // Particles in free flight wait, bounded by their speed relative to the turning frame; the
  // flyers, by far the fastest in it (the layer on the mantle moves at 0.3 m/s in it), wait
  // until they near the layer. Fewer than one particle in a hundred, they get larger shares of
  // the skin (skin by speed), and their pairs are looked at from the start. After each step
  // every particle is where it is: each overlapping pair (all pairs, brute force) must be a
  // contact of the step's force pass, and there are no others.
  SceneConfig scene = spinning_strand(kSkin, true, 8, true);
  scene.time.multi_rate = true;
  Simulation sim(scene);
  ASSERT_NE(sim.neighbors().motion_frame().omega_rad_per_s, 0.0);
  ASSERT_NE(sim.neighbors().speed_report(sim.particles()).scale2, nullptr);
  std::uint64_t contact_steps = 0;
  for (int step = 0; step < 1500; ++step) {
    ASSERT_FALSE(sim.step().has_value());
    const std::uint64_t overlapping = overlapping_pairs(sim.particles());
    ASSERT_EQ(sim.contact_stats().touching_pairs, overlapping) << "step " << step;
    contact_steps += overlapping > 0 ? 1 : 0;
  }
  EXPECT_GT(contact_steps, 750u);
  ASSERT_NE(sim.multi_rate(), nullptr);
  EXPECT_GT(sim.multi_rate()->stats.waiting_particle_steps, 0.0) << "some particles must wait";
}

}  // namespace
}  // namespace millsim
