// The local executor starts the engine as the service means it to (issue 33): with the server's
// scenes root as --files-root, so the run itself decides what its file sources may open, and
// without the service token in its environment, which the engine has no use for. The engine is
// stood in for by a script that records its arguments and environment.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <cstdlib>
#include <thread>
#include <utility>

#include "executors/executor.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

namespace fs = std::filesystem;

// Runs `run` through a LocalExecutor whose "engine" is `script_body` (a shell script run in the
// run's directory); returns run/`record` ("" when the run did not end within 30 s).
std::string run_stand_in_engine(const fs::path& dir, RunRecord run, const std::string& script_body,
                                const std::string& record) {
  const fs::path script = dir / "engine.sh";
  test::write_file(script, "#!/bin/sh\n" + script_body);
  fs::permissions(script, fs::perms::owner_all);
  LocalExecutor executor(script);
  run.id = "s000001-r0";
  run.scene = "{}";
  run.out_dir = (dir / "run").string();
  run.wall_limit_s = 60;
  run.memory_limit_mb = 4096;
  ExecHandle handle = executor.start(run, 0.0);
  std::optional<ChildExit> exit;
  for (int k = 0; k < 3000 && !exit; ++k) {  // at most 30 s on a busy machine
    exit = executor.poll(handle, 0.0);
    if (!exit) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!exit) {
    executor.cancel(handle, 1e9);
    return "";
  }
  return test::read_file(dir / "run" / record);
}

// Runs `run` through a LocalExecutor whose "engine" is a script writing what it got; returns
// that record ("" when the script never ran).
std::string what_the_engine_got(const fs::path& dir, RunRecord run) {
  return run_stand_in_engine(dir, std::move(run),
                             "echo \"args: $*\" > got.txt\n"
                             "env >> got.txt\n",
                             "got.txt");
}

// The runs of one study share their gas spin-up: the cache is in the study's directory, beside
// the run's own (out_dir is <study>/<run>).
std::string cache_arg(const std::filesystem::path& dir) {
  return " --spin-up-cache " + (dir / "spin-up-cache").string();
}

TEST(LocalExecutor, TheEngineGetsTheFilesRootAndNotTheToken) {
  test::TempDir dir;
  setenv("MILLSIM_TOKEN", "secret-token", 1);
  setenv("MILLSIM_EXECUTOR_TEST", "kept", 1);
  RunRecord run;
  run.files_root = "/srv/scenes";
  const std::string got = what_the_engine_got(dir.path(), run);
  unsetenv("MILLSIM_TOKEN");
  unsetenv("MILLSIM_EXECUTOR_TEST");
  ASSERT_FALSE(got.empty()) << "the engine script did not run";
  EXPECT_NE(got.find("args: run scene.json --out . --quiet --resume --files-root /srv/scenes" +
                     cache_arg(dir.path()) + " --threads 1\n"),
            std::string::npos)
      << got;
  EXPECT_EQ(got.find("MILLSIM_TOKEN"), std::string::npos) << got;
  EXPECT_NE(got.find("MILLSIM_EXECUTOR_TEST=kept"), std::string::npos) << got;  // the rest stays

  // A local study (no server, no root): no --files-root; its limits.threads_per_run.
  test::TempDir local;
  RunRecord threaded;
  threaded.threads = 3;
  const std::string unrooted = what_the_engine_got(local.path(), threaded);
  EXPECT_NE(unrooted.find("args: run scene.json --out . --quiet --resume" +
                          cache_arg(local.path()) + " --threads 3\n"),
            std::string::npos)
      << unrooted;
}

// log.txt is the run's log (its thermo lines and messages on stderr), which the API's log tail
// and the dashboard show: the JSON summary `millsim run` prints on stdout is result.json's copy
// and stays out of it, or a finished run's tail would be the end of that JSON.
TEST(LocalExecutor, TheRunLogHoldsStderrNotTheSummaryOnStdout) {
  test::TempDir dir;
  const std::string log = run_stand_in_engine(dir.path(), RunRecord{},
                                              "echo '      Step   Time_s' >&2\n"
                                              "echo '{\"status\": \"ok\"}'\n"
                                              "echo '       100    1e-05' >&2\n",
                                              "log.txt");
  EXPECT_EQ(log, "      Step   Time_s\n       100    1e-05\n");
}

}  // namespace
}  // namespace millsim
