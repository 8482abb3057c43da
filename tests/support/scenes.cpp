#include "support/scenes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <memory>
#include <random>

#include "scene/scene_json.h"
#include "sim/run.h"
#include "sim/simulation.h"

namespace millsim::test {

FragmentConfig power_law_fragments(double exponent, double min_ratio, double max_ratio) {
  FragmentConfig f;
  f.model = FragmentModel::PowerLaw;
  f.exponent = exponent;
  f.min_ratio = min_ratio;
  f.max_ratio = max_ratio;
  return f;
}

nlohmann::json run_scene_document(const nlohmann::json& doc, std::unique_ptr<Simulation>* kept) {
  InputErrors errors;
  const SceneConfig scene = parse_scene(doc, ".", errors);
  EXPECT_TRUE(errors.empty()) << errors.front().path << ": " << errors.front().allowed;
  if (!errors.empty()) return nlohmann::json::object();
  auto sim = std::make_unique<Simulation>(scene);
  TempDir dir;
  RunOptions options;
  options.out_dir = dir.path();
  const bool failed = bool(run_simulation(*sim, scene, options).failure);
  EXPECT_FALSE(failed);
  if (kept) *kept = std::move(sim);
  std::ifstream in(dir.path() / "result.json");
  if (failed || !in) return nlohmann::json::object();
  return nlohmann::json::parse(in);
}

nlohmann::json rising_stream_mill() {
  return {{"name", "rising_stream_mill"},
          {"seed", 5},
          {"domain", {{"min_m", {0, 0, 0}}, {"max_m", {0.04, 0.04, 0.006}}}},
          {"materials",
           {{{"name", "glass"},
             {"youngs_modulus_pa", 1e7},
             {"poisson_ratio", 0.25},
             {"density_kg_per_m3", 2500},
             {"restitution", 0.5},
             {"friction", 0.3}}}},
          {"mill",
           {{"center_xy_m", {0.02, 0.02}},
            {"radius_m", 0.02},
            {"wall_material", "glass"},
            {"outlet", {{"name", "vortex_finder"}, {"radius_m", 0.005}, {"depth_m", 0.002}}}}},
          {"sources", nlohmann::json::array()},
          {"feeds",
           {{{"name", "under_the_mouth"},
             {"material", "glass"},
             {"mass_rate_kg_per_s", 3.6e-4},
             {"region", {{"min_m", {0.018, 0.018, 0.0009}}, {"max_m", {0.022, 0.022, 0.0013}}}},
             {"sizes", {{"distribution", "uniform"}, {"min_m", 2e-4}, {"max_m", 2e-4}}},
             {"velocity_m_per_s", {0, 0, 1}}}}},
          {"time", {{"end_s", 0.01}, {"step_s", 1e-6}, {"fill_to_projection_s", 0.003625}}},
          {"output", {{"h5", false}, {"snapshot_interval_s", 0.0005}}}};
}

nlohmann::json mill_with_ledger_outflows(double end_s, std::optional<double> feeds_end_s) {
  std::ifstream in(std::string(MILLSIM_SOURCE_DIR) + "/cases/spiral_jet_mill.json");
  nlohmann::json doc = nlohmann::json::parse(in);
  doc["time"]["end_s"] = end_s;
  doc["dust"] = {{"threshold_diameter_m", 2e-5}, {"model", "ledger"}, {"grinding", "sweep"}};
  doc["feeds"] = {
      {{"name", "mouth"},
       {"material", "salt"},
       {"mass_rate_kg_per_s", 2e-6},
       {"region", {{"min_m", {0.0185, 0.0185, 0.0025}}, {"max_m", {0.0215, 0.0215, 0.0035}}}},
       {"sizes", {{"distribution", "uniform"}, {"min_m", 2.5e-5}, {"max_m", 3e-5}}},
       {"velocity_m_per_s", {0, 0, 5}}},
      {{"name", "floor_shot"},
       {"material", "salt"},
       {"mass_rate_kg_per_s", 2e-5},
       {"region", {{"min_m", {0.017, 0.017, 0.0015}}, {"max_m", {0.023, 0.023, 0.0022}}}},
       {"sizes", {{"distribution", "uniform"}, {"min_m", 1e-4}, {"max_m", 1e-4}}},
       {"velocity_m_per_s", {0, 0, -60}}}};
  if (feeds_end_s)
    for (nlohmann::json& feed : doc["feeds"]) feed["end_s"] = *feeds_end_s;
  return doc;
}

InputErrors scene_errors(const nlohmann::json& doc) {
  InputErrors errors;
  parse_scene(doc, ".", errors);
  return errors;
}

MaterialConfig table1_material(double restitution, double friction) {
  MaterialConfig m;
  m.name = "table1";
  m.youngs_modulus_pa = 1e9;
  m.poisson_ratio = 0.3;
  m.density_kg_per_m3 = 2000.0;
  m.restitution = restitution;
  m.friction = friction;
  return m;
}

SceneConfig empty_scene(Vec3 min_m, Vec3 max_m, const MaterialConfig& material,
                        std::array<bool, 3> periodic) {
  SceneConfig s;
  s.name = "test";
  s.domain.min_m = min_m;
  s.domain.max_m = max_m;
  s.domain.periodic = periodic;
  s.materials.push_back(material);
  s.time.end_s = 1.0;
  s.output.write_h5 = false;
  return s;
}

SceneConfig periodic_random_gas(double L, std::int64_t count, const SizeDistribution& sizes,
                                double spread, const MaterialConfig& material, std::uint64_t seed) {
  SceneConfig s = empty_scene({0, 0, 0}, {L, L, L}, material, {true, true, true});
  SourceConfig source;
  source.kind = SourceKind::Random;
  source.count = count;
  source.region_min_m = {0, 0, 0};
  source.region_max_m = {L, L, L};
  source.sizes = sizes;
  source.velocity_spread_m_per_s = spread;
  s.sources.push_back(source);
  s.seed = seed;
  return s;
}

MillConfig small_mill_chamber() {
  MillConfig m;
  m.axis_point_m = {0.01, 0.01, 0.0};
  m.radius_m = 0.01;
  m.height_m = 0.004;
  m.outlet.radius_m = 0.0025;
  m.outlet.depth_m = 0.0015;
  return m;
}

void add_particle(SceneConfig& scene, Vec3 position_m, Vec3 velocity_m_per_s, double diameter_m,
                  int material) {
  SourceConfig source;
  source.kind = SourceKind::List;
  source.material = material;
  source.particles.push_back({position_m, velocity_m_per_s, {}, diameter_m});
  scene.sources.push_back(source);
}

Vec3 total_momentum(const ParticleStore& p) {
  Vec3 sum;
  for (std::size_t i = 0; i < p.size(); ++i) sum += p.motion[i].velocity_m_per_s * p.mass_kg[i];
  return sum;
}

nlohmann::json physics_of(nlohmann::json result) {
  for (const char* key : {"wall_time_s", "wall_time_total_s", "particle_steps_per_second",
                          "phase_seconds", "resumed", "checkpoints", "outputs", "spin_up"})
    result.erase(key);
  if (result.contains("gas"))
    result["gas"].erase("seconds"), result["gas"].erase("pressure_matrix_builds");
  return result;
}

TempDir::TempDir() {
  std::random_device seed;
  path_ = std::filesystem::temp_directory_path() /
          ("millsim-test-" + std::to_string(getpid()) + "-" + std::to_string(seed()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

}  // namespace millsim::test
