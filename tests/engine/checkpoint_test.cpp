// Checkpoints: a run saved at a step and restored into a fresh Simulation of the same scene goes
// on bit for bit as the run that never stopped (plain DEM, breakage with feeds, outlet and dust,
// and the coupled gas); checkpoint files are read back only when whole.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "checkpoint/checkpoint_file.h"
#include "core/errors.h"
#include "scene/scene_json.h"
#include "sim/simulation.h"
#include "support/process.h"
#include "support/run_compare.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

using test::expect_identical;
using test::shipped_case;

struct Case {
  const char* file;
  double end_s;
  bool ramped_inlet = false;  // the bed's inlet ramps up through the split (a schedule)
  bool multi_rate = false;    // particles in free flight take long steps (sim/multi_rate.h)
  bool dust_ledger = false;   // a downward gas flow and the dust ledger (dust/dust_ledger.h)
  bool wall_riders = false;   // particles on walls alone take steps of their own too
};

// The attrition target under air blown down at 8 m/s, its dust in the ledger, ground by the
// particles that sweep it.
void add_gas_and_dust_ledger(SceneConfig& scene) {
  GasConfig gas;
  gas.cells = {8, 4, 10};
  GasBoundaryPatch top, bottom;
  top.name = "top", top.face = 5, top.kind = GasBoundaryKind::Inlet;
  top.velocity_m_per_s = {0, 0, -8.0};
  bottom.name = "bottom", bottom.face = 4, bottom.kind = GasBoundaryKind::Outlet;
  gas.boundaries = {top, bottom};
  scene.gas = gas;
  scene.dust->model = DustModel::Ledger;
  scene.dust->grinding = true;
  scene.dust->threshold_diameter_m = 6e-5;  // a coarser threshold: a larger step
}

TEST(Checkpoint, RestoredRunContinuesBitForBit) {
  // Under the sanitizers (5-15x slower; their run checks the memory safety of saving and
  // restoring) half the bed's window.
#if defined(MILLSIM_SANITIZED)
  constexpr double kBedEnd = 0.005;
#else
  constexpr double kBedEnd = 0.01;
#endif
  for (const Case& c :
       {Case{"settling_column.json", 0.01}, Case{"attrition_target.json", 3e-4},
        Case{"fluidized_bed.json", kBedEnd}, Case{"fluidized_bed.json", kBedEnd, true},
        Case{"attrition_target.json", 3e-4, false, true},
        Case{"fluidized_bed.json", kBedEnd, false, true},
        Case{"spiral_jet_mill_4barg.json", 5e-5, false, true},
        Case{"attrition_target.json", 6e-4, false, false, true},
        Case{"attrition_target.json", 3e-4, false, true, false, true},
        Case{"attrition_target.json", 6e-4, false, true, true, true}}) {
    SCOPED_TRACE(std::string(c.file) + (c.ramped_inlet ? ", ramped inlet" : "") +
                 (c.multi_rate ? ", multi-rate" : "") + (c.dust_ledger ? ", dust ledger" : "") +
                 (c.wall_riders ? ", wall riders" : ""));
    SceneConfig scene = shipped_case(c.file, test::bit_for_bit_window_s(c.file, c.end_s));
    if (c.dust_ledger) add_gas_and_dust_ledger(scene);
    scene.time.multi_rate = c.multi_rate;
    scene.time.wall_riders = c.wall_riders;
    if (scene.gas && scene.gas->model == GasModel::Compressible)
      scene.gas->spin_up_s = 0.0;  // the jets start blowing at time 0: the gas changes fast
    if (c.ramped_inlet) {
      scene.gas->boundaries.at(0).velocity_m_per_s = {};
      scene.gas->boundaries.at(0).schedule = InflowSchedule{{{0.0, 0.01}, {0.05, 0.3}}, false};
    }
    Simulation whole(scene);
    const std::int64_t total = whole.total_steps();
    ASSERT_FALSE(whole.advance(total));
    // Split at a third and at an odd step past two thirds (off any rebuild or CFD rhythm). Under
    // the sanitizers, whose run checks the memory safety of saving and restoring, at the odd step
    // only (the test's six cases at both splits take two minutes there).
#if defined(MILLSIM_SANITIZED)
    const std::vector<std::int64_t> splits{2 * total / 3 + 7};
#else
    const std::vector<std::int64_t> splits{total / 3, 2 * total / 3 + 7};
#endif
    for (const std::int64_t split : splits) {
      SCOPED_TRACE(split);
      Simulation first(scene);
      ASSERT_FALSE(first.advance(split));
      ArchiveWriter saved;
      first.checkpoint_io(saved);

      Simulation resumed(scene, true);  // a fresh run of the scene, then the saved state into it
      ArchiveReader reader(saved.data().data(), saved.data().size());
      resumed.checkpoint_io(reader);
      EXPECT_TRUE(reader.at_end());
      ASSERT_EQ(resumed.step_index(), split);
      ASSERT_FALSE(resumed.advance(total - split));
      if (!c.multi_rate) {
        expect_identical(whole, resumed);
        continue;
      }
      // With multi-rate stepping the particles in free flight are caught up where each advance()
      // ends, so the run that never stopped is advanced over the same two spans.
      Simulation unbroken(scene);
      ASSERT_FALSE(unbroken.advance(split));
      ASSERT_FALSE(unbroken.advance(total - split));
      expect_identical(unbroken, resumed);
      EXPECT_GT(unbroken.multi_rate()->stats.waiting_particle_steps, 0.0)
          << "the case must have particles in free flight";
      if (c.wall_riders) {
        EXPECT_GT(unbroken.multi_rate()->stats.rider_steps, 0.0)
            << "the case must have particles riding walls on their own step";
      }
    }
    if (std::string(c.file) == "attrition_target.json") {
      EXPECT_GT(whole.breakage()->stats().events, 0u) << "the case must break something";
    }
    if (c.dust_ledger) {
      double ground = 0.0;
      for (double kg : whole.dust_grinding()->stats().ground_kg) ground += kg;
      EXPECT_GT(ground, 0.0) << "the case must grind dust";
    }
  }
}

