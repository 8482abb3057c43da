// millsim regress SUITE [--local | --server URL] [--token-file FILE] [--db FILE] [--out DIR]
//                       [--workers N] [--junit FILE] [--format table|json] [--update-baseline]
// millsim regress --history CHECK[/QUANTITY] [--suite NAME] [--db FILE | --server URL]
// Runs a regression suite (docs/regression.md) through the same queue and workers as studies:
// every check is a study, on this machine (the SQLite file --db) or on a server. Compares what
// they measured with the suite's baseline, prints the drift table, records the regression run in
// the history (the same SQLite file, or the server's through POST /v1/regressions) and writes
// JUnit XML on request. --update-baseline writes a new baseline from this run and prints what
// changed; nothing else writes a baseline.
// Exit 0 when every quantity passes, 1 on any drift or failed run, 2 for a bad suite or bad
// options (every problem listed), 4 when the database, the disk or the server fails.
#include <unistd.h>

#include <httplib.h>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>

#include "build_info.h"
#include "cli_args.h"
#include "commands.h"
#include "executors/local_runner.h"
#include "executors/slurm_executor.h"
#include "io/text_file.h"
#include "regression/regression.h"
#include "studies/results.h"

namespace millsim::cli {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;

constexpr int kMaxRunsPerCheck = 1000;

struct RegressArgs {
  std::string suite_path;
  bool local = false;
  std::string server, token;
  std::string db = "out/millsim.db";
  std::string out = "out/regress";
  int workers = 0;
  std::string junit;
  std::string format = "table";
  bool update_baseline = false;
  std::string history;     // CHECK or CHECK/QUANTITY
  std::string suite_name;  // --suite, with --history
  std::string executor = "local";
};

constexpr const char* kUsage =
    "usage: millsim regress SUITE.json [--local | --server URL] [--token-file FILE] [--db FILE]\n"
    "                       [--out DIR] [--workers N] [--executor local|slurm]\n"
    "                       [--junit FILE] [--format table|json] [--update-baseline]\n"
    "       millsim regress --history CHECK[/QUANTITY] [--suite NAME] [--db FILE | --server "
    "URL]\n";

bool parse_args(const std::vector<std::string>& args, RegressArgs& a) {
  if (const char* t = std::getenv("MILLSIM_TOKEN")) a.token = t;
  ArgReader r("regress", args);
  while (r.next()) {
    if (r.option("--server", a.server) || r.token_option(a.token) || r.option("--db", a.db) ||
        r.option("--out", a.out) || r.option("--junit", a.junit) ||
        r.option("--format", a.format) || r.option("--history", a.history) ||
        r.option("--suite", a.suite_name) || r.option("--executor", a.executor) ||
        r.int_option("--workers", a.workers, 1, 1024) || r.positional(a.suite_path))
      continue;
    if (r.is_flag("--local")) {
      a.local = true;
      continue;
    }
    if (r.is_flag("--update-baseline")) {
      a.update_baseline = true;
      continue;
    }
    r.unknown(
        "--local, --server URL, --token-file FILE, --db FILE, --out DIR, --workers N, --executor "
        "local|slurm, --junit FILE, --format table|json, --update-baseline, --history CHECK, "
        "--suite NAME");
  }
  if (!r.ok()) return false;
  auto bad = [](const std::string& message) {
    std::fprintf(stderr, "millsim regress: %s\n%s", message.c_str(), kUsage);
    return false;
  };
  if (a.format != "table" && a.format != "json")
    return bad("--format = " + a.format + ": expected table or json");
  if (a.executor != "local" && a.executor != "slurm")
    return bad("--executor = " + a.executor + ": expected local or slurm");
  if (a.local && !a.server.empty()) return bad("give --local or --server URL, not both");
  if (a.history.empty() && a.suite_path.empty()) return bad("missing SUITE.json");
  if (!a.history.empty() && !a.suite_path.empty())
    return bad("--history shows past runs; give it without a suite file");
  if (!a.history.empty() && (a.update_baseline || !a.junit.empty()))
    return bad("--history takes neither --update-baseline nor --junit");
  return true;
}

// ---- the checks, on this machine ------------------------------------------------------------

// The attempt's error in one line: its first line ("exit status 3") and the log line that says
// why (the stability guard's "run stopped at step …", a validation error), when there is one.
std::string error_summary(const std::string& error) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < error.size()) {
    const std::size_t end = std::min(error.find('\n', start), error.size());
    const std::string line = error.substr(start, end - start);
    if (line.find_first_not_of(' ') != std::string::npos) lines.push_back(line);
    start = end + 1;
  }
  if (lines.empty()) return "";
  std::string out = lines[0];
  for (std::size_t k = 1; k < lines.size(); ++k)
    if (lines[k].find("stopped") != std::string::npos ||
        lines[k].find("error") != std::string::npos ||
        lines[k].find("expected") != std::string::npos) {
      out += ": " + lines[k].substr(lines[k].find_first_not_of(' '));
      break;
    }
  return out.size() > 400 ? out.substr(0, 400) + "..." : out;
}

