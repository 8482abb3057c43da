// Packed and fluidized beds (cases/fluidized_bed.json) against Ergun (1952): the pressure
// gradient through the fixed bed at the bed's measured voidage, and fluidization between 0.8
// and 1.2 times the minimum fluidization velocity Ergun predicts for that voidage: below it
// the gas carries part of the bed's weight, above it all of it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "scene/scene_json.h"
#include "sim/simulation.h"
#include "support/sanitizers.h"

namespace millsim {
namespace {

constexpr double kPi = std::numbers::pi, kG = 9.81;

struct Bed {
  double top_m = 0.0;              // height below which 98 % of the particle volume lies
  double voidage = 0.0;            // in the slab [3, 5] mm
  double gradient_pa_per_m = 0.0;  // −dp/dz between the cell centres at 3 and 5 mm
  double drop_pa = 0.0;            // from the distributor to 20 mm
  double weight_pa = 0.0;          // buoyant weight of the bed per area
  double density_kg_per_m3 = 0.0, viscosity_pa_s = 0.0, diameter_m = 0.0, gas_density = 0.0;
};

// Volume of a sphere (centre zc, radius r) between heights z0 and z1.
double slab_volume(double zc, double r, double z0, double z1) {
  const double a = std::max(z0 - zc, -r), b = std::min(z1 - zc, r);
  if (b <= a) return 0.0;
  const auto F = [r](double t) { return kPi * (r * r * t - t * t * t / 3.0); };
  return F(b) - F(a);
}

// Mean gas pressure over the cells whose centre is at height z.
double layer_pressure(const GasSolver& gas, double z) {
  const GasGrid& g = gas.grid();
  const int k = int(std::lround((z - g.origin_m.z) / g.h_m.z + 0.5));
  double sum = 0.0;
  for (int j = 1; j <= g.n[1]; ++j)
    for (int i = 1; i <= g.n[0]; ++i) sum += gas.pressure()[g.index(i, j, k)];
  return sum / (g.n[0] * g.n[1]);
}

Bed run_bed(double superficial_m_per_s, double end_s, std::optional<DragLaw> drag = std::nullopt) {
  SceneConfig scene = load_scene(std::string(MILLSIM_SOURCE_DIR) + "/cases/fluidized_bed.json");
  if (drag) scene.gas->drag = *drag;
  scene.gas->boundaries.at(0).velocity_m_per_s.z = superficial_m_per_s;
  scene.time.end_s = end_s;
  Simulation sim(scene);
  while (sim.step_index() < sim.total_steps()) {
    const auto failure = sim.step();
    EXPECT_FALSE(failure) << failure->detail;
    if (failure) break;
  }
  const ParticleStore& p = sim.particles();
  const GasSolver& gas = sim.gas()->gas();
  const GasGrid& g = gas.grid();
  const double area = (g.n[0] * g.h_m.x) * (g.n[1] * g.h_m.y);
  Bed bed;
  bed.gas_density = scene.gas->density_kg_per_m3;
  bed.viscosity_pa_s = scene.gas->viscosity_pa_s;
  bed.density_kg_per_m3 = scene.materials[0].density_kg_per_m3;
  bed.diameter_m = 2.0 * p.radius_m[0];
  std::vector<double> tops;
  double solid = 0.0, mass = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    tops.push_back(p.position_m[i].z + p.radius_m[i]);
    solid += slab_volume(p.position_m[i].z, p.radius_m[i], 0.003, 0.005);
    mass += p.mass_kg[i];
  }
  std::sort(tops.begin(), tops.end());
  bed.top_m = tops[std::size_t(0.98 * double(tops.size()))];
  // Inside the bed, away from its surface.
  bed.voidage = 1.0 - solid / (area * 0.002);
  bed.gradient_pa_per_m = (layer_pressure(gas, 0.003) - layer_pressure(gas, 0.005)) / 0.002;
  // The distributor pressure: the first cell centre's (1 mm) plus the gas's weight over the
  // half cell below it; the drag of the particles there is already in it (gas/pressure_probe.h).
  // The gas's own weight is not the bed's: the drop leaves out ρ g over the 21 mm.
  bed.drop_pa =
      layer_pressure(gas, 0.001) - layer_pressure(gas, 0.021) - bed.gas_density * kG * 0.020;
  bed.weight_pa = mass * kG * (1.0 - bed.gas_density / bed.density_kg_per_m3) / area;
  return bed;
}

double ergun_gradient(const Bed& b, double U) {
  const double e = b.voidage, d = b.diameter_m;
  return 150.0 * (1 - e) * (1 - e) * b.viscosity_pa_s * U / (e * e * e * d * d) +
         1.75 * (1 - e) * b.gas_density * U * U / (e * e * e * d);
}

// u_mf from Ergun = buoyant weight per bed volume, (1 − ε)(ρ_p − ρ_g) g.
double ergun_minimum_fluidization(const Bed& b) {
  const double target = (1 - b.voidage) * (b.density_kg_per_m3 - b.gas_density) * kG;
  double lo = 0.0, hi = 10.0;
  for (int k = 0; k < 200; ++k) {
    const double u = 0.5 * (lo + hi);
    (ergun_gradient(b, u) < target ? lo : hi) = u;
  }
  return 0.5 * (lo + hi);
}

TEST(PackedBed, PressureGradientMatchesErgun) {
  const double U = 0.1;
  const Bed bed = run_bed(U, 0.2);
  ASSERT_GT(bed.voidage, 0.3);
  ASSERT_LT(bed.voidage, 0.55);
  const double expected = ergun_gradient(bed, U) + bed.gas_density * kG;
  std::printf(
      "packed bed U = %.3f m/s: voidage %.4f, -dp/dz %.1f Pa/m, Ergun %.1f Pa/m (%.2f %%)\n", U,
      bed.voidage, bed.gradient_pa_per_m, expected,
      100.0 * (bed.gradient_pa_per_m / expected - 1.0));
  EXPECT_NEAR(bed.gradient_pa_per_m, expected, 0.10 * expected);
  EXPECT_LT(bed.drop_pa, bed.weight_pa);  // a fixed bed: the gas carries only part of it
}

// The same packed bed with Koch–Hill drag: the gradient is Koch–Hill's total force per particle
// summed over the bed, 18 μ φ F(ε, Re) U / d² with F = F0 + ½ F3 Re (Hill, Koch & Ladd 2001, the
// dense branch 10 φ/ε³ here), Re = ρ d U / μ, at the bed's measured voidage.
TEST(PackedBed, PressureGradientMatchesKochHill) {
  MILLSIM_RELEASE_ONLY(
      "PackedBed.PressureGradientMatchesErgun (the same bed and solver, another drag law)");
  const double U = 0.1;
  const Bed bed = run_bed(U, 0.2, DragLaw::KochHill);
  ASSERT_GT(bed.voidage, 0.3);
  ASSERT_LT(bed.voidage, 0.55);
  const double eps = bed.voidage, phi = 1 - eps, d = bed.diameter_m;
  const double re = bed.gas_density * d * U / bed.viscosity_pa_s;
  const double f =
      10 * phi / (eps * eps * eps) + 0.5 * (0.0673 + 0.212 * phi + 0.0232 / std::pow(eps, 5)) * re;
  const double expected = 18 * bed.viscosity_pa_s * phi * f * U / (d * d) + bed.gas_density * kG;
  std::printf("packed bed, Koch-Hill: voidage %.4f, -dp/dz %.1f Pa/m, expected %.1f Pa/m\n", eps,
              bed.gradient_pa_per_m, expected);
  EXPECT_NEAR(bed.gradient_pa_per_m, expected, 0.10 * expected);
}

TEST(FluidizedBed, FluidizesBetweenPointEightAndOnePointTwoTimesErgunMinimum) {
  MILLSIM_RELEASE_ONLY("PackedBed.PressureGradientMatchesErgun and tests/gas/coupling_test.cpp");
  const Bed packed = run_bed(0.1, 0.2);
  const double u_mf = ergun_minimum_fluidization(packed);
  const Bed below = run_bed(0.8 * u_mf, 0.25);
  const Bed above = run_bed(1.2 * u_mf, 0.25);
  std::printf(
      "Ergun u_mf = %.4f m/s at voidage %.4f; at 0.8 u_mf: dp/W = %.3f, top %.2f mm; at 1.2 "
      "u_mf: dp/W = %.3f, top %.2f mm (packed top %.2f mm)\n",
      u_mf, packed.voidage, below.drop_pa / below.weight_pa, 1e3 * below.top_m,
      above.drop_pa / above.weight_pa, 1e3 * above.top_m, 1e3 * packed.top_m);
  EXPECT_LT(below.drop_pa / below.weight_pa, 0.95);  // still resting on the distributor
  EXPECT_LT(below.top_m, 1.03 * packed.top_m);
  EXPECT_NEAR(above.drop_pa / above.weight_pa, 1.0, 0.1);  // the gas carries the whole bed
}

}  // namespace
}  // namespace millsim
