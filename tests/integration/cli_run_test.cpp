// `millsim run` as a real process: exit codes (0 ok, 2 bad input, 3 stopped by the stability
// guard), the summary on stdout, the files it writes, and that bad input writes nothing.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "parallel/thread_team.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using test::CommandResult;
using test::run_millsim;
using test::write_file;

// A disk that fills up during a run (here the file-size limit, with SIGXFSZ ignored so writes
// fail as on a full disk) is an I/O error: exit 4 with a message naming the file, the partial
// file left aside, and the last good run.h5 of an earlier run intact. Before, HDF5's cleanup at
// exit crashed the process (SIGSEGV) after the message, and the service retried it as a crash.
TEST(CliRun, AFullDiskIsExitFourAndKeepsTheLastGoodFiles) {
  test::TempDir dir;
  const std::string scene = MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json";
  ASSERT_EQ(run_millsim("run '" + scene + "' --out full --quiet", dir.path()).exit_code, 0);
  const std::string good = test::read_file(dir.path() / "full" / "run.h5");
  ASSERT_GT(good.size(), 40u * 1024u);
  const CommandResult r =
      test::run_shell("cd '" + dir.path().string() +
                      "' && trap '' XFSZ && ulimit -f 40 && '" MILLSIM_BINARY "' run '" + scene +
                      "' --out full --quiet 2>&1");
  EXPECT_EQ(r.exit_code, 4) << r.out;
  EXPECT_NE(r.out.find("run.h5"), std::string::npos) << r.out;
  EXPECT_EQ(test::read_file(dir.path() / "full" / "run.h5"), good);
}

