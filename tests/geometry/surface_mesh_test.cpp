// The scene geometry's triangles (run.h5 /geometry): each surface drawn where the contacts see
// it. Areas and radii against their closed forms: a plane cut to the box, an infinite cylinder
// over the box's height, an annulus as the regular polygon it is drawn as.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "geometry/surface_mesh.h"

namespace millsim {
namespace {

double area(const SurfaceMesh& m) {
  double a = 0.0;
  for (const auto& t : m.triangles)
    a +=
        0.5 * norm(cross(m.points_m[t[1]] - m.points_m[t[0]], m.points_m[t[2]] - m.points_m[t[0]]));
  return a;
}

const PeriodicBox kBox{{0, 0, 0}, {1, 2, 3}};

TEST(SurfaceMesh, PlanesAreCutToTheBox) {
  SurfaceMesh across;
  add_surface(across, plane_surface({0.5, 1, 1.5}, {1, 0, 0}), kBox, "x");
  EXPECT_NEAR(area(across), 2.0 * 3.0, 1e-12);  // the y–z face
  SurfaceMesh diagonal;  // through the box's z axis at 45°: a 3 × (√5 … ) rectangle
  const double s = 1.0 / std::sqrt(2.0);
  add_surface(diagonal, plane_surface({0, 0, 0}, {s, -s, 0}), kBox, "d");
  EXPECT_NEAR(area(diagonal), 3.0 * std::sqrt(2.0), 1e-12);  // from (0,0) to (1,1), height 3
  SurfaceMesh outside;
  add_surface(outside, plane_surface({5, 0, 0}, {1, 0, 0}), kBox, "o");
  EXPECT_TRUE(outside.triangles.empty());
}

TEST(SurfaceMesh, CylindersAndDiscsAreTheRegularPolygonsTheyAreDrawnAs) {
  Surface mantle;
  mantle.kind = SurfaceKind::CylinderInside;
  mantle.point_m = {0.5, 1, 0};
  mantle.normal = {0, 0, 1};
  mantle.radius_m = 0.4;
  SurfaceMesh m;
  add_surface(m, mantle, kBox, "chamber");
  const double n = kMeshSegments;
  for (const Vec3& p : m.points_m) {
    EXPECT_NEAR(std::hypot(p.x - 0.5, p.y - 1), 0.4, 1e-12);
    EXPECT_TRUE(p.z == 0.0 || p.z == 3.0);
  }
  // Side of the inscribed polygon times the box's height.
  EXPECT_NEAR(area(m), n * 2 * 0.4 * std::sin(std::numbers::pi / n) * 3.0, 1e-12);

  Surface plate;
  plate.kind = SurfaceKind::Disc;
  plate.point_m = {0.5, 1, 0};
  plate.normal = {0, 0, 1};
  plate.radius_m = 0.4;
  plate.inner_radius_m = 0.1;
  plate.axial_min_m = 2.0;
  SurfaceMesh d;
  add_surface(d, plate, kBox, "top_plate");
  EXPECT_NEAR(area(d), 0.5 * n * std::sin(2 * std::numbers::pi / n) * (0.16 - 0.01), 1e-12);
  for (const Vec3& p : d.points_m) EXPECT_DOUBLE_EQ(p.z, 2.0);
  EXPECT_EQ(d.part_names, std::vector<std::string>{"top_plate"});
}

}  // namespace
}  // namespace millsim
