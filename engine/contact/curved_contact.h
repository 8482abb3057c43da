// Hertz for a sphere against a curved wall. A sphere of radius r touching a surface whose
// principal curvatures are κ (across a cylinder's axis; positive convex, negative concave) and 0
// (along the axis) makes an elliptic contact (Johnson, Contact Mechanics, 1985, §4.2). Its force
// is still k δ^{3/2}, with k = (4/3) E* √R_e: the equivalent radius R_e takes the place of the
// sphere's radius that a flat wall uses (Eq. 5). Inside a cylinder of 2 radii a flat-wall Hertz
// overshoots the peak overlap by 7.6 % and undershoots the peak force by 7.1 %.
//
// The tangential spring uses the same R_e (8 G* √(R_e δ)): Mindlin's compliance of an ellipse
// differs from that of the circle of the same area by a factor near 1 for the contacts a cylinder
// makes (docs/contact-model.md).
#pragma once

namespace millsim {

// The elliptic contact of two bodies whose relative curvatures are in ratio B/A ≥ 1 (Johnson
// §4.2): the ellipse's eccentricity e and G = R_e / R_A, the equivalent radius over the larger
// relative radius of curvature 1/(2A). Solved exactly (bisection on Johnson's Eq. 4.39 with the
// complete elliptic integrals K(e) and E(e)); G = 1 for a circle.
struct EllipticContact {
  double eccentricity = 0.0;
  double radius_factor = 1.0;
};
EllipticContact elliptic_hertz_contact(double curvature_ratio);

// R_e of a sphere of radius r on a surface of curvature κ across its axis (above); r on a flat
// one. From a table of G over t = 1 − A/B (interpolation error below 1e-6), exact past its end.
double equivalent_contact_radius_m(double sphere_radius_m, double wall_curvature_per_m);

}  // namespace millsim
