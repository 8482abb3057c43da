// `millsim study --local` as a real process with real `millsim run` children and a real SQLite
// file: a study runs to its results table; a child killed with SIGKILL is run again and the
// study still completes every run exactly once; the wall-time limit stops a run; a bad study is
// refused with nothing queued.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <map>

#include <chrono>
#include <fstream>
#include <thread>

#include "queue/store.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using test::children_of;

using nlohmann::json;
using test::run_millsim;
using test::write_file;

// A study over the settling column shortened to `end_s`, varying the restitution.
json settling_study(double end_s, std::vector<double> restitutions) {
  return {{"name", "settle"},
          {"scene", MILLSIM_SOURCE_DIR "/cases/settling_column.json"},
          {"set", {{"time.end_s", end_s}, {"output.h5", false}}},
          {"parameters", {{{"path", "materials.0.restitution"}, {"values", restitutions}}}},
          {"reference", {{"materials.0.restitution", restitutions.back()}}}};
}

TEST(CliStudy, LocalStudyRunsToItsResultsTable) {
  test::TempDir dir;
  write_file(dir.path() / "study.json", settling_study(0.002, {0.3, 0.5, 0.7}).dump());
  const test::CommandResult r = run_millsim(
      "study study.json --local --db q.db --out runs --workers 2 --format json", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const json table = json::parse(r.out);
  ASSERT_EQ(table["runs"].size(), 3u);
  EXPECT_EQ(table["error_metric"], "/energy/final/kinetic_j");  // no outlet PSD in this scene
  for (const json& row : table["runs"]) {
    EXPECT_EQ(row["state"], "COMPLETE");
    EXPECT_EQ(row["attempts"], 1);
    EXPECT_GT(row["wall_time_s"].get<double>(), 0.0);
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "runs" / table["study"].get<std::string>() /
                                        row["run"].get<std::string>() / "result.json"));
  }
  EXPECT_EQ(table["runs"][2]["error"].get<double>(), 0.0);  // the reference itself
  // Off a terminal, a line each time a run starts or ends: the last says all three are done.
  EXPECT_GE(std::count(r.err.begin(), r.err.end(), '\n'), 4) << r.err;
  EXPECT_NE(r.err.find("[3/3] running 0, complete 3, failed 0\n"), std::string::npos) << r.err;
  EXPECT_GE(table["runs"][0]["error"].get<double>(), 0.0);
  const std::filesystem::path study_dir = dir.path() / "runs" / table["study"].get<std::string>();
  EXPECT_TRUE(std::filesystem::exists(study_dir / "results.csv"));
  EXPECT_TRUE(std::filesystem::exists(study_dir / "error_vs_time.svg"));
}

TEST(CliStudy, KilledChildIsRunAgainAndEveryRunCompletesOnce) {
  test::TempDir dir;
  write_file(dir.path() / "study.json", settling_study(0.12, {0.4, 0.6}).dump());
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    test::die_with_parent();
    if (chdir(dir.path().c_str()) != 0) _exit(99);
    freopen("/dev/null", "w", stdout);
    execl(MILLSIM_BINARY, "millsim", "study", "study.json", "--local", "--db", "q.db", "--out",
          "runs", "--workers", "2", static_cast<char*>(nullptr));
    _exit(98);
  }
  // Wait for a `millsim run` child to be running a while, then kill it hard.
  pid_t victim = -1;
  for (int k = 0; k < 200 && victim < 0; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
    const std::vector<pid_t> kids = children_of(pid);
    if (!kids.empty() && k > 20) victim = kids.front();
  }
  ASSERT_GT(victim, 0) << "no child run appeared";
  kill(victim, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  Store store(dir.path() / "q.db");
  const std::vector<RunRecord> runs = store.runs("s000001");
  ASSERT_EQ(runs.size(), 2u);
  int retried = 0;
  for (const RunRecord& r : runs) {
    EXPECT_EQ(r.state, RunState::Complete);
    retried += r.attempts == 2;
    EXPECT_LE(r.attempts, 2);
  }
  EXPECT_EQ(retried, 1);
}

