// The Slurm executor against real Slurm daemons (deploy/slurm/slurm-local.sh starts a one-node
// cluster; CI does). Skipped, saying so, when no cluster answers. Runs become batch jobs named
// millsim-<run>; exit codes map to states as for local children; cancel reaches the jobs.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "executors/slurm_executor.h"
#include "queue/store.h"
#include "support/process.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

// State of the newest job named millsim-<run_id> (run ids repeat across databases).
std::string job_state(const std::string& run_id) {
  const std::string command = "squeue -h -t all -n millsim-" + run_id + " -o '%i %T' 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  long newest = -1;
  std::string state;
  char line[256];
  while (std::fgets(line, sizeof line, pipe)) {
    long id = 0;
    char text[64] = {};
    if (std::sscanf(line, "%ld %63s", &id, text) == 2 && id > newest) newest = id, state = text;
  }
  pclose(pipe);
  return state;
}

json settling(double end_s, json extra_set = json::object()) {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/settling_column.json");
  json set = {{"time.end_s", end_s}, {"output.h5", false}};
  set.update(extra_set);
  return {{"name", "slurm"}, {"scene", json::parse(in)}, {"set", set}};
}

TEST(Slurm, StudyRunsAsBatchJobsWithExitCodesMapped) {
  if (!SlurmExecutor::available())
    GTEST_SKIP() << "no Slurm cluster answers (start deploy/slurm/slurm-local.sh and export "
                    "SLURM_CONF)";
  test::TempDir dir;
  // Run 0 completes; run 1's fixed step is above the Rayleigh bound: the engine rejects it
  // (exit 2) inside its job, an EXECUTOR_ERROR that is not retried.
  json study = settling(0.005);
  study["parameters"] = {{{"path", "time.step_s"}, {"values", {2e-6, 1e-3}}}};
  test::write_file(dir.path() / "study.json", study.dump());
  const test::CommandResult r = test::run_millsim(
      "study study.json --local --executor slurm --workers 2 --db q.db --out runs --format json",
      dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.err;  // one run failed
  Store store(dir.path() / "q.db");
  const std::vector<RunRecord> runs = store.runs("s000001");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].state, RunState::Complete);
  EXPECT_EQ(runs[1].state, RunState::ExecutorError);
  EXPECT_EQ(runs[1].attempts, 1);
  EXPECT_EQ(runs[1].exit_code.value_or(-1), 2);
  EXPECT_NE(runs[1].error.find("time/step_s"), std::string::npos) << runs[1].error;
  // They ran as Slurm jobs.
  EXPECT_EQ(job_state(runs[0].id), "COMPLETED");
  EXPECT_EQ(job_state(runs[1].id), "FAILED");
}

TEST(Slurm, CancelReachesTheJobs) {
  if (!SlurmExecutor::available()) GTEST_SKIP() << "no Slurm cluster answers";
  test::TempDir dir;
  json study = settling(0.3);
  study["parameters"] = {{{"path", "materials.0.restitution"}, {"values", {0.4, 0.6}}}};
  test::write_file(dir.path() / "study.json", study.dump());
  {
    // An empty first study, so this one is s000002: its job names differ from the other test's
    // (s000001), which may run at the same time (ctest -j).
    Study placeholder;
    placeholder.name = "placeholder";
    placeholder.spec = json::object();
    Store(dir.path() / "q.db").submit(placeholder, std::nullopt, dir.path(), 0.0);
  }
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    test::die_with_parent();
    if (chdir(dir.path().c_str()) != 0) _exit(99);
    freopen("/dev/null", "w", stdout);
    execl(MILLSIM_BINARY, "millsim", "study", "study.json", "--local", "--executor", "slurm",
          "--workers", "2", "--db", "q.db", "--out", "runs", static_cast<char*>(nullptr));
    _exit(98);
  }
  // Both jobs running, then cancel the study in the database (as the server's cancel does).
  for (int k = 0; k < 200; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (job_state("s000002-r0") == "RUNNING" && job_state("s000002-r1") == "RUNNING") break;
  }
  {
    Store store(dir.path() / "q.db");
    store.cancel_study("s000002", 0.0);
  }
  int status = 0;
  waitpid(pid, &status, 0);  // the runner stops the jobs at its next heartbeat (≤ 10 s)
  Store store(dir.path() / "q.db");
  const std::vector<RunRecord> runs = store.runs("s000002");
  ASSERT_EQ(runs.size(), 2u);
  for (const RunRecord& r : runs) {
    EXPECT_EQ(r.state, RunState::Canceled) << r.id;
    EXPECT_EQ(job_state(r.id), "CANCELLED") << r.id;
  }
}

