// The drag of a sphere in a compressible, rarefied gas after Loth (AIAA J. 46 (2008) 2219), as a
// factor on millsim's incompressible drag laws (gas/drag.h). Loth's correlation covers Mach
// numbers up to hypersonic and Knudsen numbers up to free-molecular flow in two regimes that meet
// near Re = 45, where the drag hardly depends on M (his "nexus"):
//   compression-dominated, Re > 45:
//     C_D = 24/Re (1 + 0.15 Re^0.687) H_M + 0.42 C_M / (1 + 42500 / Re^(1.16 C_M) + G_M / √Re),
//   rarefaction-dominated, Re ≤ 45:
//     C_D = (C_D,Kn,Re + M⁴ C_D,fm,Re) / (1 + M⁴),
//     C_D,Kn,Re = 24/Re (1 + 0.15 Re^0.687) / C(Kn)  (C: Cunningham's factor, Kn = λ/d here),
//     C_D,fm,Re = C_D,fm / (1 + (C_D,fm / J_M − 1) √(Re/45)),
//   with C_D,fm the free-molecular drag of a diffusely reflecting sphere at the gas's temperature
//   (speed ratio s = M √(γ/2)), and C_M, G_M, H_M, J_M Loth's fits in M.
// The factor ξ(Re, M, Kn) = C_D(Re, M, Kn) / C_D(Re, 0, Kn) multiplies whichever law the scene
// uses, as Parmar et al. (AIAA J. 48 (2010) 1273) write their Mach correction: ξ = 1 at M = 0,
// so a slow particle keeps the law it had, and Cunningham's correction (applied separately)
// keeps the rarefaction of the M = 0 drag. Re is the particle Reynolds number ρ d |u − v| / μ.
// Left out: the particle's own temperature (taken as the gas's), and the 15 % jump of Loth's G_M
// fit at M = 0.8 and the few-percent step between the regimes at Re = 45 are kept as published.
#pragma once

namespace millsim {

// Loth's fits in the slip Mach number M.
double loth_c_m(double mach);
double loth_g_m(double mach);
double loth_h_m(double mach);
double loth_j_m(double mach);

// Free-molecular drag coefficient of a sphere with diffuse reflection at the gas's temperature,
// speed ratio s = |u − v| / √(2 R T) > 0.
double free_molecular_sphere_cd(double speed_ratio);

// Loth's drag coefficient at particle Reynolds number Re > 0, slip Mach number M ≥ 0, Knudsen
// number λ/d and heat capacity ratio γ.
double loth_drag_coefficient(double reynolds, double mach, double knudsen, double gamma);

// ξ = C_D(Re, M, Kn) / C_D(Re, 0, Kn): 1 at M = 0 (and for Re = 0 or M = 0 exactly).
double loth_mach_factor(double reynolds, double mach, double knudsen, double gamma);

}  // namespace millsim
