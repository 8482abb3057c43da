// Loth's (2008) compressible and rarefied sphere drag (gas/mach_drag.h) against independent
// results: at M = 0 it is the standard drag curve (Clift & Gauvin 1970); its free-molecular part
// has Epstein's (1924) slow limit for diffuse reflection and the hypersonic limit C_D → 2; at high
// Mach numbers and Re = 1e5 it gives modified Newtonian theory's C_D = C_p,max / 2 with Rayleigh's
// pitot pressure; the factor on the incompressible laws is 1 at M = 0 in both regimes.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "gas/mach_drag.h"

namespace millsim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kGamma = 1.4;

double clift_gauvin_cd(double re) {
  return 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687)) +
         0.42 / (1.0 + 42500.0 * std::pow(re, -1.16));
}

TEST(MachDrag, AtMachZeroTheCompressionRegimeIsTheStandardDragCurve) {
  for (double re : {46.0, 100.0, 300.0, 1000.0})
    EXPECT_NEAR(loth_drag_coefficient(re, 0.0, 0.0, kGamma) / clift_gauvin_cd(re), 1.0, 2e-3)
        << "Re = " << re;
  // Loth's extra G_M/√Re term lowers the Newton part a little as Re grows (Loth's Fig. 9).
  for (double re : {3e3, 1e4, 3e4, 1e5, 2e5})
    EXPECT_NEAR(loth_drag_coefficient(re, 0.0, 0.0, kGamma) / clift_gauvin_cd(re), 1.0, 0.06)
        << "Re = " << re;
}

TEST(MachDrag, TheFactorIsOneAtMachZeroAndTendsToItAsTheSlipVanishes) {
  for (double re : {0.01, 1.0, 20.0, 45.0, 46.0, 500.0, 1e5})
    for (double kn : {0.0, 0.01, 0.3}) {
      EXPECT_EQ(loth_mach_factor(re, 0.0, kn, kGamma), 1.0);
      EXPECT_NEAR(loth_mach_factor(re, 1e-3, kn, kGamma), 1.0, 1e-3) << re << " " << kn;
    }
  EXPECT_EQ(loth_mach_factor(0.0, 0.5, 0.0, kGamma), 1.0);
}

TEST(MachDrag, TheFreeMolecularDragHasEpsteinsAndTheHypersonicLimits) {
  // Epstein (1924), diffuse reflection with full accommodation: F = (4π/3)(1 + π/8) ρ r² c̄ v,
  // c̄ = √(8kT/(πm)); with s = v / √(2kT/m), C_D = (16 / (3√π)) (1 + π/8) / s.
  const double epstein = 16.0 / (3.0 * std::sqrt(kPi)) * (1.0 + kPi / 8.0);
  for (double s : {1e-4, 1e-3, 0.01})
    EXPECT_NEAR(free_molecular_sphere_cd(s) * s / epstein, 1.0, 2.0 * s * s + 1e-9) << s;
  // Either side of the small-s branch.
  EXPECT_NEAR(free_molecular_sphere_cd(0.999999e-3) / free_molecular_sphere_cd(1e-3), 1.0, 1e-5);
  // Fast flow: C_D → 2 (the oncoming molecules' momentum), plus the thermal spread's 2/s² − 1/(2s⁴)
  // and the diffusely re-emitted molecules' 2√π/(3s) (erf s = 1, e^(−s²) = 0 to 1e-300 here).
  for (double s : {30.0, 100.0})
    EXPECT_NEAR(free_molecular_sphere_cd(s),
                2.0 + 2.0 / (s * s) - 0.5 / (s * s * s * s) + 2.0 * std::sqrt(kPi) / (3.0 * s),
                1e-12)
        << s;
}

TEST(MachDrag, AtHighMachNumbersItGivesModifiedNewtonianTheory) {
  // A sphere in modified Newtonian flow: C_p = C_p,max cos²θ on the front, C_D = C_p,max / 2,
  // with C_p,max from Rayleigh's pitot formula behind the normal shock.
  const double g = kGamma;
  for (double m : {6.0, 10.0}) {
    const double m2 = m * m;
    const double p02_over_p =
        std::pow((g + 1) * (g + 1) * m2 / (4 * g * m2 - 2 * (g - 1)), g / (g - 1)) *
        (1 - g + 2 * g * m2) / (g + 1);
    const double newtonian = 0.5 * (p02_over_p - 1.0) / (0.5 * g * m2);
    EXPECT_NEAR(loth_drag_coefficient(1e5, m, 0.0, g) / newtonian, 1.0, 0.05) << "M = " << m;
  }
}

TEST(MachDrag, SubcriticalDragRisesThroughTheTransonicRange) {
  // The sphere's drag crisis in Mach: from the incompressible value to about twice it past M = 1
  // (Loth's Fig. 7: subcritical spheres rise from 0.4–0.5 to 0.9–1.1), monotonically from 0.3 to
  // 1.5 (below 0.3 the fits stay within 3 % of the incompressible value).
  for (double re : {2e3, 1e4, 1e5}) {
    for (double m = 0.05; m < 0.3; m += 0.05)
      EXPECT_NEAR(loth_mach_factor(re, m, 0.0, kGamma), 1.0, 0.03) << re << " " << m;
    double previous = loth_drag_coefficient(re, 0.3, 0.0, kGamma);
    for (double m = 0.4; m <= 1.501; m += 0.1) {
      const double cd = loth_drag_coefficient(re, m, 0.0, kGamma);
      EXPECT_GT(cd, previous) << "Re = " << re << ", M = " << m;
      previous = cd;
    }
    EXPECT_GT(loth_mach_factor(re, 1.5, 0.0, kGamma), 1.8) << re;
    EXPECT_LT(loth_mach_factor(re, 1.5, 0.0, kGamma), 2.8) << re;
  }
}

TEST(MachDrag, TheRarefiedRegimeBlendsTowardsTheFreeMolecularDrag) {
  // Re ≤ 45: (C_D,Kn,Re + M⁴ C_D,fm,Re) / (1 + M⁴). At Re = 45 the free-molecular part is Loth's
  // J_M, so the drag is nearly independent of M there (his nexus).
  const double continuum = 24.0 / 45.0 * (1.0 + 0.15 * std::pow(45.0, 0.687));
  for (double m : {0.5, 1.0, 2.0, 4.0}) {
    const double m4 = m * m * m * m;
    EXPECT_NEAR(loth_drag_coefficient(45.0, m, 0.0, kGamma),
                (continuum + m4 * loth_j_m(m)) / (1.0 + m4), 1e-12)
        << m;
  }
  // At a small Mach number the continuum part dominates: the standard drag divided by
  // Cunningham's factor with Kn = λ/d (Davies' constants), the slip-corrected Stokes law.
  const double re = 1e-3, kn = 0.2, m = 0.01;
  const double cunningham = 1.0 + kn * (2.514 + 0.8 * std::exp(-0.55 / kn));
  const double slip_stokes = 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687)) / cunningham;
  EXPECT_NEAR(loth_drag_coefficient(re, m, kn, kGamma) / slip_stokes, 1.0, 1e-6);
}

}  // namespace
}  // namespace millsim
