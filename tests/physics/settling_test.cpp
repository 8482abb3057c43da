// A column of particles dropped under gravity comes to rest as a packed bed:
//   the kinetic energy falls to a negligible fraction of the potential energy released,
//   every particle stays inside the column, and the bed's solids fraction lies between random
//   loose and random close packing of spheres (≈ 0.55–0.64; a narrow column packs looser near
//   its walls, so the band is widened to 0.45–0.66).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/simulation.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

TEST(Settling, ColumnComesToRestAsPackedBed) {
  MILLSIM_RELEASE_ONLY(
      "LowRestitution.TwoSpheresSeparateAtETimesTheImpactSpeed and the contact tests");
  const double w = 8e-3, h = 40e-3;
  MaterialConfig beads = test::table1_material(0.5, 0.4);
  beads.youngs_modulus_pa = 5e7;
  beads.density_kg_per_m3 = 2500;
  SceneConfig s = test::empty_scene({0, 0, 0}, {w, w, h}, beads);
  s.gravity_m_per_s2 = {0, 0, -9.81};
  SourceConfig source;
  source.kind = SourceKind::Random;
  source.count = 300;
  source.region_min_m = {0, 0, 0};
  source.region_max_m = {w, w, h};
  source.sizes = {SizeDistributionKind::Uniform, 0.0, 0.9e-3, 1.1e-3};
  s.sources.push_back(source);
  s.time.end_s = 0.35;
  Simulation sim(s);
  const double potential_start = sim.energy().potential_j;
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step().has_value());

  const EnergyReport end = sim.energy();
  const double released = potential_start - end.potential_j;
  EXPECT_GT(released, 0.0);
  EXPECT_LT(end.kinetic_j + end.rotational_j, 1e-6 * released) << "the bed is still moving";

  const ParticleStore& p = sim.particles();
  double solid_volume = 0.0, top = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3& x = p.position_m[i];
    const double r = p.radius_m[i];
    EXPECT_GT(x.z, 0.5 * r) << "particle " << p.id[i] << " sank into the floor";
    EXPECT_TRUE(x.x > 0 && x.x < w && x.y > 0 && x.y < w) << "particle " << p.id[i];
    solid_volume += 4.0 / 3.0 * std::numbers::pi * r * r * r;
    top = std::max(top, x.z + r);
  }
  // The top layer is ragged; measure the bed to the mean height of its top particles instead
  // of the highest one: use the centroid, z̄ = H/2 for a uniform bed.
  double z_mean = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) z_mean += p.position_m[i].z / double(p.size());
  const double bed_height = 2.0 * z_mean;
  const double solids_fraction = solid_volume / (w * w * bed_height);
  EXPECT_GT(solids_fraction, 0.45);
  EXPECT_LT(solids_fraction, 0.66);
  EXPECT_LT(top, h / 2) << "the bed should be far below the initial column";
}

}  // namespace
}  // namespace millsim
