// Scene validation: every bad field is reported with its JSON path, the value and what is
// allowed; all errors at once. Expectation: the messages documented in docs/scene-format.md.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/json_reader.h"
#include "particles/particle_sources.h"
#include "scene/scene_json.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

json valid_scene() {
  return json::parse(R"({
    "name": "ok",
    "domain": {"min_m": [0,0,0], "max_m": [1e-3,1e-3,1e-3]},
    "materials": [{"name": "m", "youngs_modulus_pa": 1e9, "poisson_ratio": 0.3,
                   "density_kg_per_m3": 2000, "restitution": 0.5, "friction": 0.3}],
    "sources": [{"type": "list", "material": "m",
                 "particles": [{"position_m": [5e-4,5e-4,5e-4], "diameter_m": 1e-4}]}],
    "time": {"end_s": 1e-5}
  })");
}

InputErrors errors_of(const json& doc) {
  return test::scene_errors(doc);
}

const InputError* find_error(const InputErrors& errors, const std::string& path) {
  for (const InputError& e : errors)
    if (e.path == path) return &e;
  return nullptr;
}

TEST(SceneJson, ValidSceneHasNoErrors) {
  InputErrors errors;
  const SceneConfig s = parse_scene(valid_scene(), ".", errors);
  EXPECT_TRUE(errors.empty()) << format_input_errors("scene", errors);
  EXPECT_EQ(s.materials.at(0).restitution, 0.5);
  EXPECT_EQ(s.sources.at(0).particles.at(0).diameter_m, 1e-4);
  EXPECT_FALSE(s.time.step_s.has_value());  // automatic by default
}

TEST(SceneJson, WallRidersNeedMultiRateStepping) {
  json doc = valid_scene();
  doc["time"]["wall_riders"] = true;
  const InputErrors errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "/time/wall_riders");
  EXPECT_NE(errors[0].allowed.find("/time/multi_rate"), std::string::npos) << errors[0].allowed;
  doc["time"]["multi_rate"] = true;
  EXPECT_TRUE(errors_of(doc).empty());
}

TEST(SceneJson, EveryShippedSceneLoads) {
  // Each scene in cases/ (not the studies) loads without an input error, and builds.
  int scenes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(MILLSIM_SOURCE_DIR "/cases")) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".json" || name.find(".study.") != std::string::npos) continue;
    SCOPED_TRACE(name);
    try {
      const SceneConfig scene = load_scene(entry.path());
      EXPECT_FALSE(scene.name.empty());
      ++scenes;
    } catch (const InputErrorList& e) {
      ADD_FAILURE() << e.errors().front().path << ": " << e.errors().front().allowed;
    }
  }
  EXPECT_GE(scenes, 9);
}

TEST(SceneJson, OutOfRangeValueNamesPathValueAndRange) {
  json doc = valid_scene();
  doc["materials"][0]["restitution"] = 1.3;
  const InputErrors errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "/materials/0/restitution");
  EXPECT_EQ(errors[0].value, "1.3");
  EXPECT_EQ(errors[0].allowed, "expected a number in [0, 1]");
}

TEST(SceneJson, SpeedsBeyondWhatARunCanHoldAreRefused) {
  // 1e308 m/s would give an infinite kinetic energy (null energies in result.json).
  json doc = valid_scene();
  doc["sources"][0]["particles"][0]["velocity_m_per_s"] = {1e308, 0, 0};
  doc["sources"][0]["particles"][0]["angular_velocity_rad_per_s"] = {0, 0, -1e300};
  const InputErrors errors = errors_of(doc);
  const InputError* v = find_error(errors, "/sources/0/particles/0/velocity_m_per_s/0");
  const InputError* w = find_error(errors, "/sources/0/particles/0/angular_velocity_rad_per_s/2");
  ASSERT_NE(v, nullptr) << format_input_errors("scene", errors);
  ASSERT_NE(w, nullptr) << format_input_errors("scene", errors);
  EXPECT_EQ(v->allowed, "expected a number in [-100000, 100000]");
}

TEST(SceneJson, GridDivisionIsAutoOrInRange) {
  json doc = valid_scene();
  doc["search"] = {{"subcells", 3}, {"levels", 4}};
  InputErrors errors;
  const SceneConfig s = parse_scene(doc, ".", errors);
  EXPECT_TRUE(errors.empty()) << format_input_errors("scene", errors);
  EXPECT_EQ(s.search.subcells_per_axis, 3);
  EXPECT_EQ(s.search.grid_levels, 4);
  doc["search"] = {{"subcells", "auto"}, {"levels", "auto"}};
  EXPECT_FALSE(parse_scene(doc, ".", errors).search.grid_levels.has_value());
  doc["search"] = {{"levels", 5}};
  const InputErrors bad = errors_of(doc);
  ASSERT_EQ(bad.size(), 1u);
  EXPECT_EQ(bad[0].path, "/search/levels");
  EXPECT_EQ(bad[0].value, "5");
  EXPECT_EQ(bad[0].allowed, "expected \"auto\" or an integer in [1, 4]");
}

