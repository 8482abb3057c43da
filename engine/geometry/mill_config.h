// MillConfig: the scene's `mill` section as plain data (SI units, angles in radians): a flat
// cylindrical grinding chamber about a vertical axis, a central outlet tube (a spiral jet mill's
// vortex finder) reaching down from the top plate, and gas nozzles in the chamber's mantle.
// Parsed and validated by scene/mill_json.cpp; geometry/mill.h turns it into DEM walls, an
// outlet and gas solids, jets and an outlet patch, so DEM and gas see one geometry.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "gas/gas_config.h"

namespace millsim {

// A nozzle in the chamber's mantle. Its jet lies in the horizontal plane through the nozzle and
// points inwards at `angle_to_tangent_rad` to the local tangent of the counter-clockwise
// rotation (seen from +z): 0 = tangential, π/2 = radial.
struct NozzleConfig {
  std::string name;
  double azimuth_rad = 0.0;  // where on the mantle, measured from +x towards +y
  double height_m = 0.0;     // above the chamber floor
  double diameter_m = 0.0;   // exit diameter; the jet carries π d²/4 · speed of gas
  double angle_to_tangent_rad = 0.0;
  double speed_m_per_s = 0.0;              // jet speed at the exit
  std::optional<InflowSchedule> schedule;  // the speed (or mass flow) follows this table instead
  // The compressible gas model: fed from this supply (stagnation) pressure, absolute, instead of
  // a set speed (the grinding pressure; a notional nozzle: gas/compressible/notional_nozzle.h),
  // and the supply's stagnation temperature.
  std::optional<double> supply_pressure_pa;
  double supply_temperature_k = 293.15;
};

struct MillOutletConfig {
  std::string name = "outlet";
  double radius_m = 0.0;  // of the outlet tube (vortex finder)
  double depth_m = 0.0;   // how far the tube reaches down into the chamber from the top plate
  double gas_pressure_pa = 0.0;
};

struct MillConfig {
  Vec3 axis_point_m;  // the chamber's axis at the floor: (x, y, domain min z)
  double radius_m = 0.0;
  double height_m = 0.0;  // floor at domain min z, top plate at domain max z
  int wall_material = 0;
  std::optional<double> wall_restitution;
  std::optional<double> wall_friction;
  MillOutletConfig outlet;
  std::vector<NozzleConfig> nozzles;
};

}  // namespace millsim
