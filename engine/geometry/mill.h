// The mill's geometry, in one place for its three users (DESIGN.md, "mill geometry"): the DEM
// walls (chamber mantle, floor, top plate with its central hole, outlet tube), the DEM outlet
// (the tube's inside: a particle whose centre enters it has left the mill), and the gas grid's
// solids, jets and outlet patch. Every shape is built here from the one MillConfig.
//
// Frame: the chamber's axis is +z through axis_point_m; the floor is at axial 0, the top plate
// at height_m. The outlet tube is a thin shell of the outlet radius from height_m − depth_m up
// to the top plate, where the gas leaves through the top face of the domain.
#pragma once

#include <string>
#include <vector>

#include "gas/gas_config.h"
#include "geometry/mill_config.h"
#include "geometry/surface.h"
#include "scene/scene_config.h"

namespace millsim {

struct NamedSurface {
  std::string name;
  Surface surface;
};

// Mantle ("chamber"), floor ("floor"), top plate ("top_plate"), and the outlet tube
// ("<outlet>_tube") when it reaches into the chamber.
std::vector<NamedSurface> mill_surfaces(const MillConfig& mill);

// The DEM outlet: the inside of the outlet tube, from its mouth upwards.
OutletConfig mill_outlet(const MillConfig& mill);

// True when a sphere of radius `radius_m` centred at x lies in the chamber's free space: inside
// the mantle, between floor and top plate, and clear of the outlet tube and its inside.
bool inside_mill(const MillConfig& mill, const Vec3& x, double radius_m);

// Where a nozzle's jet leaves the mantle and which way it points (unit).
struct JetFrame {
  Vec3 exit_point_m;
  Vec3 direction;
};
JetFrame nozzle_jet(const MillConfig& mill, const NozzleConfig& nozzle);

// Adds the mill to a gas config: the solid outside the mantle, the outlet tube's shell (half as
// thick as `shell_half_thickness_m`, enough to keep the voxelised tube gas-tight), the nozzles as
// jets and the outlet as a pressure patch on the domain's top face.
void add_mill_to_gas(const MillConfig& mill, double shell_half_thickness_m, GasConfig& gas);

}  // namespace millsim
