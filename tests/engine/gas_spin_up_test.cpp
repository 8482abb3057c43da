// The gas spin-up as a phase of the run (sim/gas_spin_up.h, issue 32 items 3 and 4): a run
// stopped during its spin-up leaves result.json and a checkpoint of the gas, and continues from
// it; runs whose gas inputs are identical share one spin-up through the cache; and whichever way
// the gas got its spin-up (in one go, stopped and resumed, read from the cache) the run that
// follows is the same, bit for bit, as the run that spun its own gas up without stopping.
#include <gtest/gtest.h>

#include <signal.h>
#include <atomic>
#include <fstream>
#include <nlohmann/json.hpp>

#include "checkpoint/checkpoint_file.h"
#include "scene/scene_json.h"
#include "sim/gas_spin_up.h"
#include "sim/run.h"
#include "sim/simulation.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

// The spiral jet mill (the case whose spin-up users wait for), its gas spun up for 0.6 ms and
// then fed for 30 µs (about 10,000 DEM steps).
json mill_scene() {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/spiral_jet_mill.json");
  json scene = json::parse(in);
  scene["gas"]["spin_up_s"] = 6e-4;
  scene["time"]["end_s"] = 3e-5;
  scene["output"] = {{"snapshot_interval_s", 1e-5}, {"timeseries_interval_s", 2e-6}};
  return scene;
}

SceneConfig scene_of(const json& doc) {
  InputErrors errors;
  SceneConfig scene = parse_scene(doc, MILLSIM_SOURCE_DIR "/cases", errors);
  if (!errors.empty()) throw InputErrorList(errors);
  return scene;
}

// What a run ends with: its result.json, the particles and the gas field.
struct Ending {
  RunOutcome outcome;
  std::vector<Vec3> position, velocity;
  std::array<std::vector<double>, 3> gas_velocity;
  std::vector<double> gas_pressure;
  std::uint64_t spin_up_steps = 0;
};

struct Attempt {
  std::filesystem::path out_dir;
  std::filesystem::path cache_dir;
  bool resume = false;
  bool stop_during_spin_up = false;  // a stop request once the spin-up has made progress
};

Ending run_scene(const json& doc, const Attempt& a) {
  const SceneConfig scene = scene_of(doc);
  Simulation sim(scene, SimulationStart::AfterSpinUp);
  std::atomic<int> stop{0};
  RunOptions options;
  options.out_dir = a.out_dir;
  options.scene_text = doc.dump(1);
  options.resume = a.resume;
  options.spin_up_cache_dir = a.cache_dir;
  options.stop_request = &stop;
  options.progress_interval_s = 0.0;  // a report after every gas step
  if (a.stop_during_spin_up)
    options.on_spin_up_progress = [&stop](const SpinUpProgress& p) {
      if (p.done_s > 0.25 * p.total_s) stop = SIGTERM;
    };
  Ending e;
  e.outcome = run_simulation(sim, scene, options);
  const ParticleStore& p = sim.particles();
  for (std::size_t i = 0; i < p.size(); ++i) {
    e.position.push_back(p.position_m[i]);
    e.velocity.push_back(p.motion[i].velocity_m_per_s);
  }
  e.gas_velocity = sim.gas()->gas().velocity();
  e.gas_pressure = sim.gas()->gas().pressure();
  e.spin_up_steps = sim.gas()->stats().spin_up_steps;
  return e;
}

void expect_same_run(const Ending& a, const Ending& b, const char* what) {
  SCOPED_TRACE(what);
  ASSERT_GT(a.position.size(), 0u) << "the mill fed no particle: nothing is compared";
  ASSERT_EQ(a.position.size(), b.position.size());
  for (std::size_t i = 0; i < a.position.size(); ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      ASSERT_EQ(a.position[i][axis], b.position[i][axis]) << "particle slot " << i;
      ASSERT_EQ(a.velocity[i][axis], b.velocity[i][axis]) << "particle slot " << i;
    }
  }
  for (int axis = 0; axis < 3; ++axis) ASSERT_EQ(a.gas_velocity[axis], b.gas_velocity[axis]);
  ASSERT_EQ(a.gas_pressure, b.gas_pressure);
  EXPECT_EQ(a.spin_up_steps, b.spin_up_steps);
  EXPECT_EQ(test::physics_of(json::parse(a.outcome.summary.dump())),
            test::physics_of(json::parse(b.outcome.summary.dump())));
}

json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  return json::parse(in);
}

