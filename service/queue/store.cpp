#include "queue/store.h"

#include <unistd.h>

namespace millsim {
namespace {

constexpr const char* kSchemaV1 = R"(
CREATE TABLE studies (
  id TEXT PRIMARY KEY,
  name TEXT NOT NULL,
  spec TEXT NOT NULL,
  error_metric TEXT NOT NULL,
  reference_run TEXT,
  idempotency_key TEXT UNIQUE,
  canceled INTEGER NOT NULL DEFAULT 0,
  created_at REAL NOT NULL
);
CREATE TABLE runs (
  id TEXT PRIMARY KEY,
  study_id TEXT NOT NULL REFERENCES studies(id),
  idx INTEGER NOT NULL,
  params TEXT NOT NULL,
  seed INTEGER NOT NULL,
  scene TEXT NOT NULL,
  is_reference INTEGER NOT NULL,
  state TEXT NOT NULL,
  attempts INTEGER NOT NULL DEFAULT 0,
  max_attempts INTEGER NOT NULL,
  fencing_token INTEGER NOT NULL DEFAULT 0,
  lease_owner TEXT,
  lease_expires_at REAL NOT NULL DEFAULT 0,
  created_at REAL NOT NULL,
  started_at REAL NOT NULL DEFAULT 0,
  finished_at REAL NOT NULL DEFAULT 0,
  exit_code INTEGER,
  error TEXT NOT NULL DEFAULT '',
  wall_time_s REAL NOT NULL DEFAULT 0,
  result TEXT NOT NULL DEFAULT '',
  out_dir TEXT NOT NULL,
  wall_limit_s REAL NOT NULL,
  memory_limit_mb REAL NOT NULL,
  UNIQUE (study_id, idx)
);
CREATE INDEX runs_by_state ON runs(state, study_id, idx);
CREATE TABLE attempts (
  run_id TEXT NOT NULL REFERENCES runs(id),
  attempt INTEGER NOT NULL,
  worker TEXT NOT NULL,
  started_at REAL NOT NULL,
  finished_at REAL NOT NULL DEFAULT 0,
  state TEXT NOT NULL,
  exit_code INTEGER,
  error TEXT NOT NULL DEFAULT '',
  PRIMARY KEY (run_id, attempt)
);
)";

// Version 2: the regression history (millsim regress), one row per regression run.
constexpr const char* kSchemaV2 = R"(
CREATE TABLE regressions (
  id TEXT PRIMARY KEY,
  suite TEXT NOT NULL,
  created_at REAL NOT NULL,
  passed INTEGER NOT NULL,
  failures INTEGER NOT NULL,
  record TEXT NOT NULL
);
CREATE INDEX regressions_by_suite ON regressions(suite, created_at);
)";

// Version 3: each run's Slurm options (the study's `slurm` key), as JSON.
constexpr const char* kSchemaV3 =
    "ALTER TABLE runs ADD COLUMN executor_options TEXT NOT NULL DEFAULT '{}';";

// Version 4: the simulated time each attempt resumed from (a checkpoint), NULL from the start.
constexpr const char* kSchemaV4 = "ALTER TABLE attempts ADD COLUMN resumed_from_s REAL;";

// Version 5: each run's thread count (the study's limits.threads_per_run).
constexpr const char* kSchemaV5 = "ALTER TABLE runs ADD COLUMN threads INTEGER NOT NULL DEFAULT 1;";

constexpr const char* kRunColumns =
    "id, study_id, idx, params, seed, scene, is_reference, state, attempts, max_attempts, "
    "fencing_token, lease_owner, lease_expires_at, created_at, started_at, finished_at, "
    "exit_code, error, wall_time_s, result, out_dir, wall_limit_s, memory_limit_mb, "
    "executor_options, threads";

