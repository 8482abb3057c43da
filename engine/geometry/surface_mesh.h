// SurfaceMesh: the scene's geometry as triangles, for pictures (run.h5 /geometry, drawn by
// ParaView from run.xdmf). Walls are drawn from the same Surface numbers the contacts use
// (geometry/surface.h), unbounded ones clipped to the domain box; outlets, the gas's boundary
// patches and the mill's nozzle exits are drawn as the regions the engine tests against. Each
// triangle names its part (an index into part_names).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "contact/walls.h"
#include "dem/box.h"
#include "gas/gas_config.h"
#include "geometry/surface.h"
#include "scene/scene_config.h"

namespace millsim {

struct SurfaceMesh {
  std::vector<Vec3> points_m;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::int32_t> part;  // per triangle
  std::vector<std::string> part_names;
};

// Segments around a circle.
inline constexpr int kMeshSegments = 64;

// Adds one surface as triangles: planes as their polygon inside the box, an infinite cylinder
// over the box's extent along its axis, tubes over their length, discs as annuli.
void add_surface(SurfaceMesh& mesh, const Surface& s, const PeriodicBox& box,
                 const std::string& name);

// Walls, outlets, the gas's inlet and outlet patches and jets (none of a section the scene
// lacks).
SurfaceMesh scene_geometry(const SceneConfig& scene, const std::vector<Wall>& walls,
                           const PeriodicBox& box, const GasConfig* gas);

}  // namespace millsim