std::string run_failure(const std::string& id, const std::string& state, const json& exit_code,
                        const std::string& error) {
  std::string text = "run " + id + " ended " + state;
  if (exit_code.is_number()) text += " (exit " + exit_code.dump() + ")";
  if (!error.empty()) text += ": " + error_summary(error);
  return text;
}

void print_progress(const Progress& p) {
  if (!isatty(STDERR_FILENO)) return;
  const int done = p.total - p.count(RunState::Queued) - p.count(RunState::Running) -
                   p.count(RunState::Canceling);
  std::fprintf(stderr, "\r[%d/%d] running %d, failed %d   ", done, p.total,
               p.count(RunState::Running),
               p.count(RunState::ExecutorError) + p.count(RunState::SystemError));
}

std::map<std::string, CheckOutcome> run_locally(const RegressionSuite& suite, Store& store,
                                                const RegressArgs& a,
                                                std::map<std::string, std::string>& studies) {
  const std::filesystem::path out_root = std::filesystem::absolute(a.out);
  std::vector<std::string> ids;
  for (const RegressionCheck& check : suite.checks) {
    ids.push_back(store.submit(check.study, std::nullopt, out_root, wall_clock_s()).study_id);
    studies[check.name] = ids.back();
  }
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
  const std::unique_ptr<Executor> executor = make_executor(a.executor, self);
  LocalRunOptions options;
  options.workers =
      a.workers > 0 ? a.workers : int(std::max(1u, std::thread::hardware_concurrency()));
  options.on_progress = print_progress;
  run_studies_locally(store, ids, *executor, options);
  if (isatty(STDERR_FILENO)) std::fprintf(stderr, "\n");

  std::map<std::string, CheckOutcome> outcomes;
  for (std::size_t i = 0; i < suite.checks.size(); ++i) {
    const RegressionCheck& check = suite.checks[i];
    CheckOutcome& o = outcomes[check.name];
    o.ok = true;
    for (const RunRecord& run : store.runs(ids[i]))
      if (run.state != RunState::Complete && o.ok) {
        o.ok = false;
        o.failure = run_failure(run.id, std::string(run_state_name(run.state)),
                                run.exit_code ? json(*run.exit_code) : json(), run.error);
      }
    if (!o.ok) continue;
    if (check.is_study) {
      o.document = results_table(store, ids[i]);
    } else {
      for (const RunRecord& run : store.runs(ids[i])) {  // in seed order
        json document = json::parse(run.result, nullptr, false);
        if (document.is_discarded()) {
          o.ok = false;
          o.failure = "run " + run.id + ": its result.json is not valid JSON";
          break;
        }
        o.run_documents.push_back(std::move(document));
      }
    }
  }
  return outcomes;
}

// ---- the checks, through a server -----------------------------------------------------------

class Remote {
 public:
  explicit Remote(const RegressArgs& a) : client_(a.server), token_(a.token), server_(a.server) {
    client_.set_connection_timeout(30);
    client_.set_read_timeout(60);
    client_.set_tcp_nodelay(true);
  }
  // The reply's JSON; throws IoError for an unreachable server or any status >= 300.
  json call(const std::string& method, const std::string& path, const std::string& body = "") {
    httplib::Headers headers;
    if (!token_.empty()) headers.emplace("Authorization", "Bearer " + token_);
    auto res = method == "GET" ? client_.Get(path.c_str(), headers)
                               : client_.Post(path.c_str(), headers, body, "application/json");
    if (!res)
      throw IoError("cannot reach the server at " + server_ + " (" +
                    httplib::to_string(res.error()) + ")");
    json parsed = json::parse(res->body, nullptr, false);
    if (res->status >= 300) {
      std::string message = method + " " + path + ": HTTP " + std::to_string(res->status);
      if (parsed.is_object() && parsed.contains("error")) {
        message += ": " + parsed["error"].value("message", "");
        if (parsed["error"].contains("details"))
          for (const json& d : parsed["error"]["details"])
            message += "\n  " + d.value("path", "") + " = " + d.value("value", "") + ": " +
                       d.value("allowed", "");
      }
      throw IoError(message);
    }
    return parsed;
  }

