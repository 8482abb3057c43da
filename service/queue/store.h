// The service's queue and log: one SQLite file (WAL) holding studies, their runs and every
// attempt, with a versioned schema migrated on open. Only the process that owns the Store
// writes (the server, or `millsim study --local`); workers reach it through that process.
// Claiming is atomic (one UPDATE … RETURNING inside BEGIN IMMEDIATE): two claimers never get the
// same run. A claim carries a lease and a fencing token; a report with a stale token is refused.
// A run whose lease expires is a system error of that attempt: it is queued again until
// max_attempts, then stays failed with its last error. Engine errors are never retried.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "queue/run_state.h"
#include "queue/sqlite_db.h"
#include "studies/study.h"

namespace millsim {

inline constexpr int kSchemaVersion = 5;

struct RunRecord {
  std::string id;
  std::string study_id;
  int index = 0;
  nlohmann::json params;
  std::uint64_t seed = 0;
  std::string scene;  // JSON text
  bool is_reference = false;
  RunState state = RunState::Queued;
  int attempts = 0;
  int max_attempts = 3;
  std::int64_t fencing_token = 0;
  std::optional<std::string> lease_owner;
  double lease_expires_at = 0.0;
  double created_at = 0.0, started_at = 0.0, finished_at = 0.0;
  std::optional<int> exit_code;
  std::string error;
  double wall_time_s = 0.0;
  std::string result;  // result.json text, when complete
  std::string out_dir;
  double wall_limit_s = 0.0, memory_limit_mb = 0.0;
  int threads = 1;     // `millsim run --threads` (the study's limits.threads_per_run)
  SlurmOptions slurm;  // the study's batch-job options (Slurm executor)
  // Where the run's file sources may lead: the server's scenes root, sent with a claim and
  // passed to `millsim run --files-root` (not stored; empty for a local study).
  std::string files_root;
};

struct StudyRecord {
  std::string id;
  std::string name;
  std::string spec;  // JSON text as submitted
  std::string error_metric;
  std::optional<std::string> reference_run;
  bool canceled = false;
  double created_at = 0.0;
};

// One regression run of the history (millsim regress): its record is the JSON of
// regression_record() (service/regression/regression.h).
struct RegressionEntry {
  std::string id;  // "g" and six digits
  std::string suite;
  double created_at = 0.0;
  bool passed = false;
  int failures = 0;
  std::string record;  // JSON text
};

struct Claim {
  RunRecord run;
  std::int64_t token = 0;
};

struct FinishReport {
  RunState state = RunState::Complete;  // Complete, ExecutorError, SystemError or Canceled
  bool retryable = false;               // a system error that may be tried again
  std::optional<int> exit_code;
  std::string error;
  double wall_time_s = 0.0;
  std::string result;  // result.json; its "resumed" section gives the attempt's resumed_from_s
};

// One attempt at a run, as the attempts table keeps it.
struct AttemptRecord {
  int attempt = 0;
  std::string worker;
  double started_at = 0.0, finished_at = 0.0;
  std::string state;
  std::optional<int> exit_code;
  std::string error;
  std::optional<double> resumed_from_s;
};

struct Progress {
  int total = 0;
  int by_state[7] = {};  // indexed by RunState
  int count(RunState s) const { return by_state[int(s)]; }
  bool finished() const;  // no run queued, running or canceling
};

class Store {
 public:
  // Opens (creating) the file and brings the schema to kSchemaVersion; throws DbError.
  explicit Store(const std::filesystem::path& path);

  int schema_version();

  // Inserts the study and all its runs in one transaction. With an idempotency key already
  // used, returns that study's id and inserts nothing (`created` false).
  struct Submitted {
    std::string study_id;
    bool created = true;
  };
  Submitted submit(const Study& study, const std::optional<std::string>& idempotency_key,
                   const std::filesystem::path& out_root, double now);

  // The next queued run (oldest study first, then index), leased to `worker` until now + lease.
  std::optional<Claim> claim(const std::string& worker, double lease_s, double now,
                             const std::optional<std::string>& study_id = std::nullopt);
  // Extends a lease; false when the token is stale or the run is no longer running (a CANCELING
  // run returns false too: the worker must stop its child).
  bool heartbeat(const std::string& run_id, std::int64_t token, double lease_s, double now);
  // Records the attempt's end; false when the token is stale (the report is ignored).
  bool finish(const std::string& run_id, std::int64_t token, const FinishReport& report,
              double now);
  // Expired leases become system errors of their attempt; returns how many runs it touched.
  int requeue_expired(double now);
  // Queued runs are canceled at once, running ones marked CANCELING for their worker.
  void cancel_study(const std::string& study_id, double now);

  std::optional<StudyRecord> study(const std::string& id);
  std::vector<StudyRecord> studies(int limit, int offset);  // newest first
  std::optional<RunRecord> run(const std::string& id);
  std::vector<AttemptRecord> attempts(const std::string& run_id);
  std::vector<RunRecord> runs(const std::string& study_id,
                              const std::optional<RunState>& state = std::nullopt,
                              int limit = 1000000, int offset = 0);
  Progress progress(const std::string& study_id);
  // Mean wall time of the study's completed runs (0 when none).
  double mean_wall_time_s(const std::string& study_id);
  // Appends a regression run to the history (one transaction); returns its id.
  std::string add_regression(const nlohmann::json& record, double now);
  // Newest first; only `suite`'s when it is not empty.
  std::vector<RegressionEntry> regressions(int limit, int offset, const std::string& suite = "");
  std::optional<RegressionEntry> regression(const std::string& id);

  // Changes whenever a run of the study changes state or finishes (for caches).
  std::string change_signature(const std::string& study_id);

 private:
  void migrate();
  Database db_;
};

std::optional<RunState> run_state_from_name(std::string_view name);

}  // namespace millsim
