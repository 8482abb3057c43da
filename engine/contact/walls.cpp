#include "contact/walls.h"

namespace millsim {

std::vector<PlaneWall> build_walls(const SceneConfig& scene, MaterialTable& materials) {
  std::vector<PlaneWall> walls;
  const DomainConfig& d = scene.domain;
  const char* axis_names[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (d.periodic[a]) continue;
    for (int side = 0; side < 2; ++side) {
      PlaneWall w;
      w.name = std::string(axis_names[a]) + (side == 0 ? "min" : "max");
      w.point_m = side == 0 ? d.min_m : d.max_m;
      w.normal[a] = side == 0 ? 1.0 : -1.0;
      w.pair_table = materials.add_wall(d.wall_material, d.wall_restitution, d.wall_friction);
      walls.push_back(w);
    }
  }
  for (const PlaneWallConfig& c : scene.walls)
    walls.push_back(
        {c.name, c.point_m, c.normal, materials.add_wall(c.material, c.restitution, c.friction)});
  return walls;
}

int stiffest_wall(const MaterialTable& materials, const std::vector<PlaneWall>& walls) {
  int best = -1;
  double best_compliance = 0.0;
  for (std::size_t w = 0; w < walls.size(); ++w) {
    const double c = materials.wall_pair(walls[w].pair_table, 0).wall_normal_compliance;
    if (best < 0 || c < best_compliance) best = int(w), best_compliance = c;
  }
  return best;
}

}  // namespace millsim