 private:
  httplib::Client client_;
  std::string token_, server_;
};

std::map<std::string, CheckOutcome> run_on_server(const RegressionSuite& suite, Remote& remote,
                                                  std::map<std::string, std::string>& studies) {
  for (const RegressionCheck& check : suite.checks)
    studies[check.name] =
        remote.call("POST", "/v1/studies", check.submit_spec.dump())["study"].get<std::string>();
  for (const auto& [name, id] : studies)
    while (!remote.call("GET", "/v1/studies/" + id)["progress"]["finished"].get<bool>())
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
  std::map<std::string, CheckOutcome> outcomes;
  for (const RegressionCheck& check : suite.checks) {
    const std::string& id = studies[check.name];
    CheckOutcome& o = outcomes[check.name];
    o.ok = true;
    const json runs = remote.call("GET", "/v1/studies/" + id + "/runs?limit=1000")["runs"];
    for (const json& run : runs)
      if (run["state"] != "COMPLETE" && o.ok) {
        o.ok = false;
        o.failure = run_failure(run["id"].get<std::string>(), run["state"].get<std::string>(),
                                run["exit_code"], run.value("error", ""));
      }
    if (!o.ok) continue;
    if (check.is_study) {
      o.document = remote.call("GET", "/v1/studies/" + id + "/results");
      continue;
    }
    for (const json& run : runs)  // in seed order
      o.run_documents.push_back(
          remote.call("GET", "/v1/runs/" + run["id"].get<std::string>() + "/result"));
  }
  return outcomes;
}

// ---- the history ----------------------------------------------------------------------------

int show_history(const RegressArgs& a) {
  const std::size_t slash = a.history.find('/');
  const std::string check = a.history.substr(0, slash);
  const std::string quantity = slash == std::string::npos ? "" : a.history.substr(slash + 1);
  std::vector<json> records;  // oldest first
  if (!a.server.empty()) {
    Remote remote(a);
    std::string path =
        "/v1/regressions?limit=1000&check=" + httplib::detail::encode_query_param(check);
    if (!a.suite_name.empty())
      path += "&suite=" + httplib::detail::encode_query_param(a.suite_name);
    const json list = remote.call("GET", path)["regressions"];
    for (auto it = list.rbegin(); it != list.rend(); ++it) records.push_back(*it);
  } else {
    if (!std::filesystem::exists(a.db)) {
      std::fprintf(stderr, "millsim regress: no history: %s does not exist\n", a.db.c_str());
      return kBadInput;
    }
    Store store(a.db);
    const std::vector<RegressionEntry> list = store.regressions(1000000, 0, a.suite_name);
    for (auto it = list.rbegin(); it != list.rend(); ++it) {
      json record = json::parse(it->record);
      record["id"] = it->id;
      records.push_back(std::move(record));
    }
  }
  ordered_json rows = ordered_json::array();
  for (const json& record : records)
    for (const json& row : record["rows"])
      if (row.value("check", "") == check &&
          (quantity.empty() || row.value("quantity", "") == quantity))
        rows.push_back({{"regression", record.value("id", "")},
                        {"created", record.value("created", "")},
                        {"git_commit", record["build"].value("git_commit", "")},
                        {"quantity", row["quantity"]},
                        {"measured", row["measured"]},
                        {"measured_sd", row.value("measured_sd", json())},
                        {"reference", row["reference"]},
                        {"verdict", row["verdict"]}});
  if (rows.empty()) {
    std::fprintf(stderr, "millsim regress: no recorded quantity of check \"%s\"%s\n",
                 a.history.c_str(),
                 a.suite_name.empty() ? "" : (" in suite " + a.suite_name).c_str());
    return kBadInput;
  }
  if (a.format == "json") {
    std::cout << rows.dump(2) << std::endl;
    return kOk;
  }
  std::printf("%-8s %-20s %-20s %-28s %-15s %-15s %s\n", "id", "created", "commit", "quantity",
              "measured", "reference", "verdict");
  for (const ordered_json& r : rows) {
    auto num = [](const ordered_json& v) {
      char text[32] = "-";
      if (v.is_number()) std::snprintf(text, sizeof text, "%.9g", v.get<double>());
      return std::string(text);
    };
    // A mean over a check's repeats shows their spread, as in the drift table.
    const std::string measured =
        num(r["measured"]) + (r["measured_sd"].is_number() ? " sd " + num(r["measured_sd"]) : "");
    std::printf("%-8s %-20s %-20s %-28s %-15s %-15s %s\n",
                r["regression"].get<std::string>().c_str(), r["created"].get<std::string>().c_str(),
                r["git_commit"].get<std::string>().c_str(),
                r["quantity"].get<std::string>().c_str(), measured.c_str(),
                num(r["reference"]).c_str(), r["verdict"].get<std::string>().c_str());
  }
  return kOk;
}

}  // namespace

