#include "scene/mill_json.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/json_reader.h"
#include "geometry/mill.h"
#include "scene/gas_json.h"
#include "scene/scene_json.h"

namespace millsim {
namespace {

using nlohmann::json;

constexpr double kDegree = std::numbers::pi / 180.0;

// One entry of /mill/nozzles: `count` nozzles evenly spaced round the mantle from azimuth_deg.
void parse_nozzles(const json& v, const std::string& path, double height_m, const GasConfig* gas,
                   std::vector<NozzleConfig>& out, InputErrors& errors) {
  JsonObjectReader r(v, path, errors);
  NozzleConfig n;
  const std::string name = r.string("name", "nozzle");
  const int count = int(r.integer("count", 1, 1, 64));
  const double azimuth_deg = r.number("azimuth_deg", 0.0, NumberRange::closed(-360.0, 360.0));
  n.height_m = r.required_number("height_m", NumberRange::positive());
  n.diameter_m = r.required_number("diameter_m", NumberRange::open_closed(0.0, 1.0));
  n.angle_to_tangent_rad =
      r.number("angle_to_tangent_deg", 40.0, NumberRange::closed(0.0, 90.0)) * kDegree;
  const bool compressible = gas && gas->model == GasModel::Compressible;
  if (compressible)
    n.supply_temperature_k =
        r.number("supply_temperature_k", gas->compressible.initial_temperature_k,
                 NumberRange::open_closed(0.0, 1e5));
  if (r.has("supply_pressure_pa")) {
    n.supply_pressure_pa =
        r.required_number("supply_pressure_pa", NumberRange::open_closed(0.0, 1e9));
    if (!compressible)
      errors.push_back({r.path_of("supply_pressure_pa"), concat(*n.supply_pressure_pa),
                        gas ? "a nozzle set by its supply pressure needs /gas/model "
                              "\"compressible\" (the incompressible gas has no absolute pressure)"
                            : "a nozzle set by its supply pressure needs a /gas section with "
                              "model \"compressible\""});
    else
      check_supply_pressure(*gas, r.path_of("supply_pressure_pa"), *n.supply_pressure_pa, errors);
    for (const char* key : {"speed_m_per_s", "schedule"})
      if (r.has(key))
        errors.push_back({r.path_of(key), "",
                          "give speed_m_per_s, a schedule or supply_pressure_pa: one of them"});
  } else if (const json* schedule = r.child("schedule")) {
    n.schedule = parse_inflow_schedule(*schedule, r.path_of("schedule"), errors);
    if (compressible)
      errors.push_back({r.path_of("schedule"), "",
                        "the compressible model has no scheduled nozzles yet: give "
                        "supply_pressure_pa or speed_m_per_s"});
    if (r.has("speed_m_per_s"))
      errors.push_back(
          {r.path_of("speed_m_per_s"), "", "give speed_m_per_s or a schedule, not both"});
  } else {
    n.speed_m_per_s = r.required_number("speed_m_per_s", NumberRange::open_closed(0.0, 1000.0));
  }
  r.finish();
  if (r.is_object() &&
      (n.height_m - 0.5 * n.diameter_m <= 0.0 || n.height_m + 0.5 * n.diameter_m >= height_m))
    errors.push_back(
        {r.path_of("height_m"), concat(n.height_m),
         concat("the nozzle (diameter ", n.diameter_m,
                " m) must lie on the mantle, between the floor (0) and the top plate (", height_m,
                " m above it)")});
  for (int k = 0; k < count; ++k) {
    NozzleConfig c = n;
    c.name = count == 1 ? name : concat(name, k);
    c.azimuth_rad = (azimuth_deg + 360.0 * k / count) * kDegree;
    out.push_back(c);
  }
}

// The eight corners of a box region.
std::vector<Vec3> corners(const Vec3& lo, const Vec3& hi) {
  std::vector<Vec3> out;
  for (int k = 0; k < 8; ++k)
    out.push_back({k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z});
  return out;
}

bool region_inside_mill(const MillConfig& mill, const Vec3& lo, const Vec3& hi) {
  for (const Vec3& c : corners(lo, hi))
    if (!inside_mill(mill, c, 0.0)) return false;
  return true;
}

}  // namespace

MillConfig parse_mill(const json& v, const DomainConfig& domain,
                      const std::vector<MaterialConfig>& materials, const GasConfig* gas,
                      InputErrors& errors) {
  MillConfig m;
  JsonObjectReader r(v, "/mill", errors);
  if (!r.is_object()) return m;
  m.height_m = domain.max_m.z - domain.min_m.z;
  std::array<double, 2> centre{0.5 * (domain.min_m.x + domain.max_m.x),
                               0.5 * (domain.min_m.y + domain.max_m.y)};
  if (const json* c = r.child("center_xy_m")) {
    const bool ok = c->is_array() && c->size() == 2 && (*c)[0].is_number() && (*c)[1].is_number();
    if (ok)
      centre = {(*c)[0].get<double>(), (*c)[1].get<double>()};
    else
      errors.push_back({"/mill/center_xy_m", json_value_text(*c), "expected [x, y] in metres"});
  }
  m.axis_point_m = {centre[0], centre[1], domain.min_m.z};
  m.radius_m = r.required_number("radius_m", NumberRange::open_closed(0.0, 100.0));
  if (r.has("wall_material"))
    m.wall_material = find_material(materials, r, "wall_material", errors, false);
  m.wall_restitution = r.optional_number("wall_restitution", NumberRange::closed(0.05, 1.0));
  m.wall_friction = r.optional_number("wall_friction", NumberRange::closed(0.0, 10.0));
  if (const json* o = r.child("outlet")) {
    JsonObjectReader ro(*o, "/mill/outlet", errors);
    m.outlet.name = ro.string("name", "outlet");
    m.outlet.radius_m = ro.required_number("radius_m", NumberRange::open_closed(0.0, 100.0));
    m.outlet.depth_m = ro.number("depth_m", 0.0, NumberRange::non_negative());
    if (gas && gas->model == GasModel::Compressible)  // absolute: the chamber's pressure if not set
      m.outlet.gas_pressure_pa = ro.number("gas_pressure_pa", gas->compressible.initial_pressure_pa,
                                           NumberRange::open_closed(0.0, 1e9));
    else
      m.outlet.gas_pressure_pa = ro.number("gas_pressure_pa", 0.0, NumberRange::closed(-1e9, 1e9));
    ro.finish();
  } else {
    errors.push_back(
        {"/mill/outlet", "", "missing; expected {\"radius_m\": ..., \"depth_m\": ...}"});
  }
  if (const json* list = r.array("nozzles"))
    for (std::size_t i = 0; i < list->size(); ++i)
      parse_nozzles((*list)[i], json_pointer_join("/mill/nozzles", i), m.height_m, gas, m.nozzles,
                    errors);
  r.finish();

  if (m.radius_m > 0.0) {
    const double x0 = centre[0] - m.radius_m, x1 = centre[0] + m.radius_m;
    const double y0 = centre[1] - m.radius_m, y1 = centre[1] + m.radius_m;
    if (x0 < domain.min_m.x || x1 > domain.max_m.x || y0 < domain.min_m.y || y1 > domain.max_m.y)
      errors.push_back({"/mill/radius_m", concat(m.radius_m),
                        concat("the chamber (axis at x = ", centre[0], ", y = ", centre[1],
                               ") must fit inside the domain box in x and y")});
  }
  if (m.outlet.radius_m >= m.radius_m && m.outlet.radius_m > 0.0)
    errors.push_back({"/mill/outlet/radius_m", concat(m.outlet.radius_m),
                      concat("expected less than the chamber radius ", m.radius_m)});
  if (m.outlet.depth_m >= m.height_m)
    errors.push_back(
        {"/mill/outlet/depth_m", concat(m.outlet.depth_m),
         concat("expected less than the chamber height ", m.height_m, " (the domain's z extent)")});
  for (int a = 0; a < 3; ++a)
    if (domain.periodic[std::size_t(a)]) {
      errors.push_back(
          {"/domain/periodic", "", "a mill's chamber is closed: no axis may be periodic"});
      break;
    }
  return m;
}

void finish_mill_scene(SceneConfig& scene, InputErrors& errors) {
  if (!scene.mill) return;
  const MillConfig& mill = *scene.mill;
  for (std::size_t i = 0; i < scene.feeds.size(); ++i)
    if (!region_inside_mill(mill, scene.feeds[i].region_min_m, scene.feeds[i].region_max_m))
      errors.push_back({concat("/feeds/", i, "/region"), "",
                        "expected the region to lie inside the mill's chamber: within the "
                        "mantle, between floor and top plate, clear of the outlet tube"});
  for (std::size_t i = 0; i < scene.sources.size(); ++i) {
    const SourceConfig& s = scene.sources[i];
    if (s.kind == SourceKind::Random && !region_inside_mill(mill, s.region_min_m, s.region_max_m))
      errors.push_back({concat("/sources/", i, "/region"), "",
                        "expected the region to lie inside the mill's chamber: within the "
                        "mantle, between floor and top plate, clear of the outlet tube"});
  }
  scene.outlets.push_back(mill_outlet(mill));
  if (!scene.gas) return;
  const Vec3 extent = scene.domain.max_m - scene.domain.min_m;
  const double h = std::max(extent.x / scene.gas->cells[0], extent.y / scene.gas->cells[1]);
  if (mill.outlet.radius_m < 1.5 * h)
    errors.push_back({"/mill/outlet/radius_m", concat(mill.outlet.radius_m),
                      concat("with gas cells of ", h,
                             " m across, the voxelised outlet tube needs "
                             "a radius of at least 1.5 cells (",
                             1.5 * h, " m): refine /gas/cells")});
  add_mill_to_gas(mill, 0.55 * std::max(h, extent.z / scene.gas->cells[2]), *scene.gas);
}

}  // namespace millsim