TEST(Checkpoint, FilesAreReadBackOnlyWhole) {
  test::TempDir dir;
  CheckpointHeader header{"0.1.0", "abc", checkpoint_layout(), 42, 100, 1e-3, 2.0};
  std::string state(1000, '\0');
  for (std::size_t k = 0; k < state.size(); ++k) state[k] = char(k * 7);
  write_checkpoint(dir.path(), header, state, 2);
  header.step = 200;
  const std::filesystem::path second = write_checkpoint(dir.path(), header, state, 2);
  header.step = 300;
  const std::filesystem::path newest = write_checkpoint(dir.path(), header, state, 2);
  // The newest two are kept, newest first.
  const std::vector<std::filesystem::path> kept = list_checkpoints(dir.path());
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0], newest);
  EXPECT_EQ(kept[1], second);

  const Checkpoint back = read_checkpoint(newest);
  EXPECT_EQ(back.header.step, 300);
  EXPECT_EQ(back.header.scene_hash, 42u);
  EXPECT_EQ(back.header.git_commit, "abc");
  EXPECT_EQ(back.state, state);

  std::ifstream in(newest, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto reason = [&](const std::string& content) {
    const std::filesystem::path p = dir.path() / "step-000000000999.ckpt";
    test::write_file(p, content);
    try {
      read_checkpoint(p);
    } catch (const CheckpointError& e) {
      return std::string(e.what());
    }
    return std::string("read");
  };
  EXPECT_NE(reason(bytes.substr(0, bytes.size() / 2)).find("checksum"), std::string::npos);
  EXPECT_NE(reason(bytes.substr(0, 10)).find("truncated"), std::string::npos);
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  EXPECT_NE(reason(flipped).find("checksum"), std::string::npos);
  std::string foreign = bytes;
  foreign[0] = 'X';
  EXPECT_NE(reason(foreign).find("not a millsim checkpoint"), std::string::npos);
  EXPECT_EQ(reason(bytes), "read");
}

TEST(Checkpoint, SceneHashIgnoresLayoutButNotValues) {
  EXPECT_EQ(scene_hash(R"({"a": 1, "b": [1, 2]})"), scene_hash("{\"b\":[1,2],\n \"a\":1}"));
  EXPECT_NE(scene_hash(R"({"a": 1, "b": [1, 2]})"), scene_hash(R"({"a": 1, "b": [1, 3]})"));
}

}  // namespace
}  // namespace millsim
