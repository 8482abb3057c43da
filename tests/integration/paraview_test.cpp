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
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

struct Case {
  const char* file;
  double end_s;
};

TEST(ParaView, EveryShippedCaseOpensWithTheDefaultReader) {
  // What ParaView reads does not depend on the sanitizers, and under them the mill's gas spin-up
  // alone takes minutes.
  MILLSIM_RELEASE_ONLY("tests/engine/output_test.cpp (the XDMF and HDF5 writers)");
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

    // What ParaView's default reader shows of one XDMF file of the run: one block per time.
    auto open_in_paraview = [&](const std::string& file) {
      // In a subshell of its own, so ParaView's stderr goes to pv.err, not into the JSON.
      const auto [status, out] = test::run_shell("(cd " + dir.path().string() +
                                                 " && xvfb-run -a pvpython " MILLSIM_SOURCE_DIR
                                                 "/tests/paraview/read_xdmf.py out/" +
                                                 file + " 2>pv.err)")
                                     .status_and_output();
      EXPECT_EQ(status, 0) << out;
      const json shown = json::parse(out.substr(out.find('{')));
      EXPECT_EQ(shown["reader"], "Xdmf3ReaderS");
      std::vector<json> blocks;
      for (const json& step : shown["steps"]) {
        EXPECT_EQ(step["blocks"].size(), 1u) << file;
        blocks.push_back(step["blocks"].begin().value());
        blocks.back()["time"] = step["time"];
      }
      return blocks;
    };
    const json& outputs = result["outputs"];
    const std::vector<json> steps = open_in_paraview("run.xdmf");
    ASSERT_EQ(steps.size(), outputs["snapshots"].get<std::size_t>());
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

    // The gas field at every snapshot time, on the gas grid of the scene.
    ASSERT_EQ(outputs.contains("gas_xdmf"), scene.contains("gas") || scene.contains("mill"));
    if (outputs.contains("gas_xdmf")) {
      const std::vector<json> gas = open_in_paraview("gas.xdmf");
      ASSERT_EQ(gas.size(), steps.size());
      const std::vector<int> n = result["gas"]["cells"].get<std::vector<int>>();
      for (std::size_t k = 0; k < gas.size(); ++k) {
        EXPECT_EQ(gas[k]["cells"], n[0] * n[1] * n[2]);
        EXPECT_EQ(gas[k]["points"], (n[0] + 1) * (n[1] + 1) * (n[2] + 1));
        EXPECT_EQ(gas[k]["cell_arrays"].get<std::set<std::string>>(),
                  (std::set<std::string>{"fluid", "pressure", "velocity", "volume_fraction"}));
        EXPECT_DOUBLE_EQ(gas[k]["time"].get<double>(), steps[k]["time"].get<double>());
        for (int a = 0; a < 3; ++a) {  // the grid spans the domain
          EXPECT_NEAR(gas[k]["bounds"][2 * a].get<double>(),
                      scene["domain"]["min_m"][a].get<double>(), 1e-12);
          EXPECT_NEAR(gas[k]["bounds"][2 * a + 1].get<double>(),
                      scene["domain"]["max_m"][a].get<double>(), 1e-12);
        }
      }
    }

    // The walls, outlets and inlets as triangles, inside the domain (to the nozzles' radius).
    if (outputs.contains("geometry_xdmf")) {
      const std::vector<json> geometry = open_in_paraview("geometry.xdmf");
      ASSERT_EQ(geometry.size(), 1u);
      EXPECT_GT(geometry[0]["cells"].get<int>(), 0);
      EXPECT_EQ(geometry[0]["cell_arrays"], json::array({"part"}));
      for (int a = 0; a < 3; ++a) {
        const double lo = scene["domain"]["min_m"][a], hi = scene["domain"]["max_m"][a];
        // Nozzle exits on a curved mantle stand out of it by up to their radius.
        const double slack = 0.02 * (hi - lo);
        EXPECT_GE(geometry[0]["bounds"][2 * a].get<double>(), lo - slack);
        EXPECT_LE(geometry[0]["bounds"][2 * a + 1].get<double>(), hi + slack);
      }
    } else {
      EXPECT_FALSE(scene.contains("mill") || scene.contains("outlets")) << "geometry expected";
    }
  }
}

}  // namespace
}  // namespace millsim
