#include "scene/gas_json.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "core/json_reader.h"

namespace millsim {
namespace {

using nlohmann::json;

const std::vector<std::string> kFaceNames = {"x-", "x+", "y-", "y+", "z-", "z+"};

int face_index(const std::string& name) {
  for (std::size_t k = 0; k < kFaceNames.size(); ++k)
    if (kFaceNames[k] == name) return int(k);
  return 0;
}

Vec3 unit_vector(JsonObjectReader& r, std::string_view key, InputErrors& errors) {
  const Vec3 v = r.vec3(key, {});
  if (r.is_object() && norm(v) < 1e-12) {
    errors.push_back({r.path_of(key), "[0,0,0]", "missing or zero; expected a non-zero vector"});
    return {0, 0, 1};
  }
  return v * (1.0 / norm(v));
}

// A column of a schedule: an array of numbers in `range`, 1 to 10000 of them.
std::vector<double> schedule_column(const json* v, const std::string& path, NumberRange range,
                                    InputErrors& errors) {
  std::vector<double> out;
  if (!v) return out;
  if (!v->is_array() || v->empty() || v->size() > 10000) {
    errors.push_back({path, json_value_text(*v), "expected an array of 1 to 10000 numbers"});
    return out;
  }
  for (std::size_t k = 0; k < v->size(); ++k)
    if (auto x = read_number((*v)[k], json_pointer_join(path, k), range, errors)) out.push_back(*x);
  return out;
}

GasBoundaryPatch parse_patch(const json& v, const std::string& path, const DomainConfig& domain,
                             const GasConfig& g, InputErrors& errors) {
  const bool compressible = g.model == GasModel::Compressible;
  JsonObjectReader r(v, path, errors);
  GasBoundaryPatch p;
  p.face = face_index(r.required_string("face", kFaceNames));
  p.name = r.string("name", kFaceNames[std::size_t(p.face)]);
  const std::string type = r.required_string("type", {"wall", "slip", "inlet", "outlet"});
  p.kind = type == "slip"     ? GasBoundaryKind::Slip
           : type == "inlet"  ? GasBoundaryKind::Inlet
           : type == "outlet" ? GasBoundaryKind::Outlet
                              : GasBoundaryKind::Wall;
  const std::string shape = r.string("shape", "face", {"face", "rectangle", "circle"});
  if (shape == "rectangle") {
    p.shape = PatchShape::Rectangle;
    p.min_m = r.vec3("min_m", {});
    p.max_m = r.vec3("max_m", {});
    if (r.is_object() && !(r.has("min_m") && r.has("max_m")))
      errors.push_back({path, "", "a rectangle patch needs min_m and max_m"});
  } else if (shape == "circle") {
    p.shape = PatchShape::Circle;
    p.center_m = r.vec3("center_m", {});
    p.radius_m = r.required_number("radius_m", NumberRange::positive());
    if (r.is_object() && !r.has("center_m"))
      errors.push_back({r.path_of("center_m"), "", "missing; a circle patch needs its centre"});
  }
  p.velocity_m_per_s = r.vec3("velocity_m_per_s", {}, NumberRange::closed(-1e4, 1e4));
  if (const json* schedule = r.child("schedule")) {
    if (p.kind != GasBoundaryKind::Inlet)
      errors.push_back({r.path_of("schedule"), type, "only an inlet has a schedule"});
    else if (r.has("velocity_m_per_s"))
      errors.push_back({r.path_of("velocity_m_per_s"), "",
                        "give velocity_m_per_s or a schedule, not both (a scheduled inlet blows "
                        "along its face's inward normal)"});
    p.schedule = parse_inflow_schedule(*schedule, r.path_of("schedule"), errors);
  }
  if (compressible) {
    // Absolute pressures: an outlet without one holds the chamber's initial pressure.
    p.pressure_pa = r.number("pressure_pa", g.compressible.initial_pressure_pa,
                             NumberRange::open_closed(0.0, 1e9));
    if (p.schedule)
      errors.push_back({r.path_of("schedule"), "",
                        "the compressible model has no scheduled inlets yet: give "
                        "velocity_m_per_s or supply_pressure_pa"});
    p.supply_pressure_pa =
        r.optional_number("supply_pressure_pa", NumberRange::open_closed(0.0, 1e9));
    p.supply_temperature_k = r.number("supply_temperature_k", g.compressible.initial_temperature_k,
                                      NumberRange::open_closed(0.0, 1e5));
    if (p.supply_pressure_pa && p.kind != GasBoundaryKind::Inlet)
      errors.push_back({r.path_of("supply_pressure_pa"), concat(*p.supply_pressure_pa),
                        "only an inlet is fed from a supply pressure"});
    if (p.supply_pressure_pa && r.has("velocity_m_per_s"))
      errors.push_back(
          {r.path_of("velocity_m_per_s"), "",
           "give velocity_m_per_s or supply_pressure_pa, not both (a reservoir inlet's "
           "speed follows from the pressures)"});
  } else {
    p.pressure_pa = r.number("pressure_pa", 0.0, NumberRange::closed(-1e9, 1e9));
    for (const char* key : {"supply_pressure_pa", "supply_temperature_k"})
      if (r.has(key))
        errors.push_back({r.path_of(key), "",
                          "only the compressible model reads it: set /gas/model to "
                          "\"compressible\""});
  }
  if (p.kind == GasBoundaryKind::Wall || p.kind == GasBoundaryKind::Slip) {
    const int axis = p.face / 2;
    if (p.velocity_m_per_s[axis] != 0.0)
      errors.push_back({r.path_of("velocity_m_per_s"), concat(p.velocity_m_per_s[axis]),
                        "a wall moves only along itself: the component normal to the face must "
                        "be 0 (use an inlet to blow gas in)"});
  }
  if (domain.periodic[std::size_t(p.face / 2)])
    errors.push_back({r.path_of("face"), kFaceNames[std::size_t(p.face)],
                      "this axis is periodic (/domain/periodic): its faces have no boundary"});
  r.finish();
  return p;
}

GasSolidConfig parse_solid(const json& v, const std::string& path, InputErrors& errors) {
  JsonObjectReader r(v, path, errors);
  GasSolidConfig s;
  const std::string type = r.required_string("type", {"box", "cylinder", "half_space"});
  s.name = r.string("name", type);
  if (type == "box") {
    s.shape = GasSolidShape::Box;
    s.min_m = r.vec3("min_m", {});
    s.max_m = r.vec3("max_m", {});
    for (int a = 0; a < 3; ++a)
      if (r.is_object() && !(s.max_m[a] > s.min_m[a])) {
        errors.push_back({r.path_of("max_m"), concat(s.max_m[a]),
                          concat("expected each component > min_m (axis ", a, ")")});
        break;
      }
  } else if (type == "cylinder") {
    s.shape = GasSolidShape::Cylinder;
    s.center_m = r.vec3("center_m", {});
    s.axis = unit_vector(r, "axis", errors);
    s.radius_m = r.required_number("radius_m", NumberRange::positive());
    s.solid_inside = r.string("solid", "outside", {"inside", "outside"}) == "inside";
  } else {
    s.shape = GasSolidShape::HalfSpace;
    s.point_m = r.vec3("point_m", {});
    s.normal = unit_vector(r, "normal", errors);
  }
  r.finish();
  return s;
}

// One end of a pressure drop: a boundary patch's name, or {"axis": "x"|"y"|"z", "at_m": ...}
// strictly between the first and last cell centres along that axis.
PressurePlane parse_pressure_plane(const json& v, const std::string& path, const GasConfig& g,
                                   const DomainConfig& domain, InputErrors& errors) {
  PressurePlane plane;
  if (v.is_string()) {
    std::string names;
    for (std::size_t k = 0; k < g.boundaries.size(); ++k) {
      names += (k ? ", " : "") + g.boundaries[k].name;
      if (g.boundaries[k].name == v.get<std::string>()) plane.patch = int(k);
    }
    if (plane.patch < 0)
      errors.push_back({path, json_value_text(v),
                        names.empty() ? std::string("expected a plane object: /gas/boundaries "
                                                    "names no patch")
                                      : "expected the name of a /gas/boundaries patch (" + names +
                                            ") or a plane object"});
    return plane;
  }
  JsonObjectReader r(v, path, errors);
  const std::string axis = r.required_string("axis", {"x", "y", "z"});
  plane.axis = axis == "x" ? 0 : axis == "y" ? 1 : 2;
  const std::size_t a = std::size_t(plane.axis);
  const double h = (domain.max_m[plane.axis] - domain.min_m[plane.axis]) / g.cells[a];
  const double lo = domain.min_m[plane.axis] + 0.5 * h, hi = domain.max_m[plane.axis] - 0.5 * h;
  plane.at_m = r.required_number(
      "at_m", hi > lo ? NumberRange::closed(lo, hi) : NumberRange::closed(lo, lo));
  if (domain.periodic[a])
    errors.push_back({r.path_of("axis"), axis, "a periodic axis has no pressure drop plane"});
  r.finish();
  return plane;
}

}  // namespace

InflowSchedule parse_inflow_schedule(const json& v, const std::string& path, InputErrors& errors) {
  InflowSchedule s;
  const std::size_t errors_before = errors.size();
  JsonObjectReader r(v, path, errors);
  if (!r.is_object()) return s;
  const bool mass = r.has("mass_flow_kg_per_s"), speed = r.has("speed_m_per_s");
  if (mass == speed)
    errors.push_back({path, "", "expected one of speed_m_per_s and mass_flow_kg_per_s"});
  s.mass_flow = mass;
  s.table.time_s = schedule_column(r.child("time_s"), r.path_of("time_s"),
                                   NumberRange::closed(-10.0, 1e6), errors);
  s.table.value =
      mass ? schedule_column(r.child("mass_flow_kg_per_s"), r.path_of("mass_flow_kg_per_s"),
                             NumberRange::closed(0.0, 1e6), errors)
           : schedule_column(r.child("speed_m_per_s"), r.path_of("speed_m_per_s"),
                             NumberRange::closed(0.0, 1e4), errors);
  r.finish();
  if (!r.has("time_s"))
    errors.push_back({r.path_of("time_s"), "", "missing; expected an array of times"});
  for (std::size_t k = 1; k < s.table.time_s.size(); ++k)
    if (s.table.time_s[k] < s.table.time_s[k - 1]) {
      errors.push_back({json_pointer_join(r.path_of("time_s"), k), concat(s.table.time_s[k]),
                        concat("expected times in non-decreasing order (after ",
                               s.table.time_s[k - 1], "); a step repeats a time")});
      break;
    }
  if (s.table.time_s.size() != s.table.value.size() || s.table.time_s.empty()) {
    if (errors.size() == errors_before)
      errors.push_back({path,
                        concat(s.table.time_s.size(), " times, ", s.table.value.size(), " values"),
                        "expected as many values as times, at least one"});
    s.table = Schedule{{0.0}, {0.0}};
  }
  return s;
}

GasConfig parse_gas(const json& v, const DomainConfig& domain, InputErrors& errors) {
  GasConfig g;
  JsonObjectReader r(v, "/gas", errors);
  if (!r.is_object()) return g;
  const bool compressible =
      r.string("model", "incompressible", {"incompressible", "compressible"}) == "compressible";
  g.model = compressible ? GasModel::Compressible : GasModel::Incompressible;
  if (const json* c = r.child("compressible")) {
    JsonObjectReader rc(*c, "/gas/compressible", errors);
    CompressibleGasConfig& cg = g.compressible;
    cg.gas.gamma = rc.number("gamma", 1.4, NumberRange::open_closed(1.0, 5.0 / 3.0));
    cg.gas.gas_constant_j_per_kg_k =
        rc.number("gas_constant_j_per_kg_k", 287.05, NumberRange::open_closed(0.0, 1e5));
    cg.gas.prandtl = rc.number("prandtl", 0.71, NumberRange::open_closed(0.0, 100.0));
    cg.initial_pressure_pa =
        rc.number("initial_pressure_pa", 101325.0, NumberRange::open_closed(0.0, 1e9));
    cg.initial_temperature_k =
        rc.number("initial_temperature_k", 293.15, NumberRange::open_closed(0.0, 1e5));
    rc.finish();
    if (!compressible)
      errors.push_back({"/gas/compressible", "",
                        "only the compressible model reads this section: set /gas/model to "
                        "\"compressible\" or remove it"});
  }
  if (compressible) {
    // What only the incompressible solver reads would be silently ignored: refused instead.
    for (const char* key :
         {"density_kg_per_m3", "advection", "smagorinsky_constant", "pressure_tolerance",
          "max_pressure_iterations", "pressure_preconditioner", "pressure_drops", "drag_courant",
          "mean_pressure_gradient_pa_per_m"})
      if (r.has(key))
        errors.push_back(
            {r.path_of(key), "",
             std::string("the compressible model does not read it") +
                 (std::string(key) == "density_kg_per_m3"
                      ? ": its density follows from /gas/compressible/initial_pressure_pa and "
                        "initial_temperature_k (ideal gas)"
                      : "; remove it")});
    g.density_kg_per_m3 = g.compressible.gas.density_kg_per_m3(
        g.compressible.initial_pressure_pa, g.compressible.initial_temperature_k);
  }
  const std::string slip =
      r.string("slip_correction", compressible ? "cunningham" : "none", {"cunningham", "none"});
  g.slip_correction = slip == "cunningham";
  if (g.slip_correction && !compressible)
    errors.push_back({"/gas/slip_correction", slip,
                      "Cunningham's correction needs the gas's absolute pressure: only with "
                      "/gas/model \"compressible\""});
  const std::string mach =
      r.string("mach_correction", compressible ? "loth" : "none", {"loth", "none"});
  g.mach_correction = mach == "loth";
  if (g.mach_correction && !compressible)
    errors.push_back({"/gas/mach_correction", mach,
                      "Loth's Mach correction needs the gas's sound speed: only with /gas/model "
                      "\"compressible\""});
  g.density_kg_per_m3 =
      r.number("density_kg_per_m3", g.density_kg_per_m3, NumberRange::open_closed(0.0, 1e5));
  g.viscosity_pa_s = r.number("viscosity_pa_s", 1.8e-5, NumberRange::open_closed(0.0, 1e3));
  const Vec3 extent = domain.max_m - domain.min_m;
  if (const json* cells = r.child("cells")) {
    bool ok = cells->is_array() && cells->size() == 3;
    for (std::size_t a = 0; ok && a < 3; ++a) {
      ok = (*cells)[a].is_number_integer() && (*cells)[a].get<long long>() >= 1 &&
           (*cells)[a].get<long long>() <= 4096;
      if (ok) g.cells[a] = int((*cells)[a].get<long long>());
    }
    if (!ok)
      errors.push_back(
          {"/gas/cells", json_value_text(*cells), "expected [nx, ny, nz], integers in [1, 4096]"});
    if (r.has("cell_size_m"))
      errors.push_back({"/gas", "", "give either cells or cell_size_m, not both"});
  } else if (auto h = r.optional_number("cell_size_m", NumberRange::positive())) {
    for (int a = 0; a < 3; ++a)
      g.cells[std::size_t(a)] = std::max(1, int(std::lround(extent[a] / *h)));
  } else {
    errors.push_back({"/gas/cells", "", "missing; expected [nx, ny, nz] or cell_size_m"});
  }
  const double total = double(g.cells[0]) * g.cells[1] * g.cells[2];
  if (total > 2e7)
    errors.push_back({"/gas/cells", concat(total, " cells"), "expected at most 2e7 cells"});
  g.initial_velocity_m_per_s =
      r.vec3("initial_velocity_m_per_s", {}, NumberRange::closed(-1e4, 1e4));
  g.mean_pressure_gradient_pa_per_m =
      r.vec3("mean_pressure_gradient_pa_per_m", {}, NumberRange::closed(-1e9, 1e9));
  for (int a = 0; a < 3; ++a)
    if (g.mean_pressure_gradient_pa_per_m[a] != 0.0 && !domain.periodic[std::size_t(a)])
      errors.push_back({concat("/gas/mean_pressure_gradient_pa_per_m/", a),
                        concat(g.mean_pressure_gradient_pa_per_m[a]),
                        "only a periodic axis can carry an imposed mean gradient; use an inlet "
                        "and an outlet on a bounded axis"});
  if (const json* step = r.child("step_s")) {
    if (!(step->is_string() && step->get<std::string>() == "auto")) {
      if (auto s = read_number(*step, "/gas/step_s", NumberRange::positive(), errors)) g.step_s = s;
    }
  }
  g.spin_up_s = r.number("spin_up_s", 0.0, NumberRange::closed(0.0, 10.0));
  g.courant = r.number("courant", 0.5, NumberRange::open_closed(0.0, 1.0));
  g.drag_courant = r.number("drag_courant", 20.0, NumberRange::open_closed(0.0, 100.0));
  g.smagorinsky_constant = r.number("smagorinsky_constant", 0.0, NumberRange::closed(0.0, 0.5));
  const std::string scheme =
      r.string("advection", "hybrid", {"hybrid", "central", "upwind", "tvd"});
  g.advection = scheme == "central"  ? AdvectionScheme::Central
                : scheme == "upwind" ? AdvectionScheme::Upwind
                : scheme == "tvd"    ? AdvectionScheme::Tvd
                                     : AdvectionScheme::Hybrid;
  if (const json* list = r.array("boundaries"))
    for (std::size_t i = 0; i < list->size(); ++i)
      g.boundaries.push_back(
          parse_patch((*list)[i], json_pointer_join("/gas/boundaries", i), domain, g, errors));
  if (const json* list = r.array("solids"))
    for (std::size_t i = 0; i < list->size(); ++i)
      g.solids.push_back(parse_solid((*list)[i], json_pointer_join("/gas/solids", i), errors));
  g.two_way = r.string("coupling", "two_way", {"two_way", "one_way"}) == "two_way";
  const std::string drag =
      r.string("drag", "schiller_naumann",
               {"schiller_naumann", "di_felice", "gidaspow", "koch_hill", "beetstra"});
  g.drag = drag == "di_felice"   ? DragLaw::DiFelice
           : drag == "gidaspow"  ? DragLaw::Gidaspow
           : drag == "koch_hill" ? DragLaw::KochHill
           : drag == "beetstra"  ? DragLaw::Beetstra
                                 : DragLaw::SchillerNaumann;
  if (const json* cache = r.child("drag_cache")) {
    JsonObjectReader c(*cache, "/gas/drag_cache", errors);
    g.cache_threshold = c.number("threshold", 0.05, NumberRange::closed(0.0, 1.0));
    g.cache_store = c.string("store", "coefficient", {"coefficient", "force"}) == "force"
                        ? DragCacheStore::Force
                        : DragCacheStore::Coefficient;
    c.finish();
  }
  g.pressure_gradient_force = r.boolean("pressure_gradient_force", true);
  g.saffman_lift = r.boolean("saffman_lift", false);
  g.min_volume_fraction = r.number("min_volume_fraction", 0.2, NumberRange::closed(0.01, 1.0));
  g.pressure_tolerance = r.number("pressure_tolerance", 1e-6, NumberRange::closed(1e-14, 1e-2));
  g.max_pressure_iterations = int(r.integer("max_pressure_iterations", 5000, 1, 1000000));
  g.pressure_preconditioner =
      r.string("pressure_preconditioner", "multigrid", {"multigrid", "incomplete_cholesky"}) ==
              "incomplete_cholesky"
          ? PressurePreconditioner::IncompleteCholesky
          : PressurePreconditioner::Multigrid;
  if (const json* list = r.array("pressure_drops"))
    for (std::size_t i = 0; i < list->size(); ++i) {
      const std::string path = json_pointer_join("/gas/pressure_drops", i);
      JsonObjectReader d((*list)[i], path, errors);
      PressureDropConfig drop;
      drop.name = d.string("name", concat("drop", i));
      const bool plain =
          !drop.name.empty() && drop.name.size() <= 64 &&
          std::all_of(drop.name.begin(), drop.name.end(), [](char ch) {
            return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-';
          });
      if (!plain)
        errors.push_back({d.path_of("name"), drop.name,
                          "expected 1 to 64 letters, digits, '_' or '-' (it names a column)"});
      for (const PressureDropConfig& other : g.pressure_drops)
        if (other.name == drop.name)
          errors.push_back({d.path_of("name"), drop.name, "expected a name no other drop has"});
      if (const json* from = d.child("from"))
        drop.from = parse_pressure_plane(*from, d.path_of("from"), g, domain, errors);
      if (const json* to = d.child("to"))
        drop.to = parse_pressure_plane(*to, d.path_of("to"), g, domain, errors);
      if (d.is_object() && !(d.has("from") && d.has("to")))
        errors.push_back({path, "", "a pressure drop needs from and to"});
      d.finish();
      g.pressure_drops.push_back(drop);
    }
  r.finish();
  return g;
}

// A reservoir inlet or a pressure-set nozzle must be fed from above the chamber's pressure (its
// initial pressure and every outlet's): otherwise it blows nothing in, or draws gas out.
void check_supply_pressure(const GasConfig& g, const std::string& path, double supply_pa,
                           InputErrors& errors) {
  double chamber_pa = g.compressible.initial_pressure_pa;
  std::string chamber = "/gas/compressible/initial_pressure_pa";
  for (const GasBoundaryPatch& b : g.boundaries)
    if (b.kind == GasBoundaryKind::Outlet && b.pressure_pa > chamber_pa)
      chamber_pa = b.pressure_pa, chamber = concat("the outlet ", b.name);
  if (supply_pa <= chamber_pa)
    errors.push_back({path, concat(supply_pa),
                      concat("expected a supply pressure above the chamber's (", chamber_pa,
                             " Pa, ", chamber, "); pressures are absolute")});
}

namespace {

void check_supply_pressures(const GasConfig& g, InputErrors& errors) {
  for (std::size_t k = 0; k < g.boundaries.size(); ++k)
    if (g.boundaries[k].supply_pressure_pa)
      check_supply_pressure(g, concat("/gas/boundaries/", k, "/supply_pressure_pa"),
                            *g.boundaries[k].supply_pressure_pa, errors);
}

}  // namespace

void check_gas_outflow(const GasConfig& g, InputErrors& errors) {
  // Gas blown in must have a way out.
  bool inflow = false, outlet = false;
  for (const GasBoundaryPatch& p : g.boundaries) {
    inflow =
        inflow ||
        (p.kind == GasBoundaryKind::Inlet &&
         (norm(p.velocity_m_per_s) > 0.0 || (p.schedule && p.schedule->table.max_abs() > 0.0)));
    outlet = outlet || p.kind == GasBoundaryKind::Outlet;
  }
  for (const GasBoundaryPatch& p : g.boundaries)
    inflow = inflow || p.supply_pressure_pa.has_value();
  if (g.model == GasModel::Compressible) check_supply_pressures(g, errors);
  if (inflow && !outlet)
    errors.push_back({"/gas/boundaries", "",
                      "an inlet blows gas in but no boundary is an outlet: "
                      "add {\"face\": ..., \"type\": \"outlet\"}"});
}

}  // namespace millsim
