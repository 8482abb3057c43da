#include "contact/walls.h"

#include "geometry/mill.h"

namespace millsim {

std::vector<Wall> build_walls(const SceneConfig& scene, MaterialTable& materials) {
  std::vector<Wall> walls;
  const DomainConfig& d = scene.domain;
  const char* axis_names[3] = {"x", "y", "z"};
  for (int a = 0; a < 3 && !scene.mill; ++a) {
    if (d.periodic[a]) continue;
    for (int side = 0; side < 2; ++side) {
      Vec3 normal;
      normal[a] = side == 0 ? 1.0 : -1.0;
      walls.push_back({std::string(axis_names[a]) + (side == 0 ? "min" : "max"),
                       plane_surface(side == 0 ? d.min_m : d.max_m, normal),
                       materials.add_wall(d.wall_material, d.wall_restitution, d.wall_friction)});
    }
  }
  for (const WallConfig& c : scene.walls) {
    Surface surface = plane_surface(c.point_m, c.normal);
    if (c.shape == WallShape::Cylinder)
      surface.kind = SurfaceKind::CylinderInside, surface.radius_m = c.radius_m;
    walls.push_back({c.name, surface, materials.add_wall(c.material, c.restitution, c.friction)});
  }
  if (scene.mill) {
    const MillConfig& m = *scene.mill;
    for (const NamedSurface& s : mill_surfaces(m))
      walls.push_back({s.name, s.surface,
                       materials.add_wall(m.wall_material, m.wall_restitution, m.wall_friction)});
  }
  return walls;
}

int stiffest_wall(const MaterialTable& materials, const std::vector<Wall>& walls) {
  int best = -1;
  double best_compliance = 0.0;
  for (std::size_t w = 0; w < walls.size(); ++w) {
    const double c = materials.wall_pair(walls[w].pair_table, 0).wall_normal_compliance;
    if (best < 0 || c < best_compliance) best = int(w), best_compliance = c;
  }
  return best;
}

}  // namespace millsim
