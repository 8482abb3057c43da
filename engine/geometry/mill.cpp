#include "geometry/mill.h"

#include <cmath>
#include <numbers>

namespace millsim {
namespace {

const Vec3 kAxis{0.0, 0.0, 1.0};

Surface axial_surface(SurfaceKind kind, const MillConfig& mill) {
  Surface s;
  s.kind = kind;
  s.point_m = mill.axis_point_m;
  s.normal = kAxis;
  return s;
}

double tube_mouth_m(const MillConfig& mill) {
  return mill.height_m - mill.outlet.depth_m;
}

}  // namespace

std::vector<NamedSurface> mill_surfaces(const MillConfig& mill) {
  std::vector<NamedSurface> out;
  Surface mantle = axial_surface(SurfaceKind::CylinderInside, mill);
  mantle.radius_m = mill.radius_m;
  out.push_back({"chamber", mantle});

  Surface floor = axial_surface(SurfaceKind::Disc, mill);
  floor.radius_m = mill.radius_m;
  floor.axial_min_m = 0.0;
  floor.facing = 1.0;
  out.push_back({"floor", floor});

  Surface top = axial_surface(SurfaceKind::Disc, mill);
  top.radius_m = mill.radius_m;
  top.inner_radius_m = mill.outlet.radius_m;
  top.axial_min_m = mill.height_m;
  top.facing = -1.0;
  out.push_back({"top_plate", top});

  if (mill.outlet.depth_m > 0.0) {
    Surface tube = axial_surface(SurfaceKind::Tube, mill);
    tube.radius_m = mill.outlet.radius_m;
    tube.axial_min_m = tube_mouth_m(mill);
    tube.axial_max_m = mill.height_m;
    out.push_back({mill.outlet.name + "_tube", tube});
  }
  return out;
}

OutletConfig mill_outlet(const MillConfig& mill) {
  OutletConfig o;
  o.name = mill.outlet.name;
  o.kind = OutletKind::Cylinder;
  o.point_m = mill.axis_point_m;
  o.normal = kAxis;
  o.radius_m = mill.outlet.radius_m;
  o.axial_min_m = tube_mouth_m(mill);
  o.axial_max_m = 1e300;
  return o;
}

bool inside_mill(const MillConfig& mill, const Vec3& x, double radius_m) {
  const Vec3 d = x - mill.axis_point_m;
  const double rho = std::hypot(d.x, d.y);
  if (rho + radius_m > mill.radius_m) return false;
  if (d.z - radius_m < 0.0 || d.z + radius_m > mill.height_m) return false;
  // Clear of the tube's shell and of its inside (the outlet).
  const bool beside_tube = d.z + radius_m > tube_mouth_m(mill);
  if (beside_tube && rho - radius_m < mill.outlet.radius_m) return false;
  return true;
}

JetFrame nozzle_jet(const MillConfig& mill, const NozzleConfig& nozzle) {
  const double c = std::cos(nozzle.azimuth_rad), s = std::sin(nozzle.azimuth_rad);
  const Vec3 radial{c, s, 0.0}, tangent{-s, c, 0.0};
  JetFrame f;
  f.exit_point_m = mill.axis_point_m + radial * mill.radius_m + kAxis * nozzle.height_m;
  f.direction = tangent * std::cos(nozzle.angle_to_tangent_rad) -
                radial * std::sin(nozzle.angle_to_tangent_rad);
  return f;
}

void add_mill_to_gas(const MillConfig& mill, double shell_half_thickness_m, GasConfig& gas) {
  GasSolidConfig outside;
  outside.name = "mill_mantle";
  outside.shape = GasSolidShape::Cylinder;
  outside.center_m = mill.axis_point_m;
  outside.axis = kAxis;
  outside.radius_m = mill.radius_m;
  outside.solid_inside = false;
  gas.solids.push_back(outside);
  if (mill.outlet.depth_m > 0.0) {
    GasSolidConfig tube;
    tube.name = mill.outlet.name + "_tube";
    tube.shape = GasSolidShape::TubeShell;
    tube.center_m = mill.axis_point_m;
    tube.axis = kAxis;
    tube.radius_m = mill.outlet.radius_m;
    tube.half_thickness_m = shell_half_thickness_m;
    tube.axial_min_m = tube_mouth_m(mill);
    tube.axial_max_m = mill.height_m + shell_half_thickness_m;
    gas.solids.push_back(tube);
  }
  GasBoundaryPatch out;
  out.name = mill.outlet.name;
  out.face = 5;  // z+
  out.kind = GasBoundaryKind::Outlet;
  out.shape = PatchShape::Circle;
  out.center_m = mill.axis_point_m + kAxis * mill.height_m;
  out.radius_m = mill.outlet.radius_m;
  out.pressure_pa = mill.outlet.gas_pressure_pa;
  gas.boundaries.push_back(out);
  for (const NozzleConfig& n : mill.nozzles) {
    const JetFrame f = nozzle_jet(mill, n);
    GasJetConfig jet;
    jet.name = n.name;
    jet.exit_point_m = f.exit_point_m;
    jet.direction = f.direction;
    jet.radius_m = 0.5 * n.diameter_m;
    jet.speed_m_per_s = n.speed_m_per_s;
    jet.schedule = n.schedule;
    jet.supply_pressure_pa = n.supply_pressure_pa;
    jet.supply_temperature_k = n.supply_temperature_k;
    gas.jets.push_back(jet);
  }
}

}  // namespace millsim
