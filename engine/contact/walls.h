// Walls: the faces of the domain box on non-periodic axes, the scene's extra planes, and a mill's
// chamber (geometry/mill.h). A wall is a surface (geometry/surface.h: plane, cylinder, tube,
// disc) plus the material pair it registers; contacts ask it for the gap and the unit normal at a
// particle, one switch per contact, no virtual call.
#pragma once

#include <string>
#include <vector>

#include "core/vec3.h"
#include "geometry/surface.h"
#include "particles/materials.h"
#include "scene/scene_config.h"

namespace millsim {

struct Wall {
  std::string name;
  Surface surface;
  int pair_table = 0;  // index into MaterialTable::wall_pair
};

// Builds the walls of the box faces (named "xmin", "xmax", ...; none when the scene has a mill,
// whose chamber bounds the particles), the scene's planes and the mill's surfaces, and registers
// each with the material table.
std::vector<Wall> build_walls(const SceneConfig& scene, MaterialTable& materials);

// The stiffest wall (smallest compliance), or −1 when there are none.
int stiffest_wall(const MaterialTable& materials, const std::vector<Wall>& walls);

// Gap from the wall to x, and the unit normal from the wall towards x (surface_gap).
inline double wall_gap_m(const Wall& w, const Vec3& x, Vec3& normal) {
  return surface_gap(w.surface, x, normal);
}
inline double wall_gap_m(const Wall& w, const Vec3& x) {
  return surface_gap(w.surface, x);
}

}  // namespace millsim