TEST(CliStudy, WallTimeLimitStopsARunAndBadStudiesQueueNothing) {
  test::TempDir dir;
  json study = settling_study(0.3, {0.5});
  study["limits"] = {{"wall_time_s", 0.5}};
  write_file(dir.path() / "slow.json", study.dump());
  test::CommandResult r = run_millsim("study slow.json --local --db q.db --out runs", dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  {
    Store store(dir.path() / "q.db");
    const RunRecord run = *store.run("s000001-r0");
    EXPECT_EQ(run.state, RunState::ExecutorError);
    EXPECT_NE(run.error.find("wall-time limit"), std::string::npos);
  }
#ifndef MILLSIM_SANITIZED  // under ASan the executor sets no address-space limit
  // A memory limit too small for the program: the run fails, with the reason kept.
  study = settling_study(0.01, {0.5});
  study["limits"] = {{"memory_mb", 16}};
  write_file(dir.path() / "tiny.json", study.dump());
  r = run_millsim("study tiny.json --local --db q.db --out runs", dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  {
    Store store(dir.path() / "q.db");
    const RunRecord run = *store.run("s000002-r0");
    EXPECT_NE(run.state, RunState::Complete);
    EXPECT_FALSE(run.error.empty());
  }
#endif
  study = settling_study(0.01, {0.5, 2.0});  // restitution 2 is out of range
  write_file(dir.path() / "bad.json", study.dump());
  r = run_millsim("study bad.json --local --db q.db --out runs", dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("run 1 (materials.0.restitution = 2.0) /materials/0/restitution"),
            std::string::npos)
      << r.err;
  Store store(dir.path() / "q.db");
  // Only the studies above; the bad one queued nothing.
#ifndef MILLSIM_SANITIZED
  EXPECT_EQ(store.studies(10, 0).size(), 2u);
#else
  EXPECT_EQ(store.studies(10, 0).size(), 1u);
#endif
}

// The runs of a study whose gas is the same spin it up once (issue 32, item 4): with two runs at
// a time, one spins the mill's gas up and the other waits and reads it from the study's cache;
// the shared spin-up is bit for bit the one a run makes alone (tests/engine/gas_spin_up_test).
TEST(CliStudy, RunsWithTheSameGasShareOneSpinUp) {
  test::TempDir dir;
  const json study = {
      {"name", "shared_gas"},
      {"scene", MILLSIM_SOURCE_DIR "/cases/spiral_jet_mill.json"},
      {"set", {{"time.end_s", 1e-5}, {"gas.spin_up_s", 5e-4}, {"output.h5", false}}},
      {"parameters", {{{"path", "dust.threshold_diameter_m"}, {"values", {8e-5, 5e-5, 3e-5}}}}}};
  write_file(dir.path() / "study.json", study.dump());
  const test::CommandResult r = run_millsim(
      "study study.json --local --db q.db --out runs --workers 2 --format json", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const json table = json::parse(r.out);
  ASSERT_EQ(table["runs"].size(), 3u);
  const std::filesystem::path study_dir = dir.path() / "runs" / table["study"].get<std::string>();
  std::map<std::string, int> sources;
  for (const json& row : table["runs"]) {
    ASSERT_EQ(row["state"], "COMPLETE");
    const json result =
        json::parse(test::read_file(study_dir / row["run"].get<std::string>() / "result.json"));
    sources[result["spin_up"]["source"].get<std::string>()] += 1;
    // The table's run time is what the parameters cost: the engine's wall time, less the
    // spin-up (computed once, or waited for and read).
    EXPECT_EQ(row["spin_up_source"], result["spin_up"]["source"]);
    EXPECT_EQ(row["spin_up_s"], result["spin_up"]["seconds"]);
    EXPECT_DOUBLE_EQ(
        row["run_time_s"].get<double>(),
        result["wall_time_s"].get<double>() - result["spin_up"]["seconds"].get<double>());
    EXPECT_EQ(result["gas"]["spin_up_steps"],
              json::parse(test::read_file(study_dir / table["runs"][0]["run"].get<std::string>() /
                                          "result.json"))["gas"]["spin_up_steps"]);
  }
  EXPECT_EQ(sources["computed"], 1) << "one run spins the gas up";
  EXPECT_EQ(sources["cache"], 2) << "the others read it";
  EXPECT_TRUE(std::filesystem::is_directory(study_dir / "spin-up-cache"));
}

}  // namespace
}  // namespace millsim