RunRecord read_run(const Statement& s) {
  RunRecord r;
  r.id = s.text(0);
  r.study_id = s.text(1);
  r.index = int(s.integer(2));
  r.params = nlohmann::json::parse(s.text(3));
  r.seed = std::uint64_t(s.integer(4));
  r.scene = s.text(5);
  r.is_reference = s.integer(6) != 0;
  r.state = run_state_from_name(s.text(7)).value_or(RunState::SystemError);
  r.attempts = int(s.integer(8));
  r.max_attempts = int(s.integer(9));
  r.fencing_token = s.integer(10);
  if (!s.is_null(11)) r.lease_owner = s.text(11);
  r.lease_expires_at = s.real(12);
  r.created_at = s.real(13);
  r.started_at = s.real(14);
  r.finished_at = s.real(15);
  if (!s.is_null(16)) r.exit_code = int(s.integer(16));
  r.error = s.text(17);
  r.wall_time_s = s.real(18);
  r.result = s.text(19);
  r.out_dir = s.text(20);
  r.wall_limit_s = s.real(21);
  r.memory_limit_mb = s.real(22);
  r.slurm = SlurmOptions::from_json(nlohmann::json::parse(s.text(23), nullptr, false));
  r.threads = int(s.integer(24));
  return r;
}

std::string name_of(RunState s) {
  return std::string(run_state_name(s));
}

}  // namespace

std::optional<RunState> run_state_from_name(std::string_view name) {
  for (int s = 0; s <= int(RunState::Canceled); ++s)
    if (run_state_name(RunState(s)) == name) return RunState(s);
  return std::nullopt;
}

bool Progress::finished() const {
  return count(RunState::Queued) + count(RunState::Running) + count(RunState::Canceling) == 0;
}

Store::Store(const std::filesystem::path& path) : db_(path) {
  migrate();
}

int Store::schema_version() {
  Statement s = db_.prepare("PRAGMA user_version");
  return s.step() ? int(s.integer(0)) : 0;
}

void Store::migrate() {
  db_.transaction([&] {
    const int version = schema_version();
    if (version > kSchemaVersion)
      throw DbError("the database has schema version " + std::to_string(version) +
                    ", newer than this millsim (" + std::to_string(kSchemaVersion) + ")");
    if (version < 1) db_.exec(kSchemaV1);
    if (version < 2) db_.exec(kSchemaV2);
    if (version < 3) db_.exec(kSchemaV3);
    if (version < 4) db_.exec(kSchemaV4);
    if (version < 5) db_.exec(kSchemaV5);
    db_.exec(("PRAGMA user_version = " + std::to_string(kSchemaVersion)).c_str());
  });
}

Store::Submitted Store::submit(const Study& study, const std::optional<std::string>& key,
                               const std::filesystem::path& out_root, double now) {
  return db_.transaction([&]() -> Submitted {
    if (key) {
      Statement s = db_.prepare("SELECT id FROM studies WHERE idempotency_key = ?");
      s.bind(1, *key);
      if (s.step()) return {s.text(0), false};
    }
    Statement count = db_.prepare("SELECT COUNT(*) FROM studies");
    count.step();
    char id[32];
    std::snprintf(id, sizeof id, "s%06lld", static_cast<long long>(count.integer(0) + 1));
    const std::string study_id = id;
    std::optional<std::string> reference;
    if (study.reference_index) reference = study_id + "-r" + std::to_string(*study.reference_index);
    Statement insert = db_.prepare(
        "INSERT INTO studies (id, name, spec, error_metric, reference_run, idempotency_key, "
        "created_at) VALUES (?, ?, ?, ?, ?, ?, ?)");
    insert.bind(1, study_id).bind(2, study.name).bind(3, study.spec.dump());
    insert.bind(4, study.error_metric).bind(5, reference).bind(6, key).bind(7, now);
    insert.run();
    for (const StudyRun& r : study.runs) {
      const std::string run_id = study_id + "-r" + std::to_string(r.index);
      Statement run = db_.prepare(
          "INSERT INTO runs (id, study_id, idx, params, seed, scene, is_reference, state, "
          "max_attempts, created_at, out_dir, wall_limit_s, memory_limit_mb, executor_options, "
          "threads) VALUES (?, ?, ?, ?, ?, ?, ?, 'QUEUED', ?, ?, ?, ?, ?, ?, ?)");
      run.bind(1, run_id).bind(2, study_id).bind(3, std::int64_t(r.index));
      run.bind(4, r.params.dump()).bind(5, std::int64_t(r.seed)).bind(6, r.scene.dump());
      run.bind(7, std::int64_t(r.is_reference)).bind(8, std::int64_t(study.limits.max_attempts));
      run.bind(9, now).bind(10, (out_root / study_id / run_id).string());
      run.bind(11, study.limits.wall_time_s).bind(12, study.limits.memory_mb);
      run.bind(13, study.slurm.to_json().dump());
      run.bind(14, std::int64_t(study.limits.threads_per_run));
      run.run();
    }
    return {study_id, true};
  });
}

