// `millsim run --resume` as a user meets it: a run killed with SIGKILL (a crash, a lost node)
// or stopped by SIGTERM (a batch system's time limit) continues from its newest checkpoint and
// ends with the same physics in result.json as the run that never stopped; a damaged newest
// checkpoint falls back to the one before; another scene's checkpoints, or only damaged ones,
// are refused with exit 2 and change nothing in the run's folder.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "checkpoint/checkpoint_file.h"
#include "support/process.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

// The attrition case (feeds, breakage, dust, an outlet) for 0.6 ms, a checkpoint every 0.1 ms.
json attrition_scene() {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/attrition_target.json");
  json scene = json::parse(in);
  scene["time"]["end_s"] = 6e-4;
  scene["output"] = {{"checkpoint_interval_s", 1e-4}, {"snapshot_interval_s", 2e-4}};
  return scene;
}

// Starts `millsim run ARGS...` in `dir` with stdout and stderr in files; returns its pid.
pid_t start_run(const std::filesystem::path& dir, const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    test::die_with_parent();
    if (chdir(dir.c_str()) != 0) _exit(99);
    freopen("started.out", "w", stdout);
    freopen("started.err", "w", stderr);
    std::vector<char*> argv = {const_cast<char*>("millsim"), const_cast<char*>("run")};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(MILLSIM_BINARY, argv.data());
    _exit(98);
  }
  return pid;
}

// Waits until `dir` holds `count` checkpoints (or the child ended); false on a timeout.
bool wait_for_checkpoints(pid_t pid, const std::filesystem::path& dir, std::size_t count) {
  for (int k = 0; k < 2400; ++k) {
    if (list_checkpoints(dir).size() >= count) return true;
    if (waitpid(pid, nullptr, WNOHANG) == pid) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  return false;
}

// Every file under `dir` with its size and content hash, to see that nothing changed.
std::map<std::string, std::uint64_t> fingerprint(const std::filesystem::path& dir) {
  std::map<std::string, std::uint64_t> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file()) {
      const std::string text = test::read_file(e.path());
      files[e.path().lexically_relative(dir).string()] = fnv1a64(text.data(), text.size());
    }
  return files;
}

TEST(Checkpoint, KilledRunResumesToTheSameResult) {
  MILLSIM_RELEASE_ONLY("Checkpoint.RestoredRunContinuesBitForBit");
  test::TempDir dir;
  test::write_file(dir.path() / "scene.json", attrition_scene().dump(2));
  const test::CommandResult whole =
      test::run_millsim("run scene.json --out whole --quiet", dir.path());
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const json reference = json::parse(whole.out);
  ASSERT_GT(reference["breakage"]["events"].get<int>(), 0);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "whole/checkpoints"))
      << "a complete run keeps no checkpoints";

  // A crash: SIGKILL once two checkpoints are on disk.
  const pid_t pid = start_run(dir.path(), {"scene.json", "--out", "crashed", "--quiet"});
  ASSERT_TRUE(wait_for_checkpoints(pid, dir.path() / "crashed/checkpoints", 2));
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  ASSERT_FALSE(std::filesystem::exists(dir.path() / "crashed/result.json"));
  std::filesystem::copy(dir.path() / "crashed", dir.path() / "spare",
                        std::filesystem::copy_options::recursive);

  // The newest checkpoint damaged: the run falls back to the one before and still ends equal.
  const std::vector<std::filesystem::path> saved =
      list_checkpoints(dir.path() / "crashed/checkpoints");
  ASSERT_GE(saved.size(), 2u);
  {
    std::fstream f(saved[0], std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    f.put('\x5a');
  }
  const test::CommandResult resumed =
      test::run_millsim("run scene.json --out crashed --quiet --resume", dir.path());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const json result = json::parse(resumed.out);
  EXPECT_EQ(test::physics_of(result), test::physics_of(reference));
  EXPECT_EQ(result["resumed"]["skipped_damaged"].size(), 1u);
  EXPECT_EQ(result["resumed"]["checkpoint"], saved[1].filename().string());
  EXPECT_GE(result["resumed"]["snapshots_carried"].get<int>(), 1);
  EXPECT_EQ(result["outputs"]["snapshots"], reference["outputs"]["snapshots"]);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "crashed/checkpoints"));

  // Another scene's checkpoints: refused, and nothing in the folder changes.
  const auto before = fingerprint(dir.path() / "spare");
  json other = attrition_scene();
  other["materials"][0]["restitution"] = 0.45;
  test::write_file(dir.path() / "other.json", other.dump(2));
  test::CommandResult refused =
      test::run_millsim("run other.json --out spare --quiet --resume", dir.path());
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("another scene"), std::string::npos) << refused.err;
  EXPECT_EQ(fingerprint(dir.path() / "spare"), before);

  // Only damaged checkpoints: refused with each one's reason, nothing changes.
  for (const auto& p : list_checkpoints(dir.path() / "spare/checkpoints"))
    std::filesystem::resize_file(p, std::filesystem::file_size(p) / 2);
  const auto truncated = fingerprint(dir.path() / "spare");
  refused = test::run_millsim("run scene.json --out spare --quiet --resume", dir.path());
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("no usable checkpoint"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("checksum"), std::string::npos) << refused.err;
  EXPECT_EQ(fingerprint(dir.path() / "spare"), truncated);
}