TEST(SceneJson, RotatingFrameAndSkinBySpeedAreOnUnlessSetFalseAndMustBeBools) {
  for (const char* key : {"rotating_frame", "skin_by_speed"}) {
    auto flag = [&](const SceneConfig& s) {
      return std::string(key) == "rotating_frame" ? s.search.rotating_frame
                                                  : s.search.skin_by_speed;
    };
    json doc = valid_scene();
    InputErrors errors;
    EXPECT_TRUE(flag(parse_scene(doc, ".", errors))) << key;
    doc["search"] = {{key, false}};
    EXPECT_FALSE(flag(parse_scene(doc, ".", errors))) << key;
    EXPECT_TRUE(errors.empty()) << format_input_errors("scene", errors);
    doc["search"] = {{key, "yes"}};
    const InputErrors bad = errors_of(doc);
    ASSERT_EQ(bad.size(), 1u) << key;
    EXPECT_EQ(bad[0].path, std::string("/search/") + key);
    EXPECT_EQ(bad[0].value, "\"yes\"");
  }
}

TEST(SceneJson, SkinIsAutoOrANonNegativeLength) {
  json doc = valid_scene();
  InputErrors errors;
  doc["search"] = {{"skin_m", 0}};
  EXPECT_EQ(parse_scene(doc, ".", errors).search.skin_m, 0.0);
  doc["search"] = {{"skin_m", "auto"}};
  EXPECT_FALSE(parse_scene(doc, ".", errors).search.skin_m.has_value());
  EXPECT_TRUE(errors.empty()) << format_input_errors("scene", errors);
  for (const json& bad_value : {json("fast"), json(-1e-6), json(true)}) {
    doc["search"] = {{"skin_m", bad_value}};
    const InputErrors bad = errors_of(doc);
    ASSERT_EQ(bad.size(), 1u) << bad_value;
    EXPECT_EQ(bad[0].path, "/search/skin_m");
    EXPECT_EQ(bad[0].value, bad_value.dump());
    EXPECT_EQ(bad[0].allowed, "expected \"auto\" or a number >= 0 (0: search every step)");
  }
}

TEST(SceneJson, WrongTypeIsRejected) {
  json doc = valid_scene();
  doc["time"]["end_s"] = "ten";
  doc["domain"]["periodic"] = {true, "no", false};
  const InputErrors errors = errors_of(doc);
  const InputError* e = find_error(errors, "/time/end_s");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->value, "\"ten\"");
  ASSERT_NE(find_error(errors, "/domain/periodic"), nullptr);
  EXPECT_EQ(errors.size(), 2u) << "all errors are collected, not just the first";
}

TEST(SceneJson, UnknownKeySuggestsTheNearestKnownOne) {
  json doc = valid_scene();
  doc["breakge"] = json::object();
  doc["materials"][0]["densty_kg_per_m3"] = 1;
  const InputErrors errors = errors_of(doc);
  const InputError* top = find_error(errors, "/breakge");
  ASSERT_NE(top, nullptr);
  EXPECT_NE(top->allowed.find("unknown key"), std::string::npos);
  EXPECT_NE(top->allowed.find("materials"), std::string::npos) << "lists the known keys";
  const InputError* nested = find_error(errors, "/materials/0/densty_kg_per_m3");
  ASSERT_NE(nested, nullptr);
  EXPECT_NE(nested->allowed.find("did you mean \"density_kg_per_m3\""), std::string::npos);
}

TEST(SceneJson, MissingRequiredFieldsAreNamed) {
  json doc = valid_scene();
  doc["materials"][0].erase("youngs_modulus_pa");
  doc.erase("time");
  const InputErrors errors = errors_of(doc);
  EXPECT_NE(find_error(errors, "/materials/0/youngs_modulus_pa"), nullptr);
  EXPECT_NE(find_error(errors, "/time"), nullptr);
}