TEST(CliRun, ImpactCaseRunsAndWritesResults) {
  test::TempDir dir;
  const CommandResult r = run_millsim(
      "run '" MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json' --out out", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["status"], "ok");
  EXPECT_EQ(summary["particles"]["final"], 2);
  // The case has e = 0.5: kinetic energy after the rebound is e² of the initial.
  const double ratio = summary["energy"]["final"]["kinetic_j"].get<double>() /
                       summary["energy"]["initial"]["kinetic_j"].get<double>();
  EXPECT_NEAR(ratio, 0.25, 0.02 * 0.25);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out/run.h5"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out/run.xdmf"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out/result.json"));
}

TEST(CliRun, BadSceneExitsTwoNamesTheKeyAndWritesNothing) {
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["materials"][0]["poisson_ratio"] = 0.7;
  scene["time"]["ned_s"] = 1;
  write_file(dir.path() / "bad.json", scene.dump());
  const CommandResult r = run_millsim("run bad.json --out out", dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/materials/0/poisson_ratio = 0.7: expected a number in (-1, 0.5)"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("/time/ned_s"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "out"));
}

TEST(CliRun, HugeStepCountsAndOutputIntervalsDoNotOverflow) {
  // 1e6 s at 1e-13 s is 1e19 steps: an input error naming the key, not a one-step run.
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  const nlohmann::json base = nlohmann::json::parse(in);
  nlohmann::json long_run = base;
  long_run["time"] = {{"end_s", 1e6}, {"step_s", 1e-13}};
  write_file(dir.path() / "long.json", long_run.dump());
  const CommandResult r = run_millsim("run long.json --out long", dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.err.find("/time/end_s"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("at most 2e9 steps"), std::string::npos) << r.err;
  // A snapshot interval longer than the run writes the first and last state only.
  nlohmann::json sparse = base;
  sparse["output"]["snapshot_interval_s"] = 1e300;
  write_file(dir.path() / "sparse.json", sparse.dump());
  const CommandResult s = run_millsim("run sparse.json --out sparse", dir.path());
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_EQ(nlohmann::json::parse(s.out)["outputs"]["snapshots"], 2);
}

TEST(CliRun, NumbersBeyondADoubleAndOverlongPathsAreBadInput) {
  // Exit 2 naming what is wrong, not 1 (a bug) or 4 (the environment).
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  std::string text = scene.dump();
  text.replace(text.find("\"end_s\":") + 8, 0, "1e999, \"_\":");
  write_file(dir.path() / "huge.json", text);
  const CommandResult huge = run_millsim("run huge.json --out a", dir.path());
  EXPECT_EQ(huge.exit_code, 2) << huge.err;
  EXPECT_NE(huge.err.find("not valid JSON"), std::string::npos) << huge.err;
  scene["sources"] = {{{"type", "file"},
                       {"material", scene["materials"][0]["name"]},
                       {"path", std::string(5000, 'x')}}};
  write_file(dir.path() / "long_path.json", scene.dump());
  const CommandResult path = run_millsim("run long_path.json --out b", dir.path());
  EXPECT_EQ(path.exit_code, 2) << path.err;
  EXPECT_NE(path.err.find("/sources/0/path"), std::string::npos) << path.err;
  EXPECT_LT(path.err.size(), 2000u) << "the 5000-character path is not echoed whole";
  // A particle file whose header count is not a number.
  write_file(dir.path() / "p.txt", "# N: abc\n1 5e-4 5e-4 5e-4 1e-4 0 0 0\n");
  scene["sources"] = {
      {{"type", "file"}, {"material", scene["materials"][0]["name"]}, {"path", "p.txt"}}};
  write_file(dir.path() / "header.json", scene.dump());
  const CommandResult header = run_millsim("run header.json --out c", dir.path());
  EXPECT_EQ(header.exit_code, 2) << header.err;
  EXPECT_NE(header.err.find("header 'N'"), std::string::npos) << header.err;
}

// Nesting past the documented limit (64) is bad input, found before anything walks the document:
// 10^5 levels crashed the loader's and the error printer's recursion before.
TEST(CliRun, DeeplyNestedJsonIsBadInputNotACrash) {
  test::TempDir dir;
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  write_file(dir.path() / "deep.json", "{\"name\": " + deep + "}");
  const CommandResult run = run_millsim("run deep.json --out a", dir.path());
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("deeper than 64 levels at byte 72"), std::string::npos) << run.err;
  write_file(dir.path() / "study.json", "{\"scene\": {\"materials\": " + deep + "}}");
  const CommandResult study = run_millsim("study study.json --local --db q.db", dir.path());
  EXPECT_EQ(study.exit_code, 2) << study.err;
  EXPECT_NE(study.err.find("deeper than 64"), std::string::npos) << study.err;
  // 64 levels are read (and then judged by the scene format as usual).
  write_file(dir.path() / "edge.json",
             "{\"name\": " + std::string(63, '[') + std::string(63, ']') + "}");
  const CommandResult edge = run_millsim("run edge.json --out b", dir.path());
  EXPECT_EQ(edge.exit_code, 2);
  EXPECT_EQ(edge.err.find("deeper than"), std::string::npos) << edge.err;
}

// A particle file with bytes that are not UTF-8: its error quotes the line as valid text (U+FFFD
// for each bad byte), so it can go into JSON (the server's test sends it over HTTP).
TEST(CliRun, NonUtf8BytesInAParticleFileAreReportedAsText) {
  test::TempDir dir;
  write_file(dir.path() / "p.txt", "# N: 1\n1 5e-4 5e-4 \xff\xfe 1e-4 0 0 0\n");
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["sources"] = {
      {{"type", "file"}, {"material", scene["materials"][0]["name"]}, {"path", "p.txt"}}};
  write_file(dir.path() / "scene.json", scene.dump());
  const CommandResult run = run_millsim("run scene.json --out a", dir.path());
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("\xEF\xBF\xBD"), std::string::npos) << run.err;  // U+FFFD
  EXPECT_EQ(run.err.find("\xff"), std::string::npos);
}

// Thousands of repeated names: one problem per repeated entry (not per pair: 3,000 gave 4.5 M
// before), and a report lists the first 100 and counts the rest.
TEST(CliRun, RepeatedNamesAreReportedOncePerEntryAndReportsAreCapped) {
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  const nlohmann::json material = scene["materials"][0];
  scene["materials"] = nlohmann::json::array();
  for (int k = 0; k < 3000; ++k) scene["materials"].push_back(material);
  write_file(dir.path() / "repeated.json", scene.dump());
  const CommandResult r = run_millsim("run repeated.json --out a", dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("2999 errors"), std::string::npos) << r.err.substr(0, 300);
  EXPECT_NE(r.err.find("... and 2899 more"), std::string::npos);
  EXPECT_LT(r.err.size(), 20000u);
}

TEST(CliRun, MalformedJsonAndMissingFileAreBadInput) {
  test::TempDir dir;
  write_file(dir.path() / "broken.json", "{\"name\": ");
  EXPECT_EQ(run_millsim("run broken.json", dir.path()).exit_code, 2);
  const CommandResult missing = run_millsim("run nowhere.json", dir.path());
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("no such scene file"), std::string::npos);
  EXPECT_EQ(run_millsim("run a.json --frobnicate", dir.path()).exit_code, 2);
}

