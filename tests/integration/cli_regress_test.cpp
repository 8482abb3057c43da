// `millsim regress` as a nightly job would run it, with the real binary, worker children and a
// SQLite file: a baseline is written only on request and a rerun passes against it; a scene
// that drifted fails with a message naming check, quantity, baseline, measured and tolerance;
// a run stopped by the stability guard is a failure; the JUnit file parses with the right
// counts; a bad suite exits 2 listing every problem and stores nothing; the history shows a
// quantity across runs; a check with repeats runs one seed each, keeps their spread in the
// baseline and judges the mean in standard errors.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "queue/store.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

const std::string kCases = MILLSIM_SOURCE_DIR "/cases";

json impact_check(const std::string& name, double restitution) {
  return {{"name", name},
          {"scene", kCases + "/impact_two_spheres.json"},
          {"set", {{"output.h5", false}, {"materials.0.restitution", restitution}}},
          {"quantities",
           {{{"derived", "kinetic_energy_ratio"},
             {"tolerance", {{"relative", 0.01}}},
             {"reason", "e squared"}},
            {{"pointer", "/energy/final/kinetic_j"},
             {"tolerance", "exact"},
             {"reason", "bit-identical rerun"}}}}};
}

json suite(const json& checks) {
  return {{"name", "nightly"}, {"baseline", "nightly.baseline.json"}, {"checks", checks}};
}

int regressions_stored(const std::filesystem::path& db) {
  if (!std::filesystem::exists(db)) return 0;
  Store store(db);
  return int(store.regressions(1000, 0).size());
}

// Counts of a JUnit file, read by Python's XML parser (an independent reader).
std::string junit_counts(const std::filesystem::path& file) {
  const std::string command =
      "python3 -c \"import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); "
      "s = r.find('testsuite'); print(s.get('tests'), s.get('failures'), "
      "len(s.findall('testcase')), len(s.findall('testcase/failure')))\" " +
      file.string();
  std::string out;
  if (FILE* p = popen(command.c_str(), "r")) {
    char buffer[256];
    while (fgets(buffer, sizeof buffer, p)) out += buffer;
    pclose(p);
  }
  return out;
}

