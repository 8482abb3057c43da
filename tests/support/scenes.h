// Scene builders for tests: small SceneConfigs written in code, so each test states its own
// setup. Properties default to Table 1 of the paper.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "particles/particle_store.h"
#include "scene/scene_config.h"

namespace millsim {
class Simulation;
}

namespace millsim::test {

MaterialConfig table1_material(double restitution = 0.5, double friction = 0.0);

// A closed (walled) or periodic box with one material and no particles.
SceneConfig empty_scene(Vec3 min_m, Vec3 max_m, const MaterialConfig& material,
                        std::array<bool, 3> periodic = {false, false, false});

// A fully periodic cube of edge box_length_m filled by one random (non-overlapping) source.
SceneConfig periodic_random_gas(double box_length_m, std::int64_t count,
                                const SizeDistribution& sizes, double velocity_spread_m_per_s,
                                const MaterialConfig& material, std::uint64_t seed);

// A small mill chamber (geometry/mill.h): 10 mm radius, 4 mm high, its axis at (10, 10) mm, an
// outlet tube of 2.5 mm radius reaching 1.5 mm down; no nozzles.
MillConfig small_mill_chamber();

// Adds one list source with a particle.
void add_particle(SceneConfig& scene, Vec3 position_m, Vec3 velocity_m_per_s, double diameter_m,
                  int material = 0);

// A power-law breakage function B(r) ∝ r^exponent on [min_ratio, max_ratio].
FragmentConfig power_law_fragments(double exponent, double min_ratio, double max_ratio);

// Every error parse_scene reports for a scene document (base directory ".").
InputErrors scene_errors(const nlohmann::json& doc);

// The shipped spiral jet mill (cases/spiral_jet_mill.json) to `end_s`, with the dust ledger
// (threshold 20 µm, grinding on) and two feeds next to its outlet tube instead of its own: salt
// grains of 25–30 µm rising gently into the tube's mouth, and 100 µm grains shot at the floor
// under it at 60 m/s, where they break. Each feed ends at `feeds_end_s` when given.
nlohmann::json mill_with_ledger_outflows(double end_s, std::optional<double> feeds_end_s);

// A stream of 200 µm glass beads fed at 0.36 g/s under a mill's outlet tube, rising at 1 m/s
// without gravity or gas into its mouth about 2.9 ms above, to 10 ms, with a hold-up fill at
// 3.625 ms (the hold-up fill tests derive what the fill projects).
nlohmann::json rising_stream_mill();

// Parses a scene document (base directory "."), runs it to its end in a fresh directory and
// returns its result.json; a test failure and an empty object when the scene is refused or the
// run fails. With `kept`, the run's Simulation is handed over there for its final state.
nlohmann::json run_scene_document(const nlohmann::json& doc,
                                  std::unique_ptr<Simulation>* kept = nullptr);

// A run's result.json without what depends on the wall clock, on the run having been resumed or
// on how its gas got its spin-up (and the pressure matrix's builds: it is factorised again after
// a restore, not part of the state), for comparing two runs' physics.
nlohmann::json physics_of(nlohmann::json result);

// Σ m v over the particles.
Vec3 total_momentum(const ParticleStore& particles);

// A fresh empty directory under the system temp dir, removed with its contents on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace millsim::test