std::optional<Claim> Store::claim(const std::string& worker, double lease_s, double now,
                                  const std::optional<std::string>& study_id) {
  return db_.transaction([&]() -> std::optional<Claim> {
    Statement pick = db_.prepare(
        "SELECT r.id FROM runs r JOIN studies s ON s.id = r.study_id "
        "WHERE r.state = 'QUEUED' AND (?1 IS NULL OR r.study_id = ?1) "
        "ORDER BY s.created_at, r.study_id, r.idx LIMIT 1");
    pick.bind(1, study_id);
    if (!pick.step()) return std::nullopt;
    const std::string id = pick.text(0);
    Statement update = db_.prepare(
        "UPDATE runs SET state = 'RUNNING', attempts = attempts + 1, "
        "fencing_token = fencing_token + 1, lease_owner = ?, lease_expires_at = ?, "
        "started_at = ? WHERE id = ? AND state = 'QUEUED'");
    update.bind(1, worker).bind(2, now + lease_s).bind(3, now).bind(4, id);
    update.run();
    if (db_.changes() != 1) return std::nullopt;
    std::optional<RunRecord> record = run(id);
    Statement attempt = db_.prepare(
        "INSERT INTO attempts (run_id, attempt, worker, started_at, state) "
        "VALUES (?, ?, ?, ?, 'RUNNING')");
    attempt.bind(1, id).bind(2, std::int64_t(record->attempts)).bind(3, worker).bind(4, now);
    attempt.run();
    return Claim{*record, record->fencing_token};
  });
}

bool Store::heartbeat(const std::string& run_id, std::int64_t token, double lease_s, double now) {
  Statement s = db_.prepare(
      "UPDATE runs SET lease_expires_at = ? WHERE id = ? AND fencing_token = ? AND "
      "state = 'RUNNING'");
  s.bind(1, now + lease_s).bind(2, run_id).bind(3, token);
  s.run();
  return db_.changes() == 1;
}

namespace {

// The simulated time a run's result.json says it resumed from (docs/checkpoints.md).
std::optional<double> resumed_from_s(const std::string& result) {
  const nlohmann::json r = nlohmann::json::parse(result, nullptr, false);
  if (!r.is_object() || !r.contains("resumed") || !r["resumed"].is_object()) return std::nullopt;
  const nlohmann::json& t = r["resumed"].value("time_s", nlohmann::json());
  return t.is_number() ? std::optional<double>(t.get<double>()) : std::nullopt;
}

}  // namespace

bool Store::finish(const std::string& run_id, std::int64_t token, const FinishReport& report,
                   double now) {
  return db_.transaction([&] {
    std::optional<RunRecord> r = run(run_id);
    if (!r || r->fencing_token != token ||
        (r->state != RunState::Running && r->state != RunState::Canceling))
      return false;
    RunState next = report.state;
    if (r->state == RunState::Canceling) next = RunState::Canceled;
    const bool retry =
        next == RunState::SystemError && report.retryable && r->attempts < r->max_attempts;
    Statement a = db_.prepare(
        "UPDATE attempts SET finished_at = ?, state = ?, exit_code = ?, error = ?, "
        "resumed_from_s = ? WHERE run_id = ? AND attempt = ?");
    a.bind(1, now).bind(2, name_of(next));
    if (report.exit_code)
      a.bind(3, std::int64_t(*report.exit_code));
    else
      a.bind(3, std::nullopt);
    a.bind(4, report.error);
    if (const std::optional<double> t = resumed_from_s(report.result))
      a.bind(5, *t);
    else
      a.bind(5, std::nullopt);
    a.bind(6, run_id).bind(7, std::int64_t(r->attempts));
    a.run();
    Statement u = db_.prepare(
        "UPDATE runs SET state = ?, lease_owner = NULL, lease_expires_at = 0, finished_at = ?, "
        "exit_code = ?, error = ?, wall_time_s = ?, result = ? WHERE id = ?");
    u.bind(1, name_of(retry ? RunState::Queued : next)).bind(2, retry ? 0.0 : now);
    if (report.exit_code)
      u.bind(3, std::int64_t(*report.exit_code));
    else
      u.bind(3, std::nullopt);
    u.bind(4, report.error).bind(5, report.wall_time_s).bind(6, report.result).bind(7, run_id);
    u.run();
    return true;
  });
}