TEST(CliRun, BlowUpStopsWithExitThreeAndAMessage) {
  // The scene declares impacts of at most 10 m/s and takes the largest step that allows, but a
  // 100 µm particle actually hits the wall at 2 km/s: its Hertz contact lasts under two steps,
  // so the stability guard must stop the run and say why.
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["sources"][0]["particles"] = nlohmann::json::parse(
      R"([{"position_m": [0, 0, -0.0009], "velocity_m_per_s": [0, 0, -2000], "diameter_m": 1e-4}])");
  scene["contact"] = {{"max_impact_speed_m_per_s", 10}};
  scene["time"] = {{"end_s", 1e-5}, {"step_s", 1.1e-7}};
  write_file(dir.path() / "fast.json", scene.dump());
  const CommandResult r = run_millsim("run fast.json --out out", dir.path());
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("run stopped at step"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("max_impact_speed_m_per_s"), std::string::npos)
      << "names the fix: " << r.err;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["status"], "failed");
  EXPECT_EQ(summary["failure"]["particle_id"], 1);
  std::ifstream result(dir.path() / "out/result.json");
  EXPECT_EQ(nlohmann::json::parse(result)["status"], "failed");
}

// SIGTERM (a batch system's stop) and SIGINT (Ctrl-C) end a run after the step under way with
// every file complete: exit 128 + the signal, result.json "interrupted" with the step it
// reached, run.h5 renamed into place and readable by HDF5 with its snapshots and time series.
TEST(CliRun, SignalsStopARunWithEveryFileComplete) {
  for (const int sig : {SIGTERM, SIGINT}) {
    test::TempDir dir;
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      test::die_with_parent();
      if (chdir(dir.path().c_str()) != 0) _exit(99);
      freopen("/dev/null", "w", stdout);
      freopen("run.err", "w", stderr);
      execl(MILLSIM_BINARY, "millsim", "run", MILLSIM_SOURCE_DIR "/cases/settling_column.json",
            "--out", "out", "--quiet", static_cast<char*>(nullptr));
      _exit(98);
    }
    // Running: its run.h5.partial exists; then let it step a little.
    for (int k = 0; k < 200 && !std::filesystem::exists(dir.path() / "out/run.h5.partial"); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(pid, sig);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status)) << "killed instead of stopping";
    EXPECT_EQ(WEXITSTATUS(status), 128 + sig);
    std::ifstream in(dir.path() / "out/result.json");
    const nlohmann::json result = nlohmann::json::parse(in);
    EXPECT_EQ(result["status"], "interrupted");
    EXPECT_EQ(result["interrupted"]["signal"], sig == SIGTERM ? "SIGTERM" : "SIGINT");
    EXPECT_GT(result["steps"].get<long>(), 0);
    EXPECT_LT(result["steps"].get<long>(), result["steps_planned"].get<long>());
    EXPECT_EQ(result["interrupted"]["step"], result["steps"]);
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "out/run.h5.partial"));
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "out/run.xdmf"));
    const hid_t file = H5Fopen((dir.path() / "out/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(file, 0) << "run.h5 is not a valid HDF5 file";
    EXPECT_GT(H5Lexists(file, "timeseries", H5P_DEFAULT), 0);
    EXPECT_GT(H5Lexists(file, "snapshots", H5P_DEFAULT), 0);
    H5Fclose(file);
  }
}