TEST(GasSpinUp, StoppedAndResumedTheRunIsTheSameAsOneThatNeverStopped) {
  MILLSIM_RELEASE_ONLY(
      "Checkpoint.ASignalDuringTheGasSpinUpLeavesResultAndCheckpointAndResume"
      "ContinuesIt (the same path through the millsim binary)");
  test::TempDir dir;
  const json scene = mill_scene();
  const Ending straight = run_scene(scene, {dir.path() / "straight", {}, false, false});
  EXPECT_EQ(straight.outcome.summary["spin_up"]["source"], "computed");
  EXPECT_GT(straight.spin_up_steps, 20u);

  const std::filesystem::path out = dir.path() / "stopped";
  const Ending stopped = run_scene(scene, {out, {}, false, true});
  ASSERT_EQ(stopped.outcome.interrupted_by, SIGTERM);
  // What the README promises a stopped run leaves: result.json saying where it stopped, and a
  // checkpoint of the gas.
  const json result = read_json(out / "result.json");
  EXPECT_EQ(result["status"], "interrupted");
  EXPECT_EQ(result["interrupted"]["phase"], "gas_spin_up");
  EXPECT_EQ(result["interrupted"]["signal"], "SIGTERM");
  const double stopped_at_s = result["spin_up"]["done_s"];
  EXPECT_GT(stopped_at_s, 0.25 * 6e-4);
  EXPECT_LT(stopped_at_s, 6e-4);
  EXPECT_EQ(result["checkpoints"]["last"], "spin-up.ckpt");
  ASSERT_TRUE(std::filesystem::exists(out / "checkpoints/spin-up.ckpt"));
  EXPECT_TRUE(stopped.position.empty()) << "no particle may be fed before the gas is spun up";

  const Ending resumed = run_scene(scene, {out, {}, true, false});
  EXPECT_EQ(resumed.outcome.summary["spin_up"]["source"], "resumed");
  EXPECT_EQ(resumed.outcome.summary["spin_up"]["resumed_from_s"].get<double>(), stopped_at_s);
  EXPECT_EQ(resumed.outcome.summary["status"], "ok");
  expect_same_run(straight, resumed, "stopped during the spin-up, then resumed");
  // A run that reached its end keeps no checkpoint, the spin-up's neither.
  EXPECT_FALSE(std::filesystem::exists(out / "checkpoints/spin-up.ckpt"));
}

TEST(GasSpinUp, RunsWithTheSameGasShareOneSpinUpAndEndTheSameAsSpinningUpAlone) {
  MILLSIM_RELEASE_ONLY("CliStudy.RunsWithTheSameGasShareOneSpinUp (the cache through millsim run)");
  test::TempDir dir;
  const std::filesystem::path cache = dir.path() / "cache";
  const json scene = mill_scene();
  // Another dust threshold, drag law and drag cache: a study's parameters, which the gas alone
  // does not see while it spins up.
  json other = scene;
  other["dust"]["threshold_diameter_m"] = 4e-5;
  other["gas"]["drag"] = "di_felice";
  other["gas"]["drag_cache"] = {{"threshold", 0.0}};
  json other_gas = scene;
  other_gas["gas"]["viscosity_pa_s"] = 1.9e-5;

  const Ending first = run_scene(scene, {dir.path() / "first", cache, false, false});
  EXPECT_EQ(first.outcome.summary["spin_up"]["source"], "computed");
  EXPECT_TRUE(first.outcome.summary["spin_up"]["cache_written"].get<bool>());
  const std::filesystem::path entry = first.outcome.summary["spin_up"]["cache_file"];
  ASSERT_TRUE(std::filesystem::exists(entry));

  const Ending shared = run_scene(other, {dir.path() / "shared", cache, false, false});
  EXPECT_EQ(shared.outcome.summary["spin_up"]["source"], "cache");
  EXPECT_EQ(shared.outcome.summary["spin_up"]["cache_file"], entry.string());
  const Ending alone = run_scene(other, {dir.path() / "alone", {}, false, false});
  EXPECT_EQ(alone.outcome.summary["spin_up"]["source"], "computed");
  expect_same_run(alone, shared, "the spin-up read from the cache");

  // Another gas is another entry: nothing read from the first.
  const Ending different = run_scene(other_gas, {dir.path() / "different", cache, false, false});
  EXPECT_EQ(different.outcome.summary["spin_up"]["source"], "computed");
  EXPECT_NE(different.outcome.summary["spin_up"]["cache_file"], entry.string());
}

TEST(GasSpinUp, TheCacheKeyChangesWithEveryGasInputAndWithNothingElse) {
  const json base = mill_scene();
  auto key_of = [](const json& doc) {
    Simulation sim(scene_of(doc), SimulationStart::AfterSpinUp);
    return gas_spin_up_key(sim, doc.dump());
  };
  const std::uint64_t k = key_of(base);
  // Inputs the gas never sees: the same key.
  json same = base;
  same["dust"]["threshold_diameter_m"] = 4e-5;
  same["time"]["end_s"] = 1e-5;
  same["seed"] = 99;
  same["name"] = "renamed";
  // ... nor how it will exchange momentum with particles.
  same["gas"]["drag"] = "beetstra";
  same["gas"]["drag_cache"] = {{"threshold", 0.0}};
  same["gas"]["coupling"] = "one_way";
  same["gas"]["saffman_lift"] = true;
  same["gas"]["pressure_gradient_force"] = false;
  same["gas"]["drag_courant"] = 5.0;
  EXPECT_EQ(key_of(same), k);
  // One change each in the sections the gas is built from: another key.
  json viscosity = base, spin_up = base, nozzles = base, cells = base, gravity = base;
  viscosity["gas"]["viscosity_pa_s"] = 1.9e-5;
  spin_up["gas"]["spin_up_s"] = 5e-4;
  nozzles["mill"]["nozzles"][0]["speed_m_per_s"] = 110.0;
  cells["gas"]["cells"][2] = 6;
  gravity["gravity_m_per_s2"] = {0, 0, -9.0};
  for (const json* changed : {&viscosity, &spin_up, &nozzles, &cells, &gravity})
    EXPECT_NE(key_of(*changed), k) << changed->dump().substr(0, 200);
}

}  // namespace
}  // namespace millsim