int Store::requeue_expired(double now) {
  std::vector<RunRecord> expired;
  {
    Statement s =
        db_.prepare((std::string("SELECT ") + kRunColumns +
                     " FROM runs WHERE state IN ('RUNNING', 'CANCELING') AND lease_expires_at < ?")
                        .c_str());
    s.bind(1, now);
    while (s.step()) expired.push_back(read_run(s));
  }
  int touched = 0;
  for (const RunRecord& r : expired) {
    FinishReport report;
    report.state = RunState::SystemError;
    report.retryable = true;
    report.error =
        "the worker's lease expired (worker " + r.lease_owner.value_or("?") + " lost or killed)";
    touched += finish(r.id, r.fencing_token, report, now);
  }
  return touched;
}

void Store::cancel_study(const std::string& study_id, double now) {
  db_.transaction([&] {
    Statement s = db_.prepare("UPDATE studies SET canceled = 1 WHERE id = ?");
    s.bind(1, study_id);
    s.run();
    Statement q = db_.prepare(
        "UPDATE runs SET state = 'CANCELED', finished_at = ? WHERE study_id = ? AND "
        "state = 'QUEUED'");
    q.bind(1, now).bind(2, study_id);
    q.run();
    Statement r =
        db_.prepare("UPDATE runs SET state = 'CANCELING' WHERE study_id = ? AND state = 'RUNNING'");
    r.bind(1, study_id);
    r.run();
  });
}

std::optional<StudyRecord> Store::study(const std::string& id) {
  Statement s = db_.prepare(
      "SELECT id, name, spec, error_metric, reference_run, canceled, created_at FROM studies "
      "WHERE id = ?");
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  StudyRecord r;
  r.id = s.text(0);
  r.name = s.text(1);
  r.spec = s.text(2);
  r.error_metric = s.text(3);
  if (!s.is_null(4)) r.reference_run = s.text(4);
  r.canceled = s.integer(5) != 0;
  r.created_at = s.real(6);
  return r;
}

std::vector<StudyRecord> Store::studies(int limit, int offset) {
  std::vector<StudyRecord> out;
  // Newest first, like the regression history: the first page is what is going on now.
  Statement s =
      db_.prepare("SELECT id FROM studies ORDER BY created_at DESC, id DESC LIMIT ? OFFSET ?");
  s.bind(1, std::int64_t(limit)).bind(2, std::int64_t(offset));
  while (s.step()) out.push_back(*study(s.text(0)));
  return out;
}

std::optional<RunRecord> Store::run(const std::string& id) {
  Statement s =
      db_.prepare((std::string("SELECT ") + kRunColumns + " FROM runs WHERE id = ?").c_str());
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_run(s);
}

std::vector<AttemptRecord> Store::attempts(const std::string& run_id) {
  Statement s = db_.prepare(
      "SELECT attempt, worker, started_at, finished_at, state, exit_code, error, resumed_from_s "
      "FROM attempts WHERE run_id = ? ORDER BY attempt");
  s.bind(1, run_id);
  std::vector<AttemptRecord> out;
  while (s.step()) {
    AttemptRecord a;
    a.attempt = int(s.integer(0));
    a.worker = s.text(1);
    a.started_at = s.real(2);
    a.finished_at = s.real(3);
    a.state = s.text(4);
    if (!s.is_null(5)) a.exit_code = int(s.integer(5));
    a.error = s.text(6);
    if (!s.is_null(7)) a.resumed_from_s = s.real(7);
    out.push_back(std::move(a));
  }
  return out;
}