int cmd_regress(const std::vector<std::string>& args) {
  RegressArgs a;
  if (!parse_args(args, a)) return kBadInput;
  try {
    if (!a.history.empty()) return show_history(a);

    RegressionSuite suite;
    try {
      suite = load_regression_suite(a.suite_path, kMaxRunsPerCheck);
    } catch (const InputErrorList& e) {
      std::fprintf(stderr, "%s", format_input_errors(a.suite_path, e.errors()).c_str());
      return kBadInput;
    }
    json baseline = nullptr;
    if (std::filesystem::exists(suite.baseline_path)) {
      try {
        baseline = read_json_file(suite.baseline_path, suite.baseline_path.string());
      } catch (const InputErrorList& e) {
        std::fprintf(stderr, "%s", format_input_errors(a.suite_path, e.errors()).c_str());
        return kBadInput;
      }
      if (!baseline.is_object() || !baseline.contains("values") ||
          !baseline["values"].is_object()) {
        std::fprintf(stderr, "millsim regress: %s: not a baseline (no \"values\" object)\n",
                     suite.baseline_path.c_str());
        return kBadInput;
      }
    }
    const json build = build_description();
    std::fprintf(stderr, "millsim regress: suite %s, %zu checks\n", suite.name.c_str(),
                 suite.checks.size());

    std::map<std::string, std::string> studies;
    std::map<std::string, CheckOutcome> outcomes;
    std::optional<Remote> remote;
    std::optional<Store> store;
    if (!a.server.empty()) {
      remote.emplace(a);
      outcomes = run_on_server(suite, *remote, studies);
    } else {
      const std::filesystem::path db_dir = std::filesystem::path(a.db).parent_path();
      if (!db_dir.empty()) std::filesystem::create_directories(db_dir);
      store.emplace(a.db);
      outcomes = run_locally(suite, *store, a, studies);
    }

    const double now = wall_clock_s();
    const std::vector<RegressionRow> rows = compare_with_baseline(suite, outcomes, baseline, build);
    ordered_json record =
        regression_record(suite, rows, baseline, build, now, a.update_baseline, studies);
    const std::string id =
        remote ? remote->call("POST", "/v1/regressions", record.dump())["id"].get<std::string>()
               : store->add_regression(record, now);
    record["id"] = id;
    if (a.format == "json")
      std::cout << record.dump(2) << std::endl;
    else
      std::cout << drift_table_text(record) << "recorded as " << id << "\n";
    if (!a.junit.empty()) write_text_atomically(a.junit, junit_xml(record));

    if (a.update_baseline) {
      for (const auto& [name, outcome] : outcomes)
        if (!outcome.ok) {
          std::fprintf(stderr,
                       "millsim regress: the baseline was not updated: check %s failed (%s)\n",
                       name.c_str(), outcome.failure.c_str());
          return kUnexpected;
        }
      const ordered_json next = make_baseline(suite, outcomes, build, iso_utc(now));
      const std::string changes = baseline_changes(baseline, next);
      write_text_atomically(suite.baseline_path, next.dump(2) + "\n");
      std::fprintf(stderr, "millsim regress: baseline %s written%s\n%s",
                   suite.baseline_path.c_str(), changes.empty() ? " (no value changed)" : ":",
                   changes.c_str());
      return kOk;
    }
    return record["passed"].get<bool>() ? kOk : kUnexpected;
  } catch (const DbError& e) {
    std::fprintf(stderr, "millsim regress: %s\n", e.what());
    return kEnvironment;
  } catch (const IoError& e) {
    std::fprintf(stderr, "millsim regress: %s\n", e.what());
    return kEnvironment;
  }
}

}  // namespace millsim::cli
