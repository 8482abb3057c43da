// Surface: the shapes DEM walls are made of, as plain data, and the one function that measures
// a point against them. A wall is a surface plus a material (contact/walls.h); the mill module
// (geometry/mill.h) builds its chamber from these, and the gas grid voxelises the same numbers.
//
//   Plane           infinite; particles on the side its unit normal points to
//   CylinderInside  the inside of an infinite circular cylinder (a chamber's mantle); one-sided
//   Tube            a thin cylindrical shell of finite length (an outlet tube); two-sided, with
//                   rounded rims: past either end the nearest point is on the rim circle
//   Disc            a flat annulus (an end plate, possibly with a central hole) at one axial
//                   position, facing one way; past its inner or outer edge the nearest point is
//                   on that edge circle
//
// surface_gap() returns the distance from x to the surface along the returned unit normal,
// which points from the surface towards x: a sphere of radius r overlaps by r − gap. On the
// one-sided shapes (Plane, CylinderInside, a Disc over its face) the gap is signed: negative
// behind the surface. Every gap is 1-Lipschitz in x, so a Verlet skin bounds how far it can
// close between rebuilds exactly as for planes.
#pragma once

#include <cstdint>

#include "core/vec3.h"

namespace millsim {

enum class SurfaceKind : std::uint8_t { Plane, CylinderInside, Tube, Disc };

struct Surface {
  SurfaceKind kind = SurfaceKind::Plane;
  Vec3 point_m;  // plane: a point on it; others: the point of the axis at axial coordinate 0
  Vec3 normal;   // plane: unit normal to the particle side; others: unit axis direction
  double radius_m = 0.0;        // cylinder, tube: radius; disc: outer radius
  double inner_radius_m = 0.0;  // disc: radius of the central hole (0 = none)
  double axial_min_m = 0.0;     // tube: axial extent [min, max]; disc: its axial position (min)
  double axial_max_m = 0.0;
  double facing = 1.0;  // disc: +1 = particles on the +axis side, −1 = on the −axis side
};

inline Surface plane_surface(const Vec3& point_m, const Vec3& unit_normal) {
  Surface s;
  s.kind = SurfaceKind::Plane;
  s.point_m = point_m;
  s.normal = unit_normal;
  return s;
}

// Gap between x and the surface; `normal` receives the unit direction from the surface to x.
double surface_gap(const Surface& s, const Vec3& x, Vec3& normal);

// Curvature of the surface across its axis at the point nearest x, 1/m: positive where the
// surface bulges towards x (a tube seen from outside), negative where it curves round it (a
// cylinder's inside, a tube's); 0 on planes and disc faces. Along the axis the curvature is 0.
// Rims and edge circles are edges, not smooth surfaces: 0 there too (contact/curved_contact.h).
double surface_curvature_per_m(const Surface& s, const Vec3& x);

// True only when the gap at x certainly exceeds `distance_m` (a sphere of that radius cannot
// touch), decided without the square root surface_gap takes; false when it cannot tell cheaply
// (then ask surface_gap). Exact on planes; on a cylinder's inside and a disc it keeps a relative
// margin of 1e-9, far above the rounding of either test, so it never says apart where
// surface_gap would find an overlap. A disc's gap is never less than the distance to its plane
// on its facing side (over the face it is that distance, past an edge the edge circle's).
inline bool surface_certainly_beyond(const Surface& s, const Vec3& x, double distance_m) {
  if (s.kind == SurfaceKind::Plane) return dot(x - s.point_m, s.normal) >= distance_m;
  if (s.kind == SurfaceKind::Disc)
    return (dot(x - s.point_m, s.normal) - s.axial_min_m) * s.facing > distance_m * (1.0 + 1e-9);
  if (s.kind != SurfaceKind::CylinderInside) return false;
  const double inner = s.radius_m - distance_m;  // the gap exceeds distance_m for ρ below it
  if (!(inner > 0.0)) return false;
  const Vec3 d = x - s.point_m;
  const Vec3 radial = d - s.normal * dot(d, s.normal);
  return norm2(radial) < inner * inner * (1.0 - 1e-9);
}

// The gap alone (candidate tests).
inline double surface_gap(const Surface& s, const Vec3& x) {
  Vec3 n;
  return surface_gap(s, x, n);
}

}  // namespace millsim
