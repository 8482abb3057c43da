#include "geometry/surface.h"

#include <algorithm>
#include <cmath>

namespace millsim {
namespace {

// Any unit vector perpendicular to the unit axis a (for points exactly on an axis).
Vec3 some_perpendicular(const Vec3& a) {
  const Vec3 t = std::abs(a.x) < 0.9 ? Vec3{1.0, 0.0, 0.0} : Vec3{0.0, 1.0, 0.0};
  const Vec3 p = t - a * dot(t, a);
  return p * (1.0 / norm(p));
}

// Distance from x to the circle of radius `ring_radius` at axial position s_ring, given x's
// axial coordinate s, its distance rho from the axis and the unit radial direction u.
double ring_gap(double s, double rho, const Vec3& u, const Vec3& axis, double ring_radius,
                double s_ring, Vec3& normal) {
  const double dr = rho - ring_radius, ds = s - s_ring;
  const double gap = std::sqrt(dr * dr + ds * ds);
  normal = gap > 0.0 ? (u * dr + axis * ds) * (1.0 / gap) : u;
  return gap;
}

}  // namespace

double surface_gap(const Surface& s, const Vec3& x, Vec3& normal) {
  if (s.kind == SurfaceKind::Plane) {
    normal = s.normal;
    return dot(x - s.point_m, s.normal);
  }
  const Vec3 d = x - s.point_m;
  const double axial = dot(d, s.normal);
  const Vec3 radial = d - s.normal * axial;
  const double rho = norm(radial);
  const Vec3 u = rho > 0.0 ? radial * (1.0 / rho) : some_perpendicular(s.normal);
  switch (s.kind) {
    case SurfaceKind::CylinderInside:
      normal = -u;
      return s.radius_m - rho;
    case SurfaceKind::Tube: {
      const double s_near = std::clamp(axial, s.axial_min_m, s.axial_max_m);
      return ring_gap(axial, rho, u, s.normal, s.radius_m, s_near, normal);
    }
    case SurfaceKind::Disc: {
      if (rho >= s.inner_radius_m && rho <= s.radius_m) {
        normal = s.normal * s.facing;
        return (axial - s.axial_min_m) * s.facing;
      }
      const double edge = rho < s.inner_radius_m ? s.inner_radius_m : s.radius_m;
      return ring_gap(axial, rho, u, s.normal, edge, s.axial_min_m, normal);
    }
    case SurfaceKind::Plane:
      break;
  }
  normal = s.normal;
  return 0.0;
}

double surface_curvature_per_m(const Surface& s, const Vec3& x) {
  if (s.kind == SurfaceKind::CylinderInside) return -1.0 / s.radius_m;
  if (s.kind != SurfaceKind::Tube) return 0.0;
  const Vec3 d = x - s.point_m;
  const double axial = dot(d, s.normal);
  if (axial < s.axial_min_m || axial > s.axial_max_m) return 0.0;  // past the rim
  return norm(d - s.normal * axial) > s.radius_m ? 1.0 / s.radius_m : -1.0 / s.radius_m;
}

}  // namespace millsim