// A study's `slurm` options reach sbatch: a study on the cluster's partition runs; one naming a
// partition that does not exist is refused by sbatch, a system error kept with sbatch's words.
TEST(Slurm, StudyOptionsReachSbatch) {
  if (!SlurmExecutor::available()) GTEST_SKIP() << "no Slurm cluster answers";
  test::TempDir dir;
  {
    // Two empty studies first, so these are s000003 and s000004 (job names unique across the
    // tests, which ctest may run at the same time).
    Study placeholder;
    placeholder.name = "placeholder";
    placeholder.spec = json::object();
    Store store(dir.path() / "q.db");
    store.submit(placeholder, std::nullopt, dir.path(), 0.0);
    store.submit(placeholder, std::nullopt, dir.path(), 0.0);
  }
  json good = settling(0.005);
  good["slurm"] = {{"partition", "debug"}, {"sbatch_args", {"--comment=millsim-options"}}};
  json bad = settling(0.005);
  bad["slurm"] = {{"partition", "nosuchpartition"}};
  bad["limits"] = {{"max_attempts", 1}};
  test::write_file(dir.path() / "good.json", good.dump());
  test::write_file(dir.path() / "bad.json", bad.dump());
  test::CommandResult r = test::run_millsim(
      "study good.json --local --executor slurm --db q.db --out runs", dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = test::run_millsim("study bad.json --local --executor slurm --db q.db --out runs", dir.path());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  Store store(dir.path() / "q.db");
  const RunRecord ran = *store.run("s000003-r0");
  EXPECT_EQ(ran.state, RunState::Complete);
  EXPECT_EQ(ran.slurm.partition, "debug");
  EXPECT_EQ(job_state(ran.id), "COMPLETED");
  const RunRecord refused = *store.run("s000004-r0");
  EXPECT_EQ(refused.state, RunState::SystemError);
  EXPECT_NE(refused.error.find("sbatch failed"), std::string::npos) << refused.error;
  EXPECT_NE(refused.error.find("artition"), std::string::npos) << refused.error;
}

// The batch system's stop before a time limit (sbatch --signal=B:USR1@lead, sent here by hand so
// the test does not wait on Slurm's minute-grained timer): the run checkpoints, the job requeues
// itself under the same id, and the run resumes from the checkpoint to its end, all in the
// service's one attempt.
TEST(Slurm, SignalledJobCheckpointsRequeuesAndResumes) {
  MILLSIM_RELEASE_ONLY(
      "Service.NextAttemptResumesFromTheLastCheckpoint and Checkpoint.ASignal"
      "DuringTheGasSpinUp... (the signal, checkpoint and resume; here Slurm's "
      "requeue waits on a run five times slower)");
  if (!SlurmExecutor::available()) GTEST_SKIP() << "no Slurm cluster answers";
  test::TempDir dir;
  {
    // Four empty studies first, so this one is s000005 (a job name of its own).
    Study placeholder;
    placeholder.name = "placeholder";
    placeholder.spec = json::object();
    Store store(dir.path() / "q.db");
    for (int k = 0; k < 4; ++k) store.submit(placeholder, std::nullopt, dir.path(), 0.0);
  }
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/attrition_target.json");
  const json study = {{"name", "requeue"},
                      {"scene", json::parse(in)},
                      {"set", {{"time.end_s", 8e-4}, {"output.h5", false}}}};
  test::write_file(dir.path() / "study.json", study.dump());
  const pid_t runner = fork();
  if (runner == 0) {
    test::die_with_parent();
    if (chdir(dir.path().c_str()) != 0) _exit(99);
    freopen("study.out", "w", stdout);
    freopen("study.err", "w", stderr);
    execl(MILLSIM_BINARY, "millsim", "study", "study.json", "--local", "--executor", "slurm",
          "--db", "q.db", "--out", "runs", static_cast<char*>(nullptr));
    _exit(98);
  }
  // Once the job has run a few seconds, Slurm's warning signal to its batch shell.
  const std::string id = "s000005-r0";
  for (int k = 0; k < 600 && job_state(id) != "RUNNING"; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_EQ(job_state(id), "RUNNING");
  std::this_thread::sleep_for(std::chrono::seconds(3));
  const test::CommandResult signalled =
      test::run_shell("scancel --batch --signal=USR1 --name=millsim-" + id + " 2>&1");
  EXPECT_EQ(signalled.exit_code, 0) << signalled.out;
  int status = 0;
  waitpid(runner, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << test::read_file(dir.path() / "study.err");

  Store store(dir.path() / "q.db");
  const RunRecord run = *store.run(id);
  EXPECT_EQ(run.state, RunState::Complete);
  EXPECT_EQ(run.attempts, 1);  // the requeue is Slurm's, inside one attempt
  const json result = json::parse(run.result);
  EXPECT_EQ(result["status"], "ok");
  ASSERT_TRUE(result.contains("resumed")) << run.result.substr(0, 400);
  EXPECT_GT(result["resumed"]["time_s"].get<double>(), 0.0);
  const std::vector<AttemptRecord> attempts = store.attempts(id);
  ASSERT_EQ(attempts.size(), 1u);
  ASSERT_TRUE(attempts[0].resumed_from_s);
  EXPECT_EQ(*attempts[0].resumed_from_s, result["resumed"]["time_s"].get<double>());
  const std::string log = test::read_file(std::filesystem::path(run.out_dir) / "log.txt");
  EXPECT_NE(log.find("interrupted by SIGUSR1"), std::string::npos) << log;
  EXPECT_NE(log.find("requeueing job"), std::string::npos) << log;
}

}  // namespace
}  // namespace millsim