// A hold-up fill is written to the log when it happens, with what it moved: the same numbers as
// result.json's holdup_fills, to the 0.1 µg the line gives.
TEST(CliRun, AHoldUpFillIsLoggedWhenItHappens) {
  test::TempDir dir;
  nlohmann::json scene = test::rising_stream_mill();
  scene["time"]["end_s"] = 0.006;
  write_file(dir.path() / "stream.json", scene.dump());
  const CommandResult r = run_millsim("run stream.json --out out --quiet", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json result = nlohmann::json::parse(r.out);
  ASSERT_TRUE(result.contains("holdup_fills"));
  const nlohmann::json& fill = result["holdup_fills"][0];
  ASSERT_EQ(fill["status"], "filled");
  const std::string log = test::read_file(dir.path() / "out/log.txt");
  const std::size_t at = log.find("fill 1 at 3.6 ms: particles ");
  ASSERT_NE(at, std::string::npos) << log;
  double before = 0.0, after = 0.0, projected = 0.0;
  ASSERT_EQ(
      std::sscanf(log.c_str() + at, "fill 1 at 3.6 ms: particles %lf -> %lf ug (projected %lf)",
                  &before, &after, &projected),
      3)
      << log.substr(at, 200);
  EXPECT_NEAR(before, fill["particles"]["before_kg"].get<double>() * 1e9, 0.051);
  EXPECT_NEAR(after, fill["particles"]["after_kg"].get<double>() * 1e9, 0.051);
  EXPECT_NEAR(projected, fill["particles"]["projected_kg"].get<double>() * 1e9, 0.051);
  EXPECT_LT(log.find("fill 1"), log.rfind('\n', log.size() - 2)) << "before the run's last line";
}

// In a batch log (stderr not a terminal) a run writes LAMMPS-style thermo lines: a header, a line
// per interval and one at the end, to stderr and to DIR/log.txt; once only when stderr already is
// DIR/log.txt (as under the service's executors).
TEST(CliRun, BatchLogsGetThermoLines) {
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/settling_column.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["time"]["end_s"] = 0.06;
  scene["output"]["h5"] = false;
  write_file(dir.path() / "column.json", scene.dump());
  const CommandResult r =
      run_millsim("run column.json --out out --quiet --log-interval 0.05", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json result = nlohmann::json::parse(r.out);
  std::istringstream lines(r.err);
  std::string line, header, last;
  int data_lines = 0;
  while (std::getline(lines, line)) {
    if (line.find("Step") != std::string::npos && line.find("KinEng_J") != std::string::npos)
      header = line;
    else if (!header.empty() && !line.empty())
      ++data_lines, last = line;
  }
  EXPECT_FALSE(header.empty()) << r.err;
  EXPECT_GE(data_lines, 2) << r.err;
  long long step = 0;
  std::size_t particles = 0;
  std::sscanf(last.c_str(), "%lld %*g %zu", &step, &particles);
  EXPECT_EQ(step, result["steps"].get<long long>()) << last;
  EXPECT_EQ(particles, result["particles"]["final"].get<std::size_t>());
  std::ifstream log(dir.path() / "out/log.txt");
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_EQ(text.str(), r.err.substr(r.err.find(header))) << "log.txt holds the same lines";

  // stderr is DIR/log.txt itself: every line once.
  std::filesystem::create_directories(dir.path() / "same");
  const int status = std::system(("cd " + (dir.path() / "same").string() +
                                  " && " MILLSIM_BINARY " run " MILLSIM_SOURCE_DIR
                                  "/cases/impact_two_spheres.json "
                                  "--out . --quiet >/dev/null 2>>log.txt")
                                     .c_str());
  EXPECT_EQ(status, 0);
  std::ifstream same(dir.path() / "same/log.txt");
  std::string content((std::istreambuf_iterator<char>(same)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content.find("KinEng_J"), content.rfind("KinEng_J")) << content;
  EXPECT_NE(content.find("KinEng_J"), std::string::npos) << content;
}

namespace {

// A string attribute of an HDF5 object ("" when absent), which must be stored as a
// variable-length UTF-8 string: h5py reads that as str (a fixed-length one as bytes, so that
// `attrs['units'] == 'm'` would be False).
std::string string_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return "";
  const hid_t attr = H5Aopen(object, name, H5P_DEFAULT);
  const hid_t type = H5Aget_type(attr);
  std::string value;
  const bool variable_utf8 = H5Tget_class(type) == H5T_STRING && H5Tis_variable_str(type) > 0 &&
                             H5Tget_cset(type) == H5T_CSET_UTF8;
  EXPECT_TRUE(variable_utf8) << name << " is not a variable-length UTF-8 string";
  if (variable_utf8) {
    char* text = nullptr;
    H5Aread(attr, type, &text);
    if (text) value = text;
    H5free_memory(text);
  }
  H5Tclose(type);
  H5Aclose(attr);
  return value;
}

// An attribute that must be an unsigned 64-bit integer (0 when it is not).
std::uint64_t uint64_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return 0;
  const hid_t attr = H5Aopen(object, name, H5P_DEFAULT);
  const hid_t type = H5Aget_type(attr);
  std::uint64_t value = 0;
  const bool uint64 = H5Tget_class(type) == H5T_INTEGER && H5Tget_sign(type) == H5T_SGN_NONE &&
                      H5Tget_size(type) == 8;
  EXPECT_TRUE(uint64) << name << " is not an unsigned 64-bit integer";
  if (uint64) H5Aread(attr, H5T_NATIVE_UINT64, &value);
  H5Tclose(type);
  H5Aclose(attr);
  return value;
}

// A 1-D dataset's type class (H5T_INTEGER, H5T_FLOAT) and its values, read as doubles.
std::pair<H5T_class_t, std::vector<double>> column(hid_t file, const std::string& name) {
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  if (set < 0) return {H5T_NO_CLASS, {}};
  const hid_t type = H5Dget_type(set), space = H5Dget_space(set);
  std::vector<double> values(
      std::size_t(std::max<hssize_t>(0, H5Sget_simple_extent_npoints(space))));
  H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  const H5T_class_t type_class = H5Tget_class(type);
  H5Sclose(space);
  H5Tclose(type);
  H5Dclose(set);
  return {type_class, values};
}

}  // namespace

// run.h5 describes itself: every dataset has its units, /meta holds the scene as given, its seed,
// the version and the build; the scene is copied beside the results.
TEST(CliRun, RunFilesDescribeThemselves) {
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/attrition_target.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["time"]["end_s"] = 4e-4;
  const std::string text = scene.dump(1);
  write_file(dir.path() / "attrition.json", text);
  const CommandResult r = run_millsim("run attrition.json --out out --quiet", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream copy(dir.path() / "out/scene.json");
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(copy)), std::istreambuf_iterator<char>()),
            text);

  const hid_t file = H5Fopen((dir.path() / "out/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  struct Visit {
    int datasets = 0;
    std::vector<std::string> without_units;
    std::map<std::string, std::string> units;
  } visit;
  H5Ovisit2(
      file, H5_INDEX_NAME, H5_ITER_NATIVE,
      [](hid_t root, const char* name, const H5O_info_t* info, void* data) -> herr_t {
        if (info->type != H5O_TYPE_DATASET) return 0;
        auto& v = *static_cast<Visit*>(data);
        ++v.datasets;
        const hid_t set = H5Dopen2(root, name, H5P_DEFAULT);
        const std::string units = string_attribute(set, "units");
        H5Dclose(set);
        if (units.empty()) v.without_units.push_back(name);
        const std::string n = name;
        v.units[n.substr(n.rfind('/') + 1)] = units;
        return 0;
      },
      &visit, H5O_INFO_BASIC);
  EXPECT_GT(visit.datasets, 20);
  EXPECT_TRUE(visit.without_units.empty()) << visit.without_units.front();
  EXPECT_EQ(visit.units["position"], "m");
  EXPECT_EQ(visit.units["velocity"], "m/s");
  EXPECT_EQ(visit.units["angular_velocity"], "rad/s");
  EXPECT_EQ(visit.units["remaining_capacity"], "J/kg");
  EXPECT_EQ(visit.units["kinetic_j"], "J");
  EXPECT_EQ(visit.units["time_s"], "s");
  EXPECT_EQ(visit.units["dust_mass_kg"], "kg");
  EXPECT_EQ(visit.units["generation"], "1");

  const hid_t meta = H5Gopen2(file, "/meta", H5P_DEFAULT);
  ASSERT_GE(meta, 0);
  EXPECT_EQ(string_attribute(meta, "scene_json"), text);
  EXPECT_EQ(uint64_attribute(meta, "seed"), scene["seed"].get<std::uint64_t>());
  EXPECT_EQ(string_attribute(meta, "millsim_version"),
            nlohmann::json::parse(r.out)["millsim_version"]);
  EXPECT_FALSE(string_attribute(meta, "git_commit").empty());
  EXPECT_FALSE(string_attribute(meta, "compiler").empty());
  std::string names;  // the material array's name table, from the scene's own list
  for (std::size_t m = 0; m < scene["materials"].size(); ++m)
    names += std::to_string(m) + " " + scene["materials"][m]["name"].get<std::string>() + "\n";
  EXPECT_EQ(string_attribute(meta, "materials"), names);
  H5Gclose(meta);

  // Counts are integers, equal to the run's own summary; the dust table's count is an equivalent
  // number (its mass over a sphere's at the class size), a fraction, and stays a float.
  const nlohmann::json result = nlohmann::json::parse(r.out);
  for (const char* name :
       {"/timeseries/particles", "/timeseries/contact_pairs", "/timeseries/wall_contacts",
        "/timeseries/breakage_events", "/psd/outlet_count"})
    EXPECT_EQ(column(file, name).first, H5T_INTEGER) << name;
  EXPECT_EQ(column(file, "/timeseries/particles").second.back(),
            result["particles"]["final"].get<double>());
  EXPECT_EQ(column(file, "/timeseries/breakage_events").second.back(),
            result["breakage"]["events"].get<double>());
  double outlet_count = 0.0;
  for (double n : column(file, "/psd/outlet_count").second) outlet_count += n;
  EXPECT_EQ(outlet_count, result["outlet_particles"]["count"].get<double>());
  EXPECT_EQ(column(file, "/psd/dust_count").first, H5T_FLOAT);
  EXPECT_EQ(column(file, "/timeseries/time_s").first, H5T_FLOAT);
  H5Fclose(file);
}

