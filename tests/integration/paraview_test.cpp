// Results open in ParaView as they are: each shipped case, run briefly, is loaded from its
// run.xdmf by ParaView's default reader (pvpython under Xvfb, tests/paraview/read_xdmf.py), and
// every time step shows one vertex cell per particle with all the particle arrays. The counts
// are checked against the run's own summary (snapshots, particles at the start and at the end)
// and, frame by frame, against the snapshots in run.h5. Every file is visited forward and then
// backward, last frame to first, as a user stepping back does: the fed cases start with an
// empty snapshot, which the reader must open again.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
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
  bool fed = false;  // starts with no particles: its first snapshot is empty
};

// The particle count of every snapshot in run.h5, in step order (the group names are zero-padded
// step numbers): the length of each snapshot's diameter dataset.
std::vector<int> snapshot_particle_counts(const std::filesystem::path& h5_path) {
  std::vector<int> counts;
  const hid_t file = H5Fopen(h5_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) return counts;
  const hid_t group = H5Gopen2(file, "/snapshots", H5P_DEFAULT);
  hsize_t n = 0;
  H5Gget_num_objs(group, &n);
  std::vector<std::string> names;
  for (hsize_t k = 0; k < n; ++k) {
    char name[64];
    if (H5Gget_objname_by_idx(group, k, name, sizeof name) > 0) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  for (const std::string& name : names) {
    const hid_t set = H5Dopen2(group, (name + "/diameter").c_str(), H5P_DEFAULT);
    const hid_t space = H5Dget_space(set);
    counts.push_back(int(H5Sget_simple_extent_npoints(space)));
    H5Sclose(space);
    H5Dclose(set);
  }
  H5Gclose(group);
  H5Fclose(file);
  return counts;
}

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
  for (const Case& c :
       {Case{"impact_two_spheres.json", 1e-5}, Case{"settling_column.json", 0.02},
        Case{"settling_in_air.json", 0.05}, Case{"fluidized_bed.json", 0.01},
        Case{"attrition_target.json", 6e-4, true}, Case{"jet_mill_two_nozzle.json", 2e-4},
        Case{"spiral_jet_mill.json", 3e-4, true}}) {
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
    // The frames are visited forward and then backward; both visits must show the same.
    auto open_in_paraview = [&](const std::string& file) {
      // In a subshell of its own, so ParaView's stderr goes to pv.err, not into the JSON.
      const auto [status, out] = test::run_shell("(cd " + dir.path().string() +
                                                 " && xvfb-run -a pvpython " MILLSIM_SOURCE_DIR
                                                 "/tests/paraview/read_xdmf.py out/" +
                                                 file + " 2>pv.err)")
                                     .status_and_output();
      std::vector<json> blocks;
      if (status != 0 || out.find('{') == std::string::npos) {
        ADD_FAILURE() << "pvpython on " << file << " exited with " << status << ": " << out
                      << test::read_file(dir.path() / "pv.err");
        return blocks;
      }
      const json shown = json::parse(out.substr(out.find('{')));
      EXPECT_EQ(shown["reader"], "Xdmf3ReaderS");
      const json& forward = shown["steps"];
      const json& backward = shown["backward"];
      EXPECT_EQ(backward.size(), forward.size()) << file;
      for (std::size_t k = 0; k < forward.size() && k < backward.size(); ++k) {
        const json& again = backward[backward.size() - 1 - k];
        EXPECT_EQ(again["time"], forward[k]["time"]) << file;
        EXPECT_EQ(again["blocks"], forward[k]["blocks"])
            << file << ", frame " << k << " stepped back";
      }
      for (const json& step : forward) {
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
    if (c.fed) {
      EXPECT_EQ(steps.front()["points"], 0) << "a fed case starts empty";
    }
    const std::vector<int> counts = snapshot_particle_counts(dir.path() / "out/run.h5");
    ASSERT_EQ(counts.size(), steps.size());
    for (std::size_t k = 0; k < steps.size(); ++k)
      EXPECT_EQ(steps[k]["points"], counts[k]) << "frame " << k;
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