// The published breakage functions: each model's own parameters are required and named when
// missing or out of range; min_ratio may be 0 (the published domain), max_ratio stays below 1.
TEST(SceneJson, BreakageFunctionsNameTheirParameters) {
  json doc = valid_scene();
  doc["dust"] = {{"threshold_diameter_m", 1e-5}};
  doc["materials"][0]["breakage"] = json::parse(R"({
    "strength": {"model": "vogel_peukert", "f_mat_kg_per_j_m": 8, "x_w_min_j_m_per_kg": 0.1},
    "fragments": {"model": "austin_luckie", "fine_fraction": 1.5, "fine_exponent": 0.8,
                  "min_ratio": 0}})");
  InputErrors errors = errors_of(doc);
  const InputError* range = find_error(errors, "/materials/0/breakage/fragments/fine_fraction");
  ASSERT_NE(range, nullptr);
  EXPECT_EQ(range->value, "1.5");
  EXPECT_NE(find_error(errors, "/materials/0/breakage/fragments/coarse_exponent"), nullptr);
  EXPECT_EQ(find_error(errors, "/materials/0/breakage/fragments/min_ratio"), nullptr);
  EXPECT_EQ(errors.size(), 2u);

  doc["materials"][0]["breakage"]["fragments"] =
      json::parse(R"({"model": "vogel_peukert", "exponent": 1.2, "max_ratio": 1.05})");
  errors = errors_of(doc);
  EXPECT_NE(find_error(errors, "/materials/0/breakage/fragments/chipping_diameter_m"), nullptr);
  EXPECT_NE(find_error(errors, "/materials/0/breakage/fragments/max_ratio"), nullptr);

  doc["materials"][0]["breakage"]["fragments"] = json::parse(
      R"({"model": "vogel_peukert", "exponent": 1.2, "chipping_diameter_m": 5e-5, "min_ratio": 0})");
  EXPECT_TRUE(errors_of(doc).empty());
}

TEST(SceneJson, UnknownMaterialNameListsTheDefinedOnes) {
  json doc = valid_scene();
  doc["sources"][0]["material"] = "steel";
  const InputErrors errors = errors_of(doc);
  const InputError* e = find_error(errors, "/sources/0/material");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->allowed, "expected one of the material names: m");
}

TEST(SceneJson, InvertedDomainAndBadEnumAreRejected) {
  json doc = valid_scene();
  doc["domain"]["max_m"] = {1e-3, -1.0, 1e-3};
  doc["contact"] = {{"model", "hooke"}};
  const InputErrors errors = errors_of(doc);
  EXPECT_NE(find_error(errors, "/domain/max_m/1"), nullptr);
  const InputError* model = find_error(errors, "/contact/model");
  ASSERT_NE(model, nullptr);
  EXPECT_EQ(model->allowed, "expected one of series paper equivalent");
}

TEST(SceneJson, RandomRegionOutsideDomainIsRejected) {
  json doc = valid_scene();
  doc["sources"][0] = json::parse(R"({"type": "random", "material": "m", "count": 10,
      "region": {"min_m": [0,0,0], "max_m": [2e-3,1e-3,1e-3]},
      "sizes": {"distribution": "fixed", "diameter_m": 1e-4}})");
  EXPECT_NE(find_error(errors_of(doc), "/sources/0/region"), nullptr);
}

TEST(SceneJson, RandomRegionNarrowerThanItsSmallestParticleIsRejected) {
  // Each particle is placed whole inside the region: 50 um along y cannot hold 80-100 um spheres.
  json doc = valid_scene();
  doc["sources"][0] = json::parse(R"({"type": "random", "material": "m", "count": 3,
      "region": {"min_m": [0,4e-4,0], "max_m": [1e-3,4.5e-4,1e-3]},
      "sizes": {"distribution": "uniform", "min_m": 8e-5, "max_m": 1e-4}})");
  const InputErrors errors = errors_of(doc);
  ASSERT_EQ(errors.size(), 1u) << format_input_errors("scene", errors);
  EXPECT_EQ(errors[0].path, "/sources/0/region");
  EXPECT_EQ(errors[0].allowed,
            "its extent along y (5e-05 m) is below the smallest particle's diameter (8e-05 m); "
            "each particle is placed whole inside it");
  // Between the smallest and the largest size the scene loads, and the placement names the axis
  // when the first particle too wide for it comes.
  SourceConfig source;
  source.kind = SourceKind::Random;
  source.count = 20;
  source.region_min_m = {0, 4e-4, 0};
  source.region_max_m = {1e-3, 4.9e-4, 1e-3};
  source.sizes = {SizeDistributionKind::Uniform, 0.0, 8e-5, 1e-4, 0.0, 1.0, -2.5};
  Rng rng(5);
  InputErrors placing;
  const PeriodicBox box{{0, 0, 0}, {1e-3, 1e-3, 1e-3}, {false, false, false}};
  EXPECT_TRUE(random_packing(source, box, {}, rng, "/sources/0/count", placing).empty());
  ASSERT_EQ(placing.size(), 1u);
  EXPECT_NE(placing[0].allowed.find("placed 0 particles; the next (d = "), std::string::npos);
  EXPECT_NE(placing[0].allowed.find("m) does not fit the region whole along y (extent 9e-05 m)"),
            std::string::npos)
      << placing[0].allowed;
}

TEST(NumberRange, DescribesBoundsAsWritten) {
  EXPECT_EQ(NumberRange::positive().describe(), "expected a number > 0");
  EXPECT_EQ(NumberRange::open_closed(0, 1).describe(), "expected a number in (0, 1]");
  EXPECT_FALSE(NumberRange::any().contains(std::nan("")));
}

}  // namespace
}  // namespace millsim