// --threads: a count that is not a whole number ≥ 1 is exit 2 with the reason; more than the
// affinity mask allows is exit 2 with --strict-threads; and the result does not depend on it:
// run.h5 is the same file, result.json the same apart from its timings and the count itself.
TEST(CliRun, ThreadCountsAreCheckedAndDoNotChangeTheResult) {
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/attrition_target.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["time"]["end_s"] = 2e-4;  // breakage starts at about 1e-4 s
  write_file(dir.path() / "scene.json", scene.dump());
  for (const char* bad : {"0", "-1", "2x", "''", "99999"}) {
    const CommandResult r =
        run_millsim(std::string("run scene.json --out bad --quiet --threads ") + bad, dir.path());
    EXPECT_EQ(r.exit_code, 2) << bad;
    EXPECT_NE(r.err.find("--threads"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("whole number of threads"), std::string::npos) << r.err;
  }
  const std::string too_many = std::to_string(usable_core_count() + 1);
  const CommandResult strict = run_millsim(
      "run scene.json --out bad --quiet --strict-threads --threads " + too_many, dir.path());
  EXPECT_EQ(strict.exit_code, 2);
  EXPECT_NE(strict.err.find("affinity mask"), std::string::npos) << strict.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "bad"));

  std::map<std::string, nlohmann::json> summary;
  for (const std::string& threads : std::vector<std::string>{"1", "2", too_many}) {
    const CommandResult r = run_millsim(
        "run scene.json --quiet --out t" + threads + " --threads " + threads, dir.path());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    summary[threads] = nlohmann::json::parse(r.out);
    EXPECT_EQ(summary[threads]["threads"], std::stoi(threads));
    // (Compared as a bool: gtest would print both files on a mismatch.)
    EXPECT_TRUE(test::read_file(dir.path() / ("t" + threads) / "run.h5") ==
                test::read_file(dir.path() / "t1" / "run.h5"))
        << "run.h5 differs at " << threads << " threads";
  }
  EXPECT_NE(summary[too_many].dump().size(), 0u);
  EXPECT_GT(summary["1"]["breakage"]["events"].get<int>(), 0) << "the case must break something";
  for (auto& [threads, s] : summary)
    for (const char* timing :
         {"wall_time_s", "threads", "particle_steps_per_second", "phase_seconds"})
      s.erase(timing);
  EXPECT_EQ(summary["2"], summary["1"]);
  EXPECT_EQ(summary[too_many], summary["1"]);
}

}  // namespace
}  // namespace millsim
