// The SQLite queue: schema version, idempotent submission, atomic claims under concurrent
// claimers (each with its own connection, as separate processes would have), leases, fencing,
// retries bounded by max_attempts, and cancel.
#include "queue/store.h"

#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <thread>

#include "support/scenes.h"

namespace millsim {
namespace {

Study trivial_study(int runs, int max_attempts = 3) {
  Study s;
  s.name = "trivial";
  s.spec = {{"name", "trivial"}};
  s.error_metric = "";
  s.limits.max_attempts = max_attempts;
  for (int k = 0; k < runs; ++k) {
    StudyRun r;
    r.index = k;
    r.params = {{"k", k}};
    r.scene = {{"seed", k}};
    s.runs.push_back(r);
  }
  return s;
}

TEST(Store, SchemaIsVersionedAndSubmissionIsIdempotent) {
  test::TempDir dir;
  Store store(dir.path() / "q.db");
  EXPECT_EQ(store.schema_version(), kSchemaVersion);
  const auto a = store.submit(trivial_study(3), std::string("key-1"), dir.path(), 1.0);
  const auto b = store.submit(trivial_study(3), std::string("key-1"), dir.path(), 2.0);
  EXPECT_TRUE(a.created);
  EXPECT_FALSE(b.created);
  EXPECT_EQ(a.study_id, b.study_id);
  EXPECT_EQ(store.progress(a.study_id).total, 3);
  EXPECT_EQ(store.studies(10, 0).size(), 1u);
  // Reopening keeps everything.
  Store again(dir.path() / "q.db");
  EXPECT_EQ(again.progress(a.study_id).count(RunState::Queued), 3);
}

// The studies are listed newest first (the dashboard and `millsim status` show the first page),
// and the pages follow that order.
TEST(Store, StudiesAreListedNewestFirst) {
  test::TempDir dir;
  Store store(dir.path() / "q.db");
  std::vector<std::string> submitted;
  for (double now : {1.0, 2.0, 3.0})
    submitted.push_back(store.submit(trivial_study(1), std::nullopt, dir.path(), now).study_id);
  std::vector<std::string> listed;
  for (int offset : {0, 2})
    for (const StudyRecord& st : store.studies(2, offset)) listed.push_back(st.id);
  EXPECT_EQ(listed, (std::vector<std::string>{submitted[2], submitted[1], submitted[0]}));
}

// A version-1 file (before the regression history) opens, keeps its studies and gains the
// history table; records are listed newest first and by suite.
TEST(Store, VersionOneFilesMigrateAndKeepTheRegressionHistory) {
  test::TempDir dir;
  const std::filesystem::path db = dir.path() / "q.db";
  std::string study_id;
  {
    Store store(db);
    study_id = store.submit(trivial_study(2), std::nullopt, dir.path(), 1.0).study_id;
  }
  {
    Database raw(db);
    raw.exec(
        "DROP TABLE regressions; ALTER TABLE runs DROP COLUMN executor_options; "
        "ALTER TABLE attempts DROP COLUMN resumed_from_s; ALTER TABLE runs DROP COLUMN threads; "
        "PRAGMA user_version = 1;");
  }
  Store store(db);
  EXPECT_EQ(store.schema_version(), kSchemaVersion);
  EXPECT_TRUE(store.run(study_id + "-r0")->slurm.empty());
  EXPECT_EQ(store.progress(study_id).total, 2);
  EXPECT_TRUE(store.attempts(study_id + "-r0").empty());  // the v4 column is readable
  EXPECT_EQ(store.run(study_id + "-r0")->threads, 1);     // v5: one thread, as before
  auto record = [](const char* suite, bool passed) {
    return nlohmann::json{
        {"suite", suite}, {"passed", passed}, {"rows", {{{"verdict", passed ? "pass" : "drift"}}}}};
  };
  EXPECT_EQ(store.add_regression(record("physics", true), 10.0), "g000001");
  EXPECT_EQ(store.add_regression(record("physics", false), 20.0), "g000002");
  EXPECT_EQ(store.add_regression(record("other", true), 30.0), "g000003");
  const std::vector<RegressionEntry> physics = store.regressions(10, 0, "physics");
  ASSERT_EQ(physics.size(), 2u);
  EXPECT_EQ(physics[0].id, "g000002");
  EXPECT_EQ(physics[0].failures, 1);
  EXPECT_FALSE(physics[0].passed);
  EXPECT_EQ(store.regressions(10, 0).size(), 3u);
  EXPECT_EQ(store.regressions(1, 1)[0].id, "g000002");
  EXPECT_TRUE(store.regression("g000001"));
  EXPECT_FALSE(store.regression("g000009"));
}

TEST(Store, ConcurrentClaimersNeverGetTheSameRun) {
  test::TempDir dir;
  const std::filesystem::path db = dir.path() / "q.db";
  {
    Store store(db);
    store.submit(trivial_study(100), std::nullopt, dir.path(), 1.0);
  }
  std::vector<std::vector<std::string>> claimed(4);
  std::vector<std::thread> workers;
  for (int w = 0; w < 4; ++w)
    workers.emplace_back([&, w] {
      Store store(db);  // its own connection
      const std::string name = std::string(1, char('a' + w));
      while (auto c = store.claim(name, 60.0, 2.0)) {
        claimed[std::size_t(w)].push_back(c->run.id);
        FinishReport done;
        store.finish(c->run.id, c->token, done, 3.0);
      }
    });
  for (std::thread& t : workers) t.join();
  std::set<std::string> all;
  std::size_t total = 0;
  for (const auto& list : claimed) {
    total += list.size();
    all.insert(list.begin(), list.end());
  }
  EXPECT_EQ(total, 100u);
  EXPECT_EQ(all.size(), 100u);
  Store store(db);
  EXPECT_EQ(store.progress("s000001").count(RunState::Complete), 100);
}

TEST(Store, ExpiredLeasesAreRetriedUpToMaxAttemptsAndStaleTokensAreFenced) {
  test::TempDir dir;
  Store store(dir.path() / "q.db");
  const std::string study = store.submit(trivial_study(1, 2), std::nullopt, dir.path(), 0).study_id;
  auto first = store.claim("a", 10.0, 0.0);
  ASSERT_TRUE(first);
  EXPECT_TRUE(store.heartbeat(first->run.id, first->token, 10.0, 5.0));  // lease to 15
  EXPECT_EQ(store.requeue_expired(14.0), 0);
  EXPECT_EQ(store.requeue_expired(16.0), 1);  // worker a is gone: attempt 1 is a system error
  EXPECT_EQ(store.run(first->run.id)->state, RunState::Queued);

  auto second = store.claim("b", 10.0, 20.0);
  ASSERT_TRUE(second);
  EXPECT_GT(second->token, first->token);
  // Worker a comes back: its reports are refused.
  FinishReport late;
  EXPECT_FALSE(store.heartbeat(first->run.id, first->token, 10.0, 21.0));
  EXPECT_FALSE(store.finish(first->run.id, first->token, late, 21.0));
  // Attempt 2 dies too: the run stays failed with its last error.
  EXPECT_EQ(store.requeue_expired(40.0), 1);
  const RunRecord r = *store.run(first->run.id);
  EXPECT_EQ(r.state, RunState::SystemError);
  EXPECT_EQ(r.attempts, 2);
  EXPECT_NE(r.error.find("lease expired"), std::string::npos);
  EXPECT_FALSE(store.claim("c", 10.0, 41.0));
  EXPECT_TRUE(store.progress(study).finished());
}

TEST(Store, EngineErrorsAreNotRetriedAndCancelStopsTheStudy) {
  test::TempDir dir;
  Store store(dir.path() / "q.db");
  const std::string study = store.submit(trivial_study(3), std::nullopt, dir.path(), 0).study_id;
  auto c = store.claim("a", 10.0, 1.0);
  FinishReport rejected;
  rejected.state = RunState::ExecutorError;
  rejected.exit_code = 2;
  rejected.error = "bad scene";
  EXPECT_TRUE(store.finish(c->run.id, c->token, rejected, 2.0));
  EXPECT_EQ(store.run(c->run.id)->state, RunState::ExecutorError);

  auto running = store.claim("a", 10.0, 3.0);
  store.cancel_study(study, 4.0);
  const Progress p = store.progress(study);
  EXPECT_EQ(p.count(RunState::Canceled), 1);   // the queued one
  EXPECT_EQ(p.count(RunState::Canceling), 1);  // the running one, for its worker
  EXPECT_FALSE(store.heartbeat(running->run.id, running->token, 10.0, 5.0));  // stop the child
  FinishReport stopped;
  stopped.state = RunState::SystemError;
  EXPECT_TRUE(store.finish(running->run.id, running->token, stopped, 6.0));
  EXPECT_EQ(store.run(running->run.id)->state, RunState::Canceled);
  EXPECT_TRUE(store.progress(study).finished());
}

}  // namespace
}  // namespace millsim
