#include "geometry/surface_mesh.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace millsim {
namespace {

// Two unit vectors completing `axis` (unit) to a right-handed frame.
void frame(const Vec3& axis, Vec3& u, Vec3& v) {
  const Vec3 helper = std::abs(axis.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  u = cross(axis, helper);
  u = u * (1.0 / norm(u));
  v = cross(axis, u);
}

int part_index(SurfaceMesh& mesh, const std::string& name) {
  const auto at = std::find(mesh.part_names.begin(), mesh.part_names.end(), name);
  if (at != mesh.part_names.end()) return int(at - mesh.part_names.begin());
  mesh.part_names.push_back(name);
  return int(mesh.part_names.size() - 1);
}

std::uint32_t add_point(SurfaceMesh& mesh, const Vec3& x) {
  mesh.points_m.push_back(x);
  return std::uint32_t(mesh.points_m.size() - 1);
}

void add_triangle(SurfaceMesh& mesh, std::uint32_t a, std::uint32_t b, std::uint32_t c, int part) {
  mesh.triangles.push_back({a, b, c});
  mesh.part.push_back(part);
}

// A convex polygon (points in order) as a fan.
void add_polygon(SurfaceMesh& mesh, const std::vector<Vec3>& corners, int part) {
  if (corners.size() < 3) return;
  const std::uint32_t first = add_point(mesh, corners[0]);
  std::uint32_t previous = add_point(mesh, corners[1]);
  for (std::size_t k = 2; k < corners.size(); ++k) {
    const std::uint32_t next = add_point(mesh, corners[k]);
    add_triangle(mesh, first, previous, next, part);
    previous = next;
  }
}

// The plane through `point` with unit `normal`, cut to the box: the points where it crosses the
// box's twelve edges, in order around their centre.
std::vector<Vec3> plane_in_box(const Vec3& point, const Vec3& normal, const PeriodicBox& box) {
  const Vec3 lo = box.min_m, hi = box.max_m;
  std::vector<Vec3> hits;
  for (int axis = 0; axis < 3; ++axis)
    for (int corner = 0; corner < 4; ++corner) {
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      Vec3 p0 = lo, p1;
      p0[a1] = (corner & 1) ? hi[a1] : lo[a1];
      p0[a2] = (corner & 2) ? hi[a2] : lo[a2];
      p1 = p0;
      p1[axis] = hi[axis];
      const double d0 = dot(p0 - point, normal), d1 = dot(p1 - point, normal);
      if ((d0 < 0.0) == (d1 < 0.0) && d0 != 0.0) continue;
      const double t = d0 == d1 ? 0.0 : d0 / (d0 - d1);
      const Vec3 x = p0 + (p1 - p0) * t;
      if (std::none_of(hits.begin(), hits.end(),
                       [&](const Vec3& h) { return norm(h - x) < 1e-12 * (1.0 + norm(x)); }))
        hits.push_back(x);
    }
  if (hits.size() < 3) return {};
  Vec3 centre{};
  for (const Vec3& h : hits) centre += h;
  centre = centre * (1.0 / double(hits.size()));
  Vec3 u, v;
  frame(normal, u, v);
  std::sort(hits.begin(), hits.end(), [&](const Vec3& a, const Vec3& b) {
    return std::atan2(dot(a - centre, v), dot(a - centre, u)) <
           std::atan2(dot(b - centre, v), dot(b - centre, u));
  });
  return hits;
}

// The box's extent along an axis through `point`.
void axial_extent(const Vec3& point, const Vec3& axis, const PeriodicBox& box, double& lo,
                  double& hi) {
  lo = 1e300, hi = -1e300;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner{(c & 1) ? box.max_m.x : box.min_m.x, (c & 2) ? box.max_m.y : box.min_m.y,
                      (c & 4) ? box.max_m.z : box.min_m.z};
    const double a = dot(corner - point, axis);
    lo = std::min(lo, a), hi = std::max(hi, a);
  }
}

void add_cylinder(SurfaceMesh& mesh, const Vec3& point, const Vec3& axis, double radius,
                  double axial_lo, double axial_hi, int part) {
  Vec3 u, v;
  frame(axis, u, v);
  const std::uint32_t base = std::uint32_t(mesh.points_m.size());
  for (int k = 0; k < kMeshSegments; ++k) {
    const double phi = 2.0 * std::numbers::pi * k / kMeshSegments;
    const Vec3 radial = (u * std::cos(phi) + v * std::sin(phi)) * radius;
    add_point(mesh, point + axis * axial_lo + radial);
    add_point(mesh, point + axis * axial_hi + radial);
  }
  for (int k = 0; k < kMeshSegments; ++k) {
    const std::uint32_t a = base + 2 * std::uint32_t(k),
                        b = base + 2 * std::uint32_t((k + 1) % kMeshSegments);
    add_triangle(mesh, a, b, a + 1, part);
    add_triangle(mesh, b, b + 1, a + 1, part);
  }
}

void add_annulus(SurfaceMesh& mesh, const Vec3& centre, const Vec3& axis, double inner,
                 double outer, int part) {
  Vec3 u, v;
  frame(axis, u, v);
  // A full disc shares one centre point, so its triangles join without inner edges.
  const std::uint32_t hub = inner > 0.0 ? 0 : add_point(mesh, centre);
  const std::uint32_t base = std::uint32_t(mesh.points_m.size());
  for (int k = 0; k < kMeshSegments; ++k) {
    const double phi = 2.0 * std::numbers::pi * k / kMeshSegments;
    const Vec3 radial = u * std::cos(phi) + v * std::sin(phi);
    if (inner > 0.0) add_point(mesh, centre + radial * inner);
    add_point(mesh, centre + radial * outer);
  }
  const std::uint32_t stride = inner > 0.0 ? 2 : 1;
  for (int k = 0; k < kMeshSegments; ++k) {
    const std::uint32_t a = base + stride * std::uint32_t(k),
                        b = base + stride * std::uint32_t((k + 1) % kMeshSegments);
    if (inner > 0.0) {
      add_triangle(mesh, a, b, a + 1, part);
      add_triangle(mesh, b, b + 1, a + 1, part);
    } else {
      add_triangle(mesh, hub, a, b, part);
    }
  }
}

// The six faces of an axis-aligned box.
void add_box(SurfaceMesh& mesh, const Vec3& lo, const Vec3& hi, int part) {
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      std::vector<Vec3> corners(4, lo);
      for (int c = 0; c < 4; ++c) {
        corners[std::size_t(c)][axis] = side ? hi[axis] : lo[axis];
        corners[std::size_t(c)][a1] = (c == 1 || c == 2) ? hi[a1] : lo[a1];
        corners[std::size_t(c)][a2] = (c >= 2) ? hi[a2] : lo[a2];
      }
      add_polygon(mesh, corners, part);
    }
}

