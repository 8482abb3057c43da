// Results open in ParaView as they are: each shipped case, run briefly, is loaded from its
// run.xdmf by ParaView's default reader (pvpython under Xvfb, tests/paraview/read_xdmf.py), and
// every time step shows one vertex cell per particle with all the particle arrays. The counts
// are checked against the run's own summary: snapshots, particles at the start and at the end.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

struct Case {
  const char* file;
  double end_s;
};

TEST(ParaView, EveryShippedCaseOpensWithTheDefaultReader) {
  if (test::run_shell("command -v pvpython >/dev/null && command -v xvfb-run >/dev/null")
          .exit_code != 0)
    GTEST_SKIP() << "pvpython or xvfb-run is not installed (Debian paraview, python3-paraview, "
                    "xvfb)";
  const std::set<std::string> common = {"angular_velocity", "diameter", "id",
                                        "material",         "speed",    "velocity"};
  for (const Case& c : {Case{"impact_two_spheres.json", 1e-5}, Case{"settling_column.json", 0.02},
                        Case{"settling_in_air.json", 0.05}, Case{"fluidized_bed.json", 0.01},
                        Case{"attrition_target.json", 6e-4}, Case{"jet_mill_two_nozzle.json", 2e-4},
                        Case{"spiral_jet_mill.json", 3e-4}}) {
    SCOPED_TRACE(c.file);
    test::TempDir dir;
    std::ifstream in(std::string(MILLSIM_SOURCE_DIR "/cases/") + c.file);
    json scene = json::parse(in);
    scene["time"]["end_s"] = c.end_s;
    scene["output"]["snapshot_interval_s"] = c.end_s / 4;
    test::write_file(dir.path() / "scene.json", scene.dump());
    // File sources name paths relative to the case's folder.
    for (json& s : scene["sources"])
      if (s.value("type", "") == "file")
        s["path"] = std::string(MILLSIM_SOURCE_DIR "/cases/") + s["path"].get<std::string>();
    test::write_file(dir.path() / "scene.json", scene.dump());
    const test::CommandResult run =
        test::run_millsim("run scene.json --out out --quiet", dir.path());
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const json result = json::parse(run.out);
    const bool breakage = result.contains("breakage");

    // In a subshell of its own, so ParaView's stderr goes to pv.err, not into the JSON.
    const auto [status, out] = test::run_shell("(cd " + dir.path().string() +
                                               " && xvfb-run -a pvpython " MILLSIM_SOURCE_DIR
                                               "/tests/paraview/read_xdmf.py out/run.xdmf "
                                               "2>pv.err)")
                                   .status_and_output();
    ASSERT_EQ(status, 0) << out;
    const json shown = json::parse(out.substr(out.find('{')));
    EXPECT_EQ(shown["reader"], "Xdmf3ReaderS");
    const json& steps = shown["steps"];
    ASSERT_EQ(steps.size(), result["outputs"]["snapshots"].get<std::size_t>());
    EXPECT_EQ(steps.front()["points"], result["particles"]["initial"]);
    EXPECT_EQ(steps.back()["points"], result["particles"]["final"]);
    EXPECT_DOUBLE_EQ(steps.back()["time"].get<double>(), result["simulated_time_s"].get<double>());
    for (const json& step : steps) {
      EXPECT_EQ(step["cells"], step["points"]) << "one vertex cell per particle";
      if (step["points"].get<int>() == 0) continue;
      std::set<std::string> arrays = step["arrays"].get<std::set<std::string>>();
      std::set<std::string> expected = common;
      if (breakage) expected.insert({"generation", "remaining_capacity"});
      EXPECT_EQ(arrays, expected);
    }
  }
}

}  // namespace
}  // namespace millsim