std::vector<RunRecord> Store::runs(const std::string& study_id,
                                   const std::optional<RunState>& state, int limit, int offset) {
  std::vector<RunRecord> out;
  Statement s = db_.prepare((std::string("SELECT ") + kRunColumns +
                             " FROM runs WHERE study_id = ? AND (?2 IS NULL OR state = ?2) "
                             "ORDER BY idx LIMIT ? OFFSET ?")
                                .c_str());
  s.bind(1, study_id);
  if (state)
    s.bind(2, name_of(*state));
  else
    s.bind(2, std::nullopt);
  s.bind(3, std::int64_t(limit)).bind(4, std::int64_t(offset));
  while (s.step()) out.push_back(read_run(s));
  return out;
}

namespace {

RegressionEntry read_regression(const Statement& s) {
  RegressionEntry e;
  e.id = s.text(0);
  e.suite = s.text(1);
  e.created_at = s.real(2);
  e.passed = s.integer(3) != 0;
  e.failures = int(s.integer(4));
  e.record = s.text(5);
  return e;
}

}  // namespace

std::string Store::add_regression(const nlohmann::json& record, double now) {
  return db_.transaction([&]() -> std::string {
    Statement count = db_.prepare("SELECT COUNT(*) FROM regressions");
    count.step();
    char id[32];
    std::snprintf(id, sizeof id, "g%06lld", static_cast<long long>(count.integer(0) + 1));
    int failures = 0;
    for (const nlohmann::json& row : record["rows"]) {
      const std::string verdict = row.value("verdict", "");
      failures += verdict != "pass" && verdict != "skipped";
    }
    Statement insert = db_.prepare(
        "INSERT INTO regressions (id, suite, created_at, passed, failures, record) "
        "VALUES (?, ?, ?, ?, ?, ?)");
    insert.bind(1, std::string(id)).bind(2, record["suite"].get<std::string>()).bind(3, now);
    insert.bind(4, std::int64_t(record["passed"].get<bool>())).bind(5, std::int64_t(failures));
    insert.bind(6, record.dump());
    insert.run();
    return id;
  });
}

std::vector<RegressionEntry> Store::regressions(int limit, int offset, const std::string& suite) {
  Statement s = db_.prepare(
      "SELECT id, suite, created_at, passed, failures, record FROM regressions "
      "WHERE (?1 = '' OR suite = ?1) ORDER BY created_at DESC, id DESC LIMIT ?2 OFFSET ?3");
  s.bind(1, suite).bind(2, std::int64_t(limit)).bind(3, std::int64_t(offset));
  std::vector<RegressionEntry> out;
  while (s.step()) out.push_back(read_regression(s));
  return out;
}

std::optional<RegressionEntry> Store::regression(const std::string& id) {
  Statement s = db_.prepare(
      "SELECT id, suite, created_at, passed, failures, record FROM regressions WHERE id = ?");
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_regression(s);
}

Progress Store::progress(const std::string& study_id) {
  Progress p;
  Statement s = db_.prepare("SELECT state, COUNT(*) FROM runs WHERE study_id = ? GROUP BY state");
  s.bind(1, study_id);
  while (s.step()) {
    const int n = int(s.integer(1));
    p.total += n;
    if (auto state = run_state_from_name(s.text(0))) p.by_state[int(*state)] += n;
  }
  return p;
}

double Store::mean_wall_time_s(const std::string& study_id) {
  Statement s = db_.prepare(
      "SELECT COALESCE(AVG(wall_time_s), 0) FROM runs WHERE study_id = ? AND state = 'COMPLETE'");
  s.bind(1, study_id);
  return s.step() ? s.real(0) : 0.0;
}

std::string Store::change_signature(const std::string& study_id) {
  Statement s = db_.prepare(
      "SELECT COUNT(*), SUM(attempts), MAX(finished_at), "
      "SUM(state = 'COMPLETE'), SUM(state = 'RUNNING'), SUM(state = 'QUEUED'), "
      "(SELECT canceled FROM studies WHERE id = ?1) FROM runs WHERE study_id = ?1");
  s.bind(1, study_id);
  if (!s.step()) return "";
  std::string signature;
  for (int c = 0; c < 7; ++c) signature += s.text(c) + "/";
  return signature;
}

}  // namespace millsim