// A gas boundary patch on its domain face.
void add_patch(SurfaceMesh& mesh, const GasBoundaryPatch& p, const PeriodicBox& box, int part) {
  const int axis = p.face / 2;
  const double at = p.face % 2 ? box.max_m[axis] : box.min_m[axis];
  if (p.shape == PatchShape::Circle) {
    Vec3 centre = p.center_m, normal{};
    centre[axis] = at;
    normal[axis] = 1.0;
    add_annulus(mesh, centre, normal, 0.0, p.radius_m, part);
    return;
  }
  Vec3 lo = p.shape == PatchShape::WholeFace ? box.min_m : p.min_m;
  Vec3 hi = p.shape == PatchShape::WholeFace ? box.max_m : p.max_m;
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  std::vector<Vec3> corners(4);
  for (int c = 0; c < 4; ++c) {
    Vec3& x = corners[std::size_t(c)];
    x[axis] = at;
    x[a1] = (c == 1 || c == 2) ? hi[a1] : lo[a1];
    x[a2] = (c >= 2) ? hi[a2] : lo[a2];
  }
  add_polygon(mesh, corners, part);
}

}  // namespace

void add_surface(SurfaceMesh& mesh, const Surface& s, const PeriodicBox& box,
                 const std::string& name) {
  const int part = part_index(mesh, name);
  switch (s.kind) {
    case SurfaceKind::Plane:
      add_polygon(mesh, plane_in_box(s.point_m, s.normal, box), part);
      break;
    case SurfaceKind::CylinderInside: {
      double lo, hi;
      axial_extent(s.point_m, s.normal, box, lo, hi);
      add_cylinder(mesh, s.point_m, s.normal, s.radius_m, lo, hi, part);
      break;
    }
    case SurfaceKind::Tube:
      add_cylinder(mesh, s.point_m, s.normal, s.radius_m, s.axial_min_m, s.axial_max_m, part);
      break;
    case SurfaceKind::Disc:
      add_annulus(mesh, s.point_m + s.normal * s.axial_min_m, s.normal, s.inner_radius_m,
                  s.radius_m, part);
      break;
  }
}

SurfaceMesh scene_geometry(const SceneConfig& scene, const std::vector<Wall>& walls,
                           const PeriodicBox& box, const GasConfig* gas) {
  SurfaceMesh mesh;
  for (const Wall& w : walls) add_surface(mesh, w.surface, box, w.name);
  for (const OutletConfig& o : scene.outlets) {
    const int part = part_index(mesh, o.name);
    switch (o.kind) {
      case OutletKind::Plane:
        add_polygon(mesh, plane_in_box(o.point_m, o.normal, box), part);
        break;
      case OutletKind::Box:
        add_box(mesh, o.min_m, o.max_m, part);
        break;
      case OutletKind::Cylinder: {
        double lo = o.axial_min_m, hi = o.axial_max_m;
        double box_lo, box_hi;
        axial_extent(o.point_m, o.normal, box, box_lo, box_hi);
        add_cylinder(mesh, o.point_m, o.normal, o.radius_m, std::max(lo, box_lo),
                     std::min(hi, box_hi), part);
        break;
      }
    }
  }
  if (gas) {
    for (const GasBoundaryPatch& p : gas->boundaries)
      if (p.kind == GasBoundaryKind::Inlet || p.kind == GasBoundaryKind::Outlet)
        add_patch(mesh, p, box, part_index(mesh, "gas " + p.name));
    for (const GasJetConfig& j : gas->jets)
      add_annulus(mesh, j.exit_point_m, j.direction, 0.0, j.radius_m,
                  part_index(mesh, "jet " + j.name));
  }
  return mesh;
}

}  // namespace millsim