TEST(Checkpoint, SigtermWritesACheckpointAndResumeFinishesTheRun) {
  MILLSIM_RELEASE_ONLY("Checkpoint.RestoredRunContinuesBitForBit");
  test::TempDir dir;
  json scene = attrition_scene();
  scene["output"].erase("checkpoint_interval_s");  // only the one the signal asks for
  test::write_file(dir.path() / "scene.json", scene.dump(2));
  const test::CommandResult whole =
      test::run_millsim("run scene.json --out whole --quiet", dir.path());
  ASSERT_EQ(whole.exit_code, 0) << whole.err;

  const pid_t pid = start_run(
      dir.path(), {"scene.json", "--out", "stopped", "--quiet", "--log-interval", "0.05"});
  // Stop it once it is under way: its thermo log (a line every 50 ms) has a step past 0.
  auto lines = [&] {
    const std::string log = test::read_file(dir.path() / "stopped/log.txt");
    return std::count(log.begin(), log.end(), '\n');
  };
  for (int k = 0; k < 800 && lines() < 4; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  ASSERT_EQ(list_checkpoints(dir.path() / "stopped/checkpoints").size(), 1u);

  const test::CommandResult resumed =
      test::run_millsim("run scene.json --out stopped --quiet --resume", dir.path());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const json result = json::parse(resumed.out);
  EXPECT_EQ(test::physics_of(result), test::physics_of(json::parse(whole.out)));
  EXPECT_TRUE(result["resumed"]["skipped_damaged"].empty());
  EXPECT_EQ(result["outputs"]["snapshots"], json::parse(whole.out)["outputs"]["snapshots"]);

  // --resume with no checkpoint starts from the beginning.
  const test::CommandResult fresh =
      test::run_millsim("run scene.json --out fresh --quiet --resume", dir.path());
  ASSERT_EQ(fresh.exit_code, 0) << fresh.err;
  EXPECT_FALSE(json::parse(fresh.out).contains("resumed"));
}

// A run with hold-up fills resumed between two of them: the third, the second of the dust alone,
// fits its dust's exit rates against the second fill's window (time.fill_dust_exit_follows_load),
// which the checkpoint carries; the resumed run fills, and ends, as the run that never stopped.
TEST(Checkpoint, ARunResumedBetweenTwoFillsFillsAsTheWholeRun) {
  MILLSIM_RELEASE_ONLY("HoldupFill.ALateFillMovesTheDustAloneForTheParticlesTheMillHolds");
  test::TempDir dir;
  json scene = test::mill_with_ledger_outflows(1.6e-3, std::nullopt);
  scene["gas"]["spin_up_s"] = 0.002;
  scene["time"]["fill_to_projection_s"] = {0.0004, 0.0007, 0.001};
  scene["time"]["fill_relaxation"] = 0.5;
  scene["time"]["fill_dust_only_from_s"] = 0.0006;
  scene["time"]["fill_dust_exit_follows_load"] = true;
  scene["output"] = {{"h5", false}, {"checkpoint_interval_s", 2.5e-4}};
  test::write_file(dir.path() / "scene.json", scene.dump(2));
  const test::CommandResult whole =
      test::run_millsim("run scene.json --out whole --quiet", dir.path());
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const json reference = json::parse(whole.out);
  ASSERT_EQ(reference["holdup_fills"].size(), 3u);
  ASSERT_TRUE(reference["holdup_fills"][2]["dust_exit_load"].is_object());

  // Killed once the checkpoint after the second fill (0.75 ms) is on disk; any checkpoint past
  // the third fill is removed, so that the resumed run makes it.
  const pid_t pid = start_run(dir.path(), {"scene.json", "--out", "crashed", "--quiet"});
  const std::filesystem::path saved = dir.path() / "crashed/checkpoints";
  const auto newest_s = [&] {
    try {
      const std::vector<std::filesystem::path> files = list_checkpoints(saved);
      return files.empty() ? 0.0 : read_checkpoint(files.front()).header.time_s;
    } catch (const std::exception&) {  // pruned or renamed while read: look again
      return 0.0;
    }
  };
  for (int k = 0; k < 2400 && newest_s() < 0.0007; ++k) {
    ASSERT_NE(waitpid(pid, nullptr, WNOHANG), pid) << "the run ended before its checkpoint";
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  int between = 0;
  for (const auto& path : list_checkpoints(saved)) {
    const double t = read_checkpoint(path).header.time_s;
    if (t > 0.00095)
      std::filesystem::remove(path);
    else
      between += t > 0.0007;
  }
  ASSERT_GT(between, 0) << "a checkpoint between the second and third fills";
  const test::CommandResult resumed =
      test::run_millsim("run scene.json --out crashed --quiet --resume", dir.path());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const json result = json::parse(resumed.out);
  ASSERT_TRUE(result.contains("resumed"));
  EXPECT_LT(result["resumed"]["time_s"].get<double>(), 0.00095);
  EXPECT_EQ(result["holdup_fills"], reference["holdup_fills"]);
  EXPECT_EQ(test::physics_of(result), test::physics_of(reference));
}

// The gas spin-up as a user meets it (issue 32, item 3): a line when it starts and every
// --log-interval, and a signal during it (here Slurm's SIGUSR1 before a time limit) answered like
// one during the steps: exit 128 + the signal, result.json saying where it stopped, and a
// checkpoint of the gas that --resume continues instead of spinning up again from nothing.
TEST(Checkpoint, ASignalDuringTheGasSpinUpLeavesResultAndCheckpointAndResumeContinuesIt) {
  test::TempDir dir;
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/spiral_jet_mill.json");
  json scene = json::parse(in);
  scene["gas"]["spin_up_s"] = 0.002;
  scene["time"]["end_s"] = 1e-5;
  test::write_file(dir.path() / "scene.json", scene.dump(2));
  const pid_t pid =
      start_run(dir.path(), {"scene.json", "--out", "mill", "--quiet", "--log-interval", "0.05"});
  auto spin_up_lines = [&] {
    std::istringstream log(test::read_file(dir.path() / "mill/log.txt"));
    int count = 0;
    for (std::string line; std::getline(log, line);) count += line.rfind("spin-up: gas ", 0) == 0;
    return count;
  };
  for (int k = 0; k < 3000 && spin_up_lines() < 3; ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GE(spin_up_lines(), 3) << test::read_file(dir.path() / "started.err");
  EXPECT_EQ(test::read_file(dir.path() / "mill/log.txt").rfind("spin-up: gas 0 of 0.002 s", 0), 0u)
      << "the first line comes when the spin-up starts";
  kill(pid, SIGUSR1);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGUSR1);
  EXPECT_NE(test::read_file(dir.path() / "started.err").find("during the gas spin-up"),
            std::string::npos);
  const json stopped = json::parse(test::read_file(dir.path() / "mill/result.json"));
  EXPECT_EQ(stopped["status"], "interrupted");
  EXPECT_EQ(stopped["interrupted"]["phase"], "gas_spin_up");
  const double stopped_at_s = stopped["spin_up"]["done_s"];
  EXPECT_GT(stopped_at_s, 0.0);
  EXPECT_LT(stopped_at_s, 0.002);
  ASSERT_TRUE(std::filesystem::exists(dir.path() / "mill/checkpoints/spin-up.ckpt"));

  const test::CommandResult resumed =
      test::run_millsim("run scene.json --out mill --quiet --resume", dir.path());
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const json result = json::parse(resumed.out);
  EXPECT_EQ(result["status"], "ok");
  EXPECT_EQ(result["spin_up"]["source"], "resumed");
  EXPECT_EQ(result["spin_up"]["resumed_from_s"].get<double>(), stopped_at_s);
  EXPECT_GT(result["wall_time_total_s"].get<double>(), result["wall_time_s"].get<double>());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "mill/checkpoints"));
}

}  // namespace
}  // namespace millsim