TEST(CliRegress, BaselineThenPassThenDriftWithJunitAndHistory) {
  test::TempDir dir;
  const std::string common = " --db q.db --out runs --workers 2";
  test::write_file(dir.path() / "nightly.json",
                   suite(json::array({impact_check("impact", 0.5)})).dump(2));

  // No baseline yet: every quantity fails, and nothing writes one.
  test::CommandResult r = test::run_millsim("regress nightly.json" + common, dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.out.find("no_baseline"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "nightly.baseline.json"));

  r = test::run_millsim("regress nightly.json --update-baseline" + common, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("impact kinetic_energy_ratio: new,"), std::string::npos) << r.err;
  std::ifstream in(dir.path() / "nightly.baseline.json");
  const json baseline = json::parse(in);
  const double ratio = baseline["values"]["impact"]["kinetic_energy_ratio"].get<double>();
  EXPECT_NEAR(ratio, 0.25, 0.005);  // e² of the head-on impact
  EXPECT_FALSE(baseline["build"]["git_commit"].get<std::string>().empty());

  r = test::run_millsim("regress nightly.json --junit pass.xml" + common, dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("nightly: PASSED, 2 quantities in 1 checks, 0 failing, 0 skipped"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(junit_counts(dir.path() / "pass.xml"), "2 0 2 0\n");

  // The scene drifts: restitution 0.9 instead of 0.5, against the same baseline.
  test::write_file(dir.path() / "nightly.json",
                   suite(json::array({impact_check("impact", 0.9)})).dump(2));
  r = test::run_millsim("regress nightly.json --junit drift.xml" + common, dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  char expected[160];
  std::snprintf(expected, sizeof expected, "impact kinetic_energy_ratio: measured 0.8");
  EXPECT_NE(r.out.find(expected), std::string::npos) << r.out;
  std::snprintf(expected, sizeof expected, ", baseline %.9g, off by", ratio);
  EXPECT_NE(r.out.find(expected), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("tolerance rel 0.01"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("nightly: FAILED, 2 quantities in 1 checks, 2 failing"), std::string::npos)
      << r.out;
  EXPECT_EQ(junit_counts(dir.path() / "drift.xml"), "2 2 2 2\n");
  EXPECT_EQ(regressions_stored(dir.path() / "q.db"), 4);

  // The history of one quantity, oldest first.
  r = test::run_millsim("regress --history impact/kinetic_energy_ratio --db q.db --format json",
                        dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json history = json::parse(r.out);
  ASSERT_EQ(history.size(), 4u);
  EXPECT_EQ(history[0]["verdict"], "no_baseline");
  EXPECT_EQ(history[2]["verdict"], "pass");
  EXPECT_EQ(history[3]["verdict"], "drift");
  EXPECT_NEAR(history[3]["measured"].get<double>(), 0.81, 0.01);
  r = test::run_millsim("regress --history nothing --db q.db", dir.path());
  EXPECT_EQ(r.exit_code, 2);
}

TEST(CliRegress, AStoppedRunFailsAndKeepsTheBaseline) {
  test::TempDir dir;
  // A 100 µm sphere hits the wall at 2 km/s where the scene declares impacts of at most 10 m/s:
  // its contact lasts under two steps and the stability guard stops the run (exit 3).
  std::ifstream in(kCases + "/impact_two_spheres.json");
  json fast = json::parse(in);
  fast["sources"][0]["particles"] = json::parse(
      R"([{"position_m": [0, 0, -0.0009], "velocity_m_per_s": [0, 0, -2000], "diameter_m": 1e-4}])");
  fast["contact"] = {{"max_impact_speed_m_per_s", 10}};
  fast["time"] = {{"end_s", 1e-5}, {"step_s", 1.1e-7}};
  json checks = {impact_check("impact", 0.5),
                 {{"name", "unstable"},
                  {"scene", fast},
                  {"quantities",
                   {{{"derived", "particles_final"},
                     {"tolerance", {{"relative", 0.0}}},
                     {"reason", "any"}}}}}};
  test::write_file(dir.path() / "nightly.json", suite(checks).dump(2));
  test::write_file(dir.path() / "nightly.baseline.json", R"({"values": {}})");
  test::CommandResult r = test::run_millsim(
      "regress nightly.json --update-baseline --db q.db --out runs --workers 2", dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("unstable particles_final: run "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ended EXECUTOR_ERROR (exit 3)"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("the baseline was not updated: check unstable failed"), std::string::npos)
      << r.err;
  EXPECT_NE(r.out.find("run stopped at step"), std::string::npos) << r.out;
  std::ifstream baseline(dir.path() / "nightly.baseline.json");
  EXPECT_EQ(json::parse(baseline), json::parse(R"({"values": {}})"));
}

// The breakage-probability scene (P = 1/2 of 400 impacts, binomial sd 10) over three seeds.
json selection_check(double speed_m_per_s) {
  return {{"name", "selection"},
          {"scene", kCases + "/regression/breakage_probability.json"},
          {"set", {{"sources.0.velocity_m_per_s", {0, 0, -speed_m_per_s}}}},
          {"repeats", 3},
          {"quantities",
           {{{"derived", "breakage_events"},
             {"tolerance", {{"sigmas", 4}}},
             {"reason", "binomial: its spread over seeds"}},
            {{"pointer", "/breakage/impacts"},
             {"expect", 400},
             {"tolerance", "exact"},
             {"reason", "every sphere hits the floor once, in every run"}}}}};
}

TEST(CliRegress, RepeatsJudgeTheMeanAgainstTheSpreadOfTheSeeds) {
  test::TempDir dir;
  const std::string common = " --db q.db --out runs --workers 2";
  test::write_file(dir.path() / "nightly.json",
                   suite(json::array({selection_check(10.0)})).dump(2));
  test::CommandResult r =
      test::run_millsim("regress nightly.json --update-baseline" + common, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  std::ifstream in(dir.path() / "nightly.baseline.json");
  const json baseline = json::parse(in);
  ASSERT_TRUE(baseline.contains("spread")) << baseline.dump(2);
  const json& spread = baseline["spread"]["selection"]["breakage_events"];
  EXPECT_EQ(spread["n"], 3);
  // Three seeds, three different draws of Binomial(400, 1/2): a spread, and a mean within four
  // of its standard errors (10/√3) of 200.
  EXPECT_GT(spread["sd"].get<double>(), 0.0);
  EXPECT_NEAR(baseline["values"]["selection"]["breakage_events"].get<double>(), 200.0,
              4 * 10 / std::sqrt(3.0));

  // The same build and seeds: the same runs, so the same mean.
  r = test::run_millsim("regress nightly.json" + common, dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find(" sd "), std::string::npos) << r.out;

  // At 8 m/s the specific energy 32 J/kg selects P = 1 − 2^(−22/40) = 0.317: about 127 events.
  test::write_file(dir.path() / "nightly.json", suite(json::array({selection_check(8.0)})).dump(2));
  r = test::run_millsim("regress nightly.json" + common, dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("selection breakage_events: measured mean 1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("standard errors (sd "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("tolerance 4 sigma"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("nightly: FAILED, 2 quantities in 1 checks, 1 failing"), std::string::npos)
      << r.out;

  // The history keeps each night's mean with its spread.
  r = test::run_millsim("regress --history selection/breakage_events --db q.db --format json",
                        dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json history = json::parse(r.out);
  ASSERT_EQ(history.size(), 3u);
  EXPECT_EQ(history[1]["measured"], baseline["values"]["selection"]["breakage_events"]);
  EXPECT_EQ(history[1]["measured_sd"], spread["sd"]);
  EXPECT_EQ(history[2]["verdict"], "drift");
}

TEST(CliRegress, ABadSuiteListsEveryProblemAndStoresNothing) {
  test::TempDir dir;
  json bad = suite({impact_check("impact", 0.5), impact_check("impact", 7.0)});
  bad["checks"][0]["quantities"][0]["tolerance"] = "close";
  bad["checks"][1]["quantities"][1].erase("reason");
  test::write_file(dir.path() / "nightly.json", bad.dump(2));
  const test::CommandResult r =
      test::run_millsim("regress nightly.json --update-baseline --db q.db", dir.path());
  EXPECT_EQ(r.exit_code, 2);
  for (const char* problem :
       {"/checks/0/quantities/0/tolerance = \"close\"", "/checks/1/name = \"impact\"",
        "/checks/1/quantities/1/reason", "/checks/1 run 0 () /materials/0/restitution = 7"})
    EXPECT_NE(r.err.find(problem), std::string::npos) << problem << "\n" << r.err;
  EXPECT_EQ(regressions_stored(dir.path() / "q.db"), 0);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "nightly.baseline.json"));
  EXPECT_EQ(test::run_millsim("regress", dir.path()).exit_code, 2);
  EXPECT_EQ(test::run_millsim("regress nightly.json --format xml", dir.path()).exit_code, 2);
}

}  // namespace
}  // namespace millsim
