#include "scene/scene_json.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "core/json_reader.h"
#include "io/input_file.h"
#include "particles/particle_sources.h"
#include "scene/gas_json.h"
#include "scene/mill_json.h"
#include "search/hashed_grid.h"

namespace millsim {

using nlohmann::json;

int find_material(const std::vector<MaterialConfig>& materials, JsonObjectReader& reader,
                  std::string_view key, InputErrors& errors, bool required) {
  const json* v = reader.child(key);
  if (!v) {
    if (required && reader.is_object())
      errors.push_back({reader.path_of(key), "", "missing; expected a material name"});
    return 0;
  }
  std::string names;
  for (std::size_t m = 0; m < materials.size(); ++m) {
    if (v->is_string() && v->get<std::string>() == materials[m].name) return int(m);
    names += (names.empty() ? "" : " ") + materials[m].name;
  }
  errors.push_back({reader.path_of(key), json_value_text(*v),
                    materials.empty() ? std::string("no materials are defined")
                                      : "expected one of the material names: " + names});
  return 0;
}

namespace {

const NumberRange kRestitution = NumberRange::closed(0.0, 1.0);
// Speeds a DEM run can resolve at all: far beyond any mill (1e5 m/s), yet far from overflowing
// the energies (a velocity of 1e308 m/s gives an infinite kinetic energy).
const NumberRange kVelocity = NumberRange::closed(-1e5, 1e5);
const NumberRange kAngularVelocity = NumberRange::closed(-1e9, 1e9);

StrengthConfig parse_strength(const json& v, const std::string& path, InputErrors& errors) {
  StrengthConfig s;
  JsonObjectReader r(v, path, errors);
  const std::string model = r.required_string("model", {"vogel_peukert", "weibull"});
  if (model == "weibull") {
    s.model = StrengthModel::Weibull;
    s.median_energy_j_per_kg =
        r.required_number("median_energy_j_per_kg", NumberRange::open_closed(0.0, 1e9));
    s.reference_diameter_m =
        r.required_number("reference_diameter_m", NumberRange::open_closed(0.0, 10.0));
    s.size_exponent = r.number("size_exponent", 0.0, NumberRange::closed(-5.0, 5.0));
    s.weibull_modulus = r.number("weibull_modulus", 3.0, NumberRange::closed(0.1, 100.0));
  } else {
    s.model = StrengthModel::VogelPeukert;
    s.f_mat_kg_per_j_m = r.required_number("f_mat_kg_per_j_m", NumberRange::open_closed(0.0, 1e12));
    s.x_w_min_j_m_per_kg = r.required_number("x_w_min_j_m_per_kg", NumberRange::closed(0.0, 1e6));
  }
  r.finish();
  return s;
}

FragmentConfig parse_fragments(const json& v, const std::string& path, InputErrors& errors) {
  FragmentConfig f;
  JsonObjectReader r(v, path, errors);
  const std::string model = r.required_string(
      "model", {"power_law", "broadbent_callcott", "austin_luckie", "vogel_peukert", "equal"});
  if (model == "equal") {
    f.model = FragmentModel::Equal;
    f.count = int(r.integer("count", 8, 2, 100000));
  } else {
    f.model = model == "power_law"            ? FragmentModel::PowerLaw
              : model == "broadbent_callcott" ? FragmentModel::BroadbentCallcott
              : model == "austin_luckie"      ? FragmentModel::AustinLuckie
                                              : FragmentModel::VogelPeukert;
    if (f.model == FragmentModel::PowerLaw || f.model == FragmentModel::VogelPeukert)
      f.exponent = r.number("exponent", 1.0, NumberRange::closed(0.05, 10.0));
    if (f.model == FragmentModel::AustinLuckie) {
      f.fine_fraction = r.required_number("fine_fraction", NumberRange::closed(0.0, 1.0));
      f.fine_exponent = r.required_number("fine_exponent", NumberRange::closed(0.05, 10.0));
      f.coarse_exponent = r.required_number("coarse_exponent", NumberRange::closed(0.05, 10.0));
    }
    if (f.model == FragmentModel::VogelPeukert)
      f.chipping_diameter_m =
          r.required_number("chipping_diameter_m", NumberRange::open_closed(0.0, 10.0));
    f.min_ratio = r.number("min_ratio", 0.05, NumberRange::closed(0.0, 0.9));
    // Up to the parent's size: the published domain of B (a draw near 1 is a chip off a
    // parent that stays nearly whole).
    f.max_ratio = r.number("max_ratio", 0.7, NumberRange::open_closed(0.0, 1.0));
    if (f.max_ratio <= f.min_ratio)
      errors.push_back({r.path_of("max_ratio"), concat(f.max_ratio),
                        concat("expected > min_ratio = ", f.min_ratio)});
    f.max_fragments = int(r.integer("max_fragments", 5000, 2, 1000000));
  }
  r.finish();
  return f;
}

MaterialBreakageConfig parse_material_breakage(const json& v, const std::string& path,
                                               InputErrors& errors) {
  MaterialBreakageConfig b;
  JsonObjectReader r(v, path, errors);
  if (const json* s = r.child("strength"))
    b.strength = parse_strength(*s, r.path_of("strength"), errors);
  else if (r.is_object())
    errors.push_back({r.path_of("strength"), "", "missing; expected a strength model object"});
  if (const json* f = r.child("fragments"))
    b.fragments = parse_fragments(*f, r.path_of("fragments"), errors);
  else if (r.is_object())
    errors.push_back({r.path_of("fragments"), "", "missing; expected a breakage function object"});
  if (const json* f = r.child("fatigue")) {
    JsonObjectReader fr(*f, r.path_of("fatigue"), errors);
    b.fatigue = fr.boolean("enabled", true);
    b.fatigue_factor = fr.number("factor", 1.0, NumberRange::closed(0.0, 1e3));
    fr.finish();
  }
  r.finish();
  return b;
}

std::vector<MaterialConfig> parse_materials(JsonObjectReader& top, InputErrors& errors) {
  std::vector<MaterialConfig> out;
  std::set<std::string> names;
  const json* list = top.array("materials");
  if (!list) {
    if (top.is_object() && !top.has("materials"))
      errors.push_back({"/materials", "", "missing; expected an array of materials"});
    return out;
  }
  if (list->empty()) errors.push_back({"/materials", "[]", "expected at least one material"});
  for (std::size_t i = 0; i < list->size(); ++i) {
    JsonObjectReader r((*list)[i], json_pointer_join("/materials", i), errors);
    MaterialConfig m;
    m.name = r.required_string("name");
    m.youngs_modulus_pa = r.required_number("youngs_modulus_pa", NumberRange::closed(1e3, 1e13));
    m.poisson_ratio = r.required_number("poisson_ratio", NumberRange::open(-1.0, 0.5));
    m.density_kg_per_m3 = r.required_number("density_kg_per_m3", NumberRange::closed(1.0, 1e5));
    m.restitution = r.number("restitution", 1.0, kRestitution);
    m.friction = r.number("friction", 0.0, NumberRange::closed(0.0, 10.0));
    m.rolling_friction = r.number("rolling_friction", 0.0, NumberRange::closed(0.0, 10.0));
    m.frozen = r.boolean("frozen", false);
    if (const json* b = r.child("breakage"))
      m.breakage = parse_material_breakage(*b, r.path_of("breakage"), errors);
    if (m.frozen && m.breakage)
      errors.push_back({r.path_of("frozen"), "true",
                        "a frozen material cannot break: remove /breakage or set frozen false"});
    r.finish();
    if (!m.name.empty() && !names.insert(m.name).second)  // once per repeated entry
      errors.push_back({json_pointer_join(r.path(), "name"), "\"" + m.name + "\"",
                        "material names must be unique"});
    out.push_back(m);
  }
  return out;
}

DomainConfig parse_domain(JsonObjectReader& top, const std::vector<MaterialConfig>& materials,
                          InputErrors& errors) {
  DomainConfig d;
  const json* v = top.child("domain");
  if (!v) {
    errors.push_back({"/domain", "", "missing; expected an object with min_m and max_m"});
    return d;
  }
  JsonObjectReader r(*v, "/domain", errors);
  auto lo = r.optional_vec3("min_m");
  auto hi = r.optional_vec3("max_m");
  if (r.is_object() && !lo && !r.has("min_m"))
    errors.push_back({"/domain/min_m", "", "missing; expected an array of 3 numbers"});
  if (r.is_object() && !hi && !r.has("max_m"))
    errors.push_back({"/domain/max_m", "", "missing; expected an array of 3 numbers"});
  if (lo) d.min_m = *lo;
  if (hi) d.max_m = *hi;
  if (lo && hi)
    for (int a = 0; a < 3; ++a)
      if (!(d.max_m[a] > d.min_m[a]))
        errors.push_back({json_pointer_join("/domain/max_m", std::size_t(a)), concat(d.max_m[a]),
                          concat("expected a number > min_m[", a, "] = ", d.min_m[a])});
  d.periodic = r.bool3("periodic", {false, false, false});
  if (r.has("wall_material"))
    d.wall_material = find_material(materials, r, "wall_material", errors, false);
  d.wall_restitution = r.optional_number("wall_restitution", kRestitution);
  d.wall_friction = r.optional_number("wall_friction", NumberRange::closed(0.0, 10.0));
  r.finish();
  return d;
}

std::vector<WallConfig> parse_walls(JsonObjectReader& top,
                                    const std::vector<MaterialConfig>& materials,
                                    InputErrors& errors) {
  std::vector<WallConfig> out;
  const json* list = top.array("walls");
  if (!list) return out;
  for (std::size_t i = 0; i < list->size(); ++i) {
    JsonObjectReader r((*list)[i], json_pointer_join("/walls", i), errors);
    WallConfig w;
    w.name = r.string("name", concat("wall", i));
    const std::string type = r.string("type", "plane", {"plane", "cylinder"});
    w.shape = type == "cylinder" ? WallShape::Cylinder : WallShape::Plane;
    w.point_m = r.vec3("point_m", {});
    if (!r.has("point_m"))
      errors.push_back({r.path_of("point_m"), "", "missing; expected an array of 3 numbers"});
    const char* direction_key = w.shape == WallShape::Cylinder ? "axis" : "normal";
    auto n = r.optional_vec3(direction_key);
    if (!n && !r.has(direction_key))
      errors.push_back({r.path_of(direction_key), "", "missing; expected an array of 3 numbers"});
    if (n) {
      const double len = norm(*n);
      if (len < 1e-12)
        errors.push_back({r.path_of(direction_key), "[0,0,0]", "expected a non-zero vector"});
      else
        w.normal = *n * (1.0 / len);
    }
    if (w.shape == WallShape::Cylinder)
      w.radius_m = r.required_number("radius_m", NumberRange::open_closed(0.0, 1e3));
    w.material = find_material(materials, r, "material", errors, true);
    w.restitution = r.optional_number("restitution", kRestitution);
    w.friction = r.optional_number("friction", NumberRange::closed(0.0, 10.0));
    r.finish();
    out.push_back(w);
  }
  return out;
}

SizeDistribution parse_sizes(const json& v, const std::string& path, InputErrors& errors) {
  SizeDistribution s;
  JsonObjectReader r(v, path, errors);
  const std::string kind =
      r.required_string("distribution", {"fixed", "uniform", "log_normal", "power_law"});
  const NumberRange size_range = NumberRange::open_closed(0.0, 10.0);
  if (kind == "fixed") {
    s.kind = SizeDistributionKind::Fixed;
    s.diameter_m = r.required_number("diameter_m", size_range);
  } else if (kind == "uniform" || kind == "power_law") {
    s.kind = kind == "uniform" ? SizeDistributionKind::Uniform : SizeDistributionKind::PowerLaw;
    s.min_m = r.required_number("min_m", size_range);
    s.max_m = r.required_number("max_m", size_range);
    if (kind == "power_law") s.exponent = r.number("exponent", -2.5, NumberRange::closed(-10, 10));
    if (s.max_m < s.min_m)
      errors.push_back(
          {r.path_of("max_m"), concat(s.max_m), concat("expected >= min_m = ", s.min_m)});
  } else if (kind == "log_normal") {
    s.kind = SizeDistributionKind::LogNormal;
    s.median_m = r.required_number("median_m", size_range);
    s.geometric_std = r.required_number("geometric_std", NumberRange::closed(1.0, 10.0));
    s.min_m = r.number("min_m", 0.0, NumberRange::closed(0.0, 10.0));
    s.max_m = r.number("max_m", 10.0, size_range);
  }
  r.finish();
  return s;
}

ParticleSpec parse_particle(const json& v, const std::string& path, InputErrors& errors) {
  ParticleSpec p;
  JsonObjectReader r(v, path, errors);
  p.position_m = r.vec3("position_m", {});
  if (r.is_object() && !r.has("position_m"))
    errors.push_back({r.path_of("position_m"), "", "missing; expected an array of 3 numbers"});
  p.velocity_m_per_s = r.vec3("velocity_m_per_s", {}, kVelocity);
  p.angular_velocity_rad_per_s = r.vec3("angular_velocity_rad_per_s", {}, kAngularVelocity);
  p.diameter_m = r.required_number("diameter_m", NumberRange::open_closed(0.0, 10.0));
  r.finish();
  return p;
}

// Reads {min_m, max_m} with max > min on every axis.
void parse_region(const json& v, const std::string& path, Vec3& lo, Vec3& hi, InputErrors& errors) {
  JsonObjectReader rr(v, path, errors);
  lo = rr.vec3("min_m", {});
  hi = rr.vec3("max_m", {});
  if (rr.is_object() && (!rr.has("min_m") || !rr.has("max_m")))
    errors.push_back({rr.path(), "", "expected both min_m and max_m"});
  rr.finish();
  for (int a = 0; a < 3; ++a)
    if (!(hi[a] > lo[a]))
      errors.push_back({rr.path_of("max_m"), concat(hi[a]),
                        concat("expected each component > min_m (axis ", a, ")")});
}

std::vector<SourceConfig> parse_sources(JsonObjectReader& top,
                                        const std::vector<MaterialConfig>& materials,
                                        const std::filesystem::path& base_dir,
                                        InputErrors& errors) {
  std::vector<SourceConfig> out;
  const json* list = top.array("sources");
  if (!list) {
    if (top.is_object() && !top.has("sources") && !top.has("feeds"))
      errors.push_back(
          {"/sources", "", "missing; expected an array of particle sources (or a feed)"});
    return out;
  }
  for (std::size_t i = 0; i < list->size(); ++i) {
    JsonObjectReader r((*list)[i], json_pointer_join("/sources", i), errors);
    SourceConfig s;
    const std::string type = r.required_string("type", {"list", "file", "random"});
    s.material = find_material(materials, r, "material", errors, true);
    if (type == "list") {
      s.kind = SourceKind::List;
      const json* particles = r.array("particles");
      if (!particles && r.is_object() && !r.has("particles"))
        errors.push_back({r.path_of("particles"), "", "missing; expected an array of particles"});
      if (particles)
        for (std::size_t k = 0; k < particles->size(); ++k)
          s.particles.push_back(parse_particle(
              (*particles)[k], json_pointer_join(r.path_of("particles"), k), errors));
    } else if (type == "file") {
      s.kind = SourceKind::File;
      const std::string file = r.required_string("path");
      s.file_path =
          std::filesystem::path(file).is_absolute() ? std::filesystem::path(file) : base_dir / file;
      std::error_code status_error;  // a name too long for the filesystem, say
      if (!file.empty() && !std::filesystem::is_regular_file(s.file_path, status_error))
        errors.push_back(
            {r.path_of("path"),
             "\"" + std::string(utf8_prefix(file, 200)) + (file.size() > 200 ? "…\"" : "\""),
             "expected a readable particle file" +
                 (status_error ? " (" + status_error.message() + ")" : std::string())});
    } else if (type == "random") {
      s.kind = SourceKind::Random;
      s.count = r.integer("count", 0, 1, 100'000'000);
      if (!r.has("count"))
        errors.push_back({r.path_of("count"), "", "missing; expected an integer >= 1"});
      if (const json* region = r.child("region")) {
        parse_region(*region, r.path_of("region"), s.region_min_m, s.region_max_m, errors);
      } else {
        errors.push_back({r.path_of("region"), "", "missing; expected {min_m, max_m}"});
      }
      if (const json* sizes = r.child("sizes"))
        s.sizes = parse_sizes(*sizes, r.path_of("sizes"), errors);
      else
        errors.push_back({r.path_of("sizes"), "", "missing; expected a size distribution"});
      s.velocity_m_per_s = r.vec3("velocity_m_per_s", {}, kVelocity);
      s.velocity_spread_m_per_s =
          r.number("velocity_spread_m_per_s", 0.0, NumberRange::closed(0.0, 1e4));
    }
    r.finish();
    out.push_back(std::move(s));
  }
  return out;
}

// A random source places each particle whole inside its region, except along a periodic axis
// the region spans: a region narrower than its smallest particle along another axis can hold
// none, found here rather than when the run starts (a study's runs are all checked before any
// is queued).
void check_random_regions(const SceneConfig& scene, InputErrors& errors) {
  for (std::size_t k = 0; k < scene.sources.size(); ++k) {
    const SourceConfig& s = scene.sources[k];
    if (s.kind != SourceKind::Random) continue;
    const double d = smallest_diameter_m(s.sizes);
    const PeriodicBox box{scene.domain.min_m, scene.domain.max_m, scene.domain.periodic};
    for (int a = 0; a < 3; ++a) {
      const double extent = s.region_max_m[a] - s.region_min_m[a];
      if (!region_wraps(s, box, a) && extent >= 0.0 && extent < d)
        errors.push_back({concat("/sources/", k, "/region"), "",
                          concat("its extent along ", "xyz"[a], " (", extent,
                                 " m) is below the smallest particle's diameter (", d,
                                 " m); each particle is placed whole inside it")});
    }
  }
}

// time.fill_relaxation: one ω for every fill, or a list with one per fill (a first fill far
// from the steady state relaxed, the last one taken whole, say). One entry per fill.
std::vector<double> parse_fill_relaxation(JsonObjectReader& r, std::size_t fills,
                                          InputErrors& errors) {
  const NumberRange range = NumberRange::open_closed(0.0, 1.0);
  const json* v = r.child("fill_relaxation");
  if (!v || fills == 0) return std::vector<double>(fills, 1.0);  // no fills: reported above
  const std::string path = r.path_of("fill_relaxation");
  if (!v->is_array()) {
    const std::optional<double> omega = read_number(*v, path, range, errors);
    if (!omega) errors.back().allowed = "expected a number in (0, 1] or a list of one per fill";
    return std::vector<double>(fills, omega.value_or(1.0));
  }
  if (v->size() != fills) {
    errors.push_back({path, json_value_text(*v),
                      concat("expected one number in (0, 1] per fill in "
                             "/time/fill_to_projection_s (",
                             fills, "), or one number for all")});
    return std::vector<double>(fills, 1.0);
  }
  std::vector<double> omega(fills, 1.0);
  for (std::size_t k = 0; k < fills; ++k)
    omega[k] = read_number((*v)[k], concat(path, "/", k), range, errors).value_or(1.0);
  return omega;
}

TimeConfig parse_time(JsonObjectReader& top, InputErrors& errors) {
  TimeConfig t;
  const json* v = top.child("time");
  if (!v) {
    errors.push_back({"/time", "", "missing; expected an object with end_s"});
    return t;
  }
  JsonObjectReader r(*v, "/time", errors);
  t.end_s = r.required_number("end_s", NumberRange::open_closed(0.0, 1e6));
  if (const json* step = r.child("step_s")) {
    if (step->is_string() && step->get<std::string>() == "auto") {
    } else {
      t.step_s =
          read_number(*step, r.path_of("step_s"), NumberRange::open_closed(0.0, 1.0), errors);
      if (!step->is_number()) errors.back().allowed = "expected \"auto\" or a number in (0, 1]";
    }
  }
  t.safety_factor = r.number("safety_factor", 0.2, NumberRange::open_closed(0.0, 1.0));
  t.steps_per_contact = r.number("steps_per_contact", 20.0, NumberRange::closed(4.0, 1e4));
  t.multi_rate = r.boolean("multi_rate", false);
  t.wall_riders = r.boolean("wall_riders", false);
  if (t.wall_riders && !t.multi_rate)
    errors.push_back({"/time/wall_riders", "true",
                      "wall riders are a kind of multi-rate stepping: set /time/multi_rate true "
                      "as well, or remove /time/wall_riders"});
  if (const json* fills = r.child("fill_to_projection_s")) {
    const std::string path = r.path_of("fill_to_projection_s");
    const auto read = [&](const json& v, const std::string& at) {
      return read_number(v, at, NumberRange::open_closed(0.0, 1e6), errors);
    };
    if (fills->is_array()) {
      if (fills->empty() || fills->size() > kMaxHoldupFills)
        errors.push_back(
            {path, json_value_text(*fills),
             concat("expected a time or a list of 1 to ", kMaxHoldupFills, " increasing times")});
      for (std::size_t k = 0; k < fills->size() && k < kMaxHoldupFills; ++k) {
        const std::optional<double> at = read((*fills)[k], concat(path, "/", k));
        if (!at) continue;
        if (!t.fill_to_projection_s.empty() && !(*at > t.fill_to_projection_s.back()))
          errors.push_back({concat(path, "/", k), concat(*at),
                            concat("expected a time after the fill before it (",
                                   t.fill_to_projection_s.back(), " s)")});
        t.fill_to_projection_s.push_back(*at);
      }
    } else if (const std::optional<double> at = read(*fills, path)) {
      t.fill_to_projection_s.push_back(*at);
    } else {
      errors.back().allowed = "expected a time in (0, 1e6] s or a list of increasing times";
    }
  }
  // The fill's settings: only with fills to set.
  for (const char* key :
       {"fill_relaxation", "fill_removes", "fill_min_events", "fill_particle_rate_windows",
        "fill_dust_only_from_s", "fill_dust_exit_follows_load"})
    if (t.fill_to_projection_s.empty() && r.child(key))
      errors.push_back({r.path_of(key), json_value_text(*r.child(key)),
                        "sets how a hold-up fill moves the mill's hold-up: add "
                        "/time/fill_to_projection_s, or remove it"});
  // Against the fills declared (an unreadable time among them is reported on its own).
  const json* fills = r.child("fill_to_projection_s");
  const std::size_t declared = !fills ? 0 : fills->is_array() ? fills->size() : 1;
  t.fill_relaxation = parse_fill_relaxation(r, declared, errors);
  t.fill_relaxation.resize(t.fill_to_projection_s.size(), 1.0);
  t.fill_removes = r.boolean("fill_removes", false);
  t.fill_min_events = int(r.integer("fill_min_events", 0, 0, 1000000));
  t.fill_particle_rate_windows =
      int(r.integer("fill_particle_rate_windows", 1, 1, std::int64_t(kMaxHoldupFills)));
  t.fill_dust_only_from_s =
      r.optional_number("fill_dust_only_from_s", NumberRange::open_closed(0.0, 1e6));
  // A time after the last fill would move nothing: say so rather than run the fills unchanged.
  if (t.fill_dust_only_from_s && !t.fill_to_projection_s.empty() &&
      *t.fill_dust_only_from_s > t.fill_to_projection_s.back())
    errors.push_back(
        {r.path_of("fill_dust_only_from_s"), concat(*t.fill_dust_only_from_s),
         concat("expected a time at or before the last fill (", t.fill_to_projection_s.back(),
                " s): no fill would move the dust alone")});
  // The exit rates' load: with fills of the dust alone only.
  if (!t.fill_to_projection_s.empty() && !r.child("fill_dust_only_from_s") &&
      r.child("fill_dust_exit_follows_load"))
    errors.push_back({r.path_of("fill_dust_exit_follows_load"),
                      json_value_text(*r.child("fill_dust_exit_follows_load")),
                      "sets how a fill of the dust alone projects the dust: add "
                      "/time/fill_dust_only_from_s, or remove it"});
  t.fill_dust_exit_follows_load = r.boolean("fill_dust_exit_follows_load", false);
  r.finish();
  return t;
}

ContactConfig parse_contact(const json& v, InputErrors& errors) {
  ContactConfig c;
  JsonObjectReader r(v, "/contact", errors);
  const std::string model = r.string("model", "series", {"series", "paper", "equivalent"});
  c.model = model == "equivalent" ? ContactModel::EquivalentProperties
            : model == "paper"    ? ContactModel::PaperSprings
                                  : ContactModel::SeriesSprings;
  c.damping = r.string("damping", "restitution", {"restitution", "paper"}) == "paper"
                  ? DampingModel::Paper
                  : DampingModel::Restitution;
  c.max_impact_speed_m_per_s =
      r.optional_number("max_impact_speed_m_per_s", NumberRange::open_closed(0.0, 1e4));
  c.penetration_limit = r.number("penetration_limit", 0.15, NumberRange::open(0.0, 0.5));
  c.penetration_limiter = r.boolean("penetration_limiter", true);
  const json* rs = r.child("reduced_stiffness");
  // false switches it off explicitly (a study can then toggle it); true = all defaults.
  if (rs && rs->is_boolean() && !rs->get<bool>()) rs = nullptr;
  const json empty_object = json::object();
  if (rs && rs->is_boolean()) rs = &empty_object;
  if (rs) {
    JsonObjectReader rr(*rs, r.path_of("reduced_stiffness"), errors);
    ReducedStiffnessConfig config;
    if (const json* t = rr.child("threshold_diameter_m")) {
      if (!(t->is_string() && t->get<std::string>() == "auto")) {
        config.threshold_diameter_m = read_number(*t, rr.path_of("threshold_diameter_m"),
                                                  NumberRange::open_closed(0.0, 10.0), errors);
        if (!t->is_number()) errors.back().allowed = "expected \"auto\" or a number in (0, 10]";
      }
    }
    rr.finish();
    c.reduced_stiffness = config;
  }
  r.finish();
  return c;
}

std::vector<OutletConfig> parse_outlets(JsonObjectReader& top, InputErrors& errors) {
  std::vector<OutletConfig> out;
  const json* list = top.array("outlets");
  if (!list) return out;
  for (std::size_t i = 0; i < list->size(); ++i) {
    JsonObjectReader r((*list)[i], json_pointer_join("/outlets", i), errors);
    OutletConfig o;
    o.name = r.string("name", concat("outlet", i));
    const std::string type = r.required_string("type", {"plane", "box"});
    if (type == "plane") {
      o.kind = OutletKind::Plane;
      auto point = r.optional_vec3("point_m");
      auto n = r.optional_vec3("normal");
      if (r.is_object() && (!point || !n) && !(r.has("point_m") && r.has("normal")))
        errors.push_back({r.path(), "", "a plane outlet needs point_m and normal"});
      if (point) o.point_m = *point;
      if (n) {
        if (norm(*n) < 1e-12)
          errors.push_back({r.path_of("normal"), "[0,0,0]", "expected a non-zero vector"});
        else
          o.normal = *n * (1.0 / norm(*n));
      }
    } else {
      o.kind = OutletKind::Box;
      o.min_m = r.vec3("min_m", {});
      o.max_m = r.vec3("max_m", {});
      if (r.is_object() && (!r.has("min_m") || !r.has("max_m")))
        errors.push_back({r.path(), "", "a box outlet needs min_m and max_m"});
      for (int a = 0; a < 3; ++a)
        if (!(o.max_m[a] > o.min_m[a]))
          errors.push_back({r.path_of("max_m"), concat(o.max_m[a]),
                            concat("expected each component > min_m (axis ", a, ")")});
    }
    r.finish();
    out.push_back(o);
  }
  return out;
}

std::vector<FeedConfig> parse_feeds(JsonObjectReader& top,
                                    const std::vector<MaterialConfig>& materials,
                                    InputErrors& errors) {
  std::vector<FeedConfig> out;
  const json* list = top.array("feeds");
  if (!list) return out;
  for (std::size_t i = 0; i < list->size(); ++i) {
    JsonObjectReader r((*list)[i], json_pointer_join("/feeds", i), errors);
    FeedConfig f;
    f.name = r.string("name", concat("feed", i));
    f.material = find_material(materials, r, "material", errors, true);
    if (const json* region = r.child("region"))
      parse_region(*region, r.path_of("region"), f.region_min_m, f.region_max_m, errors);
    else if (r.is_object())
      errors.push_back({r.path_of("region"), "", "missing; expected {min_m, max_m}"});
    if (const json* sizes = r.child("sizes"))
      f.sizes = parse_sizes(*sizes, r.path_of("sizes"), errors);
    else if (r.is_object())
      errors.push_back({r.path_of("sizes"), "", "missing; expected a size distribution"});
    f.mass_rate_kg_per_s = r.required_number("mass_rate_kg_per_s", NumberRange::positive());
    f.velocity_m_per_s = r.vec3("velocity_m_per_s", {}, kVelocity);
    f.velocity_spread_m_per_s =
        r.number("velocity_spread_m_per_s", 0.0, NumberRange::closed(0.0, 1e4));
    f.start_s = r.number("start_s", 0.0, NumberRange::non_negative());
    f.end_s = r.number("end_s", 1e300, NumberRange::non_negative());
    if (f.end_s <= f.start_s)
      errors.push_back(
          {r.path_of("end_s"), concat(f.end_s), concat("expected > start_s = ", f.start_s)});
    r.finish();
    out.push_back(f);
  }
  return out;
}

PsdConfig parse_psd(const json& v, InputErrors& errors) {
  PsdConfig p;
  JsonObjectReader r(v, "/psd", errors);
  if (const json* edges = r.array("edges_m")) {
    for (std::size_t k = 0; k < edges->size(); ++k)
      if (auto e = read_number((*edges)[k], json_pointer_join("/psd/edges_m", k),
                               NumberRange::open_closed(0.0, 10.0), errors))
        p.edges_m.push_back(*e);
    if (p.edges_m.size() < 2)
      errors.push_back({"/psd/edges_m", json_value_text(*edges), "expected at least 2 edges"});
    for (std::size_t k = 1; k < p.edges_m.size(); ++k)
      if (!(p.edges_m[k] > p.edges_m[k - 1])) {
        errors.push_back({json_pointer_join("/psd/edges_m", k), concat(p.edges_m[k]),
                          "expected strictly ascending edges"});
        break;
      }
    if (r.has("min_m") || r.has("max_m") || r.has("bins"))
      errors.push_back({"/psd", "", "give either edges_m or min_m/max_m/bins, not both"});
  } else if (r.has("min_m") || r.has("max_m") || r.has("bins")) {
    const double lo = r.required_number("min_m", NumberRange::open_closed(0.0, 10.0));
    const double hi = r.required_number("max_m", NumberRange::open_closed(0.0, 10.0));
    const long long bins = r.integer("bins", 30, 1, 10000);
    if (hi <= lo)
      errors.push_back({"/psd/max_m", concat(hi), concat("expected > min_m = ", lo)});
    else
      for (long long k = 0; k <= bins; ++k)
        p.edges_m.push_back(lo * std::pow(hi / lo, double(k) / double(bins)));
  }
  if (const json* window = r.array("product_window_s")) {
    if (window->size() != 2) {
      errors.push_back(
          {"/psd/product_window_s", json_value_text(*window), "expected [start_s, end_s]"});
    } else {
      auto start = read_number((*window)[0], "/psd/product_window_s/0",
                               NumberRange::closed(0.0, 1e6), errors);
      auto end = read_number((*window)[1], "/psd/product_window_s/1", NumberRange::closed(0.0, 1e6),
                             errors);
      if (start && end && !(*end > *start))
        errors.push_back({"/psd/product_window_s/1", concat(*end),
                          concat("expected > the window's start, ", *start, " s")});
      else if (start && end)
        p.product_window_s = std::array<double, 2>{*start, *end};
    }
  }
  r.finish();
  return p;
}

}  // namespace

SceneConfig parse_scene(const json& doc, const std::filesystem::path& base_dir,
                        InputErrors& errors) {
  SceneConfig scene;
  scene.base_dir = base_dir;
  JsonObjectReader top(doc, "", errors);
  if (!top.is_object()) return scene;
  scene.name = top.string("name", "scene");
  scene.description = top.string("description", "");
  scene.seed = std::uint64_t(top.integer("seed", 1, 0, (1LL << 62)));
  scene.materials = parse_materials(top, errors);
  scene.domain = parse_domain(top, scene.materials, errors);
  scene.walls = parse_walls(top, scene.materials, errors);
  scene.sources = parse_sources(top, scene.materials, base_dir, errors);
  check_random_regions(scene, errors);
  scene.gravity_m_per_s2 = top.vec3("gravity_m_per_s2", {}, NumberRange::closed(-1e6, 1e6));
  scene.time = parse_time(top, errors);

  if (const json* v = top.child("contact")) scene.contact = parse_contact(*v, errors);
  if (const json* v = top.child("search")) {
    JsonObjectReader r(*v, "/search", errors);
    scene.search.conventional_nbs = r.string("method", "hashed", {"hashed", "nbs"}) == "nbs";
    // "auto" (or absent): steered; 0: no skin, the list is searched again every step.
    if (const json* skin = r.child("skin_m")) {
      if (skin->is_number() && skin->get<double>() >= 0.0)
        scene.search.skin_m = skin->get<double>();
      else if (!(skin->is_string() && *skin == "auto"))
        errors.push_back({"/search/skin_m", json_value_text(*skin),
                          "expected \"auto\" or a number >= 0 (0: search every step)"});
    }
    scene.search.cell_size_m = r.optional_number("cell_size_m", NumberRange::positive());
    if (const json* k = r.child("subcells")) {
      if (!(k->is_string() && k->get<std::string>() == "auto")) {
        const bool ok =
            k->is_number_integer() && k->get<long long>() >= 1 && k->get<long long>() <= 8;
        if (ok)
          scene.search.subcells_per_axis = int(k->get<long long>());
        else
          errors.push_back({"/search/subcells", json_value_text(*k),
                            "expected \"auto\" or an integer in [1, 8]"});
      }
    }
    if (const json* l = r.child("levels")) {
      if (!(l->is_string() && l->get<std::string>() == "auto")) {
        const bool ok = l->is_number_integer() && l->get<long long>() >= 1 &&
                        l->get<long long>() <= kMaxGridLevels;
        if (ok)
          scene.search.grid_levels = int(l->get<long long>());
        else
          errors.push_back(
              {"/search/levels", json_value_text(*l),
               "expected \"auto\" or an integer in [1, " + std::to_string(kMaxGridLevels) + "]"});
      }
    }
    if (scene.search.conventional_nbs && (scene.search.subcells_per_axis.value_or(1) > 1 ||
                                          scene.search.grid_levels.value_or(1) > 1))
      errors.push_back({"/search/method", "\"nbs\"",
                        "the conventional NBS has no sub-grid: leave subcells and levels at "
                        "\"auto\" or 1, or use method \"hashed\""});
    scene.search.rotating_frame = r.boolean("rotating_frame", true);
    scene.search.skin_by_speed = r.boolean("skin_by_speed", true);
    r.finish();
  }
  if (const json* v = top.child("breakage")) {
    JsonObjectReader r(*v, "/breakage", errors);
    BreakageConfig b;
    b.equivalence = r.string("equivalence", "energy", {"energy", "force"}) == "force"
                        ? ImpactEquivalence::Force
                        : ImpactEquivalence::Energy;
    b.placement_attempts = int(r.integer("placement_attempts", 16, 1, 1000));
    r.finish();
    scene.breakage = b;
  }
  bool carry_courant_given = false;
  if (const json* v = top.child("dust")) {
    JsonObjectReader r(*v, "/dust", errors);
    DustConfig d;
    d.threshold_diameter_m =
        r.required_number("threshold_diameter_m", NumberRange::open_closed(0.0, 10.0));
    if (r.string("model", "table", {"table", "ledger"}) == "ledger") d.model = DustModel::Ledger;
    d.grinding = r.string("grinding", "none", {"none", "sweep"}) == "sweep";
    if (r.has("gas_coupling"))
      d.two_way = r.string("gas_coupling", "two_way", {"one_way", "two_way"}) == "two_way";
    carry_courant_given = r.has("carry_courant");
    if (carry_courant_given)
      d.carry_courant = r.number("carry_courant", 0.5, NumberRange::closed(0.0, 0.5));
    scene.dust = d;
    r.finish();
  }
  if (const json* v = top.child("psd")) scene.psd = parse_psd(*v, errors);
  scene.outlets = parse_outlets(top, errors);
  scene.feeds = parse_feeds(top, scene.materials, errors);
  if (const json* v = top.child("gas")) scene.gas = parse_gas(*v, scene.domain, errors);
  if (const json* v = top.child("mill"))
    scene.mill =
        parse_mill(*v, scene.domain, scene.materials, scene.gas ? &*scene.gas : nullptr, errors);
  if (const json* v = top.child("output")) {
    JsonObjectReader r(*v, "/output", errors);
    scene.output.snapshot_interval_s =
        r.optional_number("snapshot_interval_s", NumberRange::positive());
    scene.output.timeseries_interval_s =
        r.optional_number("timeseries_interval_s", NumberRange::positive());
    scene.output.checkpoint_interval_s =
        r.optional_number("checkpoint_interval_s", NumberRange::positive());
    scene.output.write_h5 = r.boolean("h5", true);
    if (r.has("impact_spectrum"))
      scene.output.impact_spectrum = r.boolean("impact_spectrum", false);
    r.finish();
  }
  top.finish();

  // Cross-field checks that need more than one section.
  bool breakable = false;
  for (const MaterialConfig& m : scene.materials) breakable = breakable || m.breakage.has_value();
  if (breakable && !scene.breakage) scene.breakage = BreakageConfig{};
  if (breakable && !scene.dust)
    errors.push_back({"/dust/threshold_diameter_m", "",
                      "missing; a breakable material needs the dust threshold (fragments smaller "
                      "than it go to the dust table; it is also the smallest particle the time "
                      "step must resolve)"});
  if (scene.dust && scene.dust->grinding) {
    int breakable_materials = 0;
    for (const MaterialConfig& m : scene.materials) breakable_materials += m.breakage ? 1 : 0;
    if (scene.dust->model != DustModel::Ledger)
      errors.push_back({"/dust/grinding", "\"sweep\"",
                        "grinds the dust ledger's dust: set /dust/model to \"ledger\", or use "
                        "\"none\""});
    else if (breakable_materials != 1)
      errors.push_back({"/dust/grinding", "\"sweep\"",
                        concat("the ground dust takes the strength and breakage function of the "
                               "one breakable material; the scene has ",
                               breakable_materials, ": use \"none\"")});
  }
  if (scene.dust && carry_courant_given && scene.dust->model != DustModel::Ledger)
    errors.push_back({"/dust/carry_courant", concat(scene.dust->carry_courant),
                      "sets how often the dust ledger is carried: set /dust/model to \"ledger\", "
                      "or leave it out"});
  if (scene.dust && scene.dust->two_way && scene.dust->model != DustModel::Ledger)
    errors.push_back({"/dust/gas_coupling", *scene.dust->two_way ? "\"two_way\"" : "\"one_way\"",
                      "couples the dust ledger to the gas: set /dust/model to \"ledger\", or "
                      "leave it out"});
  if (scene.dust && scene.dust->model == DustModel::Ledger) {
    if (!scene.gas)
      errors.push_back({"/dust/model", "\"ledger\"",
                        "the dust ledger rides the gas: add a gas section, or use \"table\""});
    else if (scene.dust->two_way.value_or(false) && scene.gas->model != GasModel::Compressible)
      errors.push_back({"/dust/gas_coupling", "\"two_way\"",
                        "the dust acts on the compressible gas only: set /gas/model to "
                        "\"compressible\", or use \"one_way\""});
    // One particle density for the dust's relaxation times.
    std::optional<double> density;
    for (const MaterialConfig& m : scene.materials) {
      if (!m.breakage) continue;
      if (density && *density != m.density_kg_per_m3) {
        errors.push_back({"/dust/model", "\"ledger\"",
                          "the breakable materials differ in density; the ledger holds one dust "
                          "material: use \"table\""});
        break;
      }
      density = m.density_kg_per_m3;
    }
  }
  if (scene.psd.product_window_s && (*scene.psd.product_window_s)[1] > scene.time.end_s)
    errors.push_back({"/psd/product_window_s/1", concat((*scene.psd.product_window_s)[1]),
                      concat("expected a window inside the run: at most /time/end_s = ",
                             scene.time.end_s, " s")});
  if (!scene.time.fill_to_projection_s.empty()) {
    const double last = scene.time.fill_to_projection_s.back();
    const std::string path = "/time/fill_to_projection_s", value = concat(last);
    // The steady state is judged over the product window or the run's last third: after the fill.
    const double judged_from_s = scene.psd.product_window_s ? (*scene.psd.product_window_s)[0]
                                                            : scene.time.end_s * (2.0 / 3.0);
    if (!scene.mill)
      errors.push_back({path, value,
                        "the fill places turned copies of the particles about a mill's axis: add "
                        "a mill section, or remove /time/fill_to_projection_s"});
    else if (!(last < judged_from_s))
      errors.push_back(
          {path, value,
           concat("expected the last fill before the window the steady state is judged over (",
                  judged_from_s,
                  " s: /psd/product_window_s's start, or two thirds of /time/end_s), so that the "
                  "window sees the filled mill only")});
  }
  if (!breakable && top.has("breakage"))
    errors.push_back({"/breakage", "", "no material is breakable: add /materials/N/breakage"});
  for (std::size_t i = 0; i < scene.feeds.size(); ++i) {
    const FeedConfig& f = scene.feeds[i];
    for (int a = 0; a < 3; ++a)
      if (f.region_min_m[a] < scene.domain.min_m[a] || f.region_max_m[a] > scene.domain.max_m[a]) {
        errors.push_back({concat("/feeds/", i, "/region"), "",
                          "expected the region to lie inside the domain box"});
        break;
      }
  }
  for (std::size_t i = 0; i < scene.sources.size(); ++i) {
    const SourceConfig& s = scene.sources[i];
    if (s.kind != SourceKind::Random) continue;
    for (int a = 0; a < 3; ++a)
      if (s.region_min_m[a] < scene.domain.min_m[a] || s.region_max_m[a] > scene.domain.max_m[a]) {
        errors.push_back({concat("/sources/", i, "/region"), "",
                          "expected the region to lie inside the domain box"});
        break;
      }
  }
  finish_mill_scene(scene, errors);
  if (scene.gas) check_gas_outflow(*scene.gas, errors);
  return scene;
}

SceneConfig load_scene(const std::filesystem::path& path) {
  std::error_code ec;  // a name too long for the system is as missing as any other
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputErrorList({{path.string(), "", "no such scene file"}});
  std::string text;
  try {
    text = read_input_file(path, {});
  } catch (const InputFileRefused& e) {
    throw InputErrorList({{path.string(), "", e.what()}});
  }
  json doc;
  try {
    doc = parse_untrusted_json(text);
  } catch (const json::exception& e) {  // syntax, or a number beyond a double (1e999)
    throw InputErrorList({{"", "", std::string("not valid JSON: ") + e.what()}});
  } catch (const JsonTooDeep& e) {
    throw InputErrorList({{"", "", e.what()}});
  }
  InputErrors errors;
  SceneConfig scene = parse_scene(doc, path.parent_path(), errors);
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  return scene;
}

}  // namespace millsim
