// Plane walls: the faces of the domain box on non-periodic axes plus the scene's extra planes.
// A wall is infinite; particles live on the side its unit normal points to.
#pragma once

#include <string>
#include <vector>

#include "core/vec3.h"
#include "dem/box.h"
#include "particles/materials.h"
#include "scene/scene_config.h"

namespace millsim {

struct PlaneWall {
  std::string name;
  Vec3 point_m;
  Vec3 normal;         // unit, pointing into the particle side
  int pair_table = 0;  // index into MaterialTable::wall_pair
};

// Builds the walls of the box faces (named "xmin", "xmax", ...) and the scene's planes, and
// registers each with the material table.
std::vector<PlaneWall> build_walls(const SceneConfig& scene, MaterialTable& materials);

// The stiffest wall (smallest compliance), or −1 when there are none.
int stiffest_wall(const MaterialTable& materials, const std::vector<PlaneWall>& walls);

inline double wall_distance_m(const PlaneWall& w, const Vec3& x) {
  return dot(x - w.point_m, w.normal);
}

}  // namespace millsim
