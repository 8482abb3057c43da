#include "worker.h"

#include <httplib.h>
#include <unistd.h>

#include <thread>

#include "core/errors.h"

namespace millsim {
namespace {

using nlohmann::json;

class ServerLink {
 public:
  explicit ServerLink(const WorkerConfig& c) : client_(c.server), token_(c.token) {
    client_.set_connection_timeout(5);
    client_.set_read_timeout(30);
  }

  // POST; returns the status (0 when unreachable) and the parsed body.
  int post(const std::string& path, const json& body, json& out) {
    const httplib::Headers headers = {{"Authorization", "Bearer " + token_}};
    auto res = client_.Post(path.c_str(), headers, body.dump(), "application/json");
    if (!res) return 0;
    out = res->body.empty() ? json() : json::parse(res->body, nullptr, false);
    return res->status;
  }

 private:
  httplib::Client client_;
  std::string token_;
};

RunRecord record_from(const json& run) {
  RunRecord r;
  r.id = run.at("id").get<std::string>();
  r.study_id = run.at("study").get<std::string>();
  r.scene = run.at("scene").dump();
  r.out_dir = run.at("out_dir").get<std::string>();
  r.wall_limit_s = run.at("wall_limit_s").get<double>();
  r.memory_limit_mb = run.at("memory_limit_mb").get<double>();
  return r;
}

json report_json(const FinishReport& r, std::int64_t token) {
  return {
      {"token", token},           {"state", std::string(run_state_name(r.state))},
      {"retryable", r.retryable}, {"exit_code", r.exit_code ? json(*r.exit_code) : json(nullptr)},
      {"error", r.error},         {"wall_time_s", r.wall_time_s},
      {"result", r.result}};
}

}  // namespace

int run_worker(const WorkerConfig& config, Executor& executor, const std::atomic<bool>& stop) {
  ServerLink link(config);
  char host[256] = "host";
  gethostname(host, sizeof host - 1);
  const std::string name =
      config.name.empty() ? std::string(host) + "-" + std::to_string(getpid()) : config.name;
  int executed = 0;
  int unreachable = 0;
  while (!stop) {
    json claim;
    const int status = link.post("/v1/worker/claim", {{"worker", name}}, claim);
    if (status == 0 || status >= 500) {
      if (++unreachable > 20 || (executed == 0 && unreachable > 10))
        throw IoError("the server at " + config.server + " does not answer");
      std::this_thread::sleep_for(std::chrono::duration<double>(config.idle_poll_s));
      continue;
    }
    unreachable = 0;
    if (status == 401) throw IoError("the server refused the worker's token (401)");
    if (status == 204) {
      if (config.until_empty) break;
      std::this_thread::sleep_for(std::chrono::duration<double>(config.idle_poll_s));
      continue;
    }
    if (status != 200) throw IoError(concat("unexpected answer to a claim: HTTP ", status));

    const RunRecord run = record_from(claim["run"]);
    const std::int64_t token = claim["token"].get<std::int64_t>();
    const double lease_s = claim["lease_s"].get<double>();
    FinishReport report;
    try {
      ExecHandle handle = executor.start(run, wall_clock_s());
      double last_beat = wall_clock_s();
      std::optional<ChildExit> done;
      bool stopped_by_worker = false;
      while (!(done = executor.poll(handle, wall_clock_s()))) {
        const double now = wall_clock_s();
        if (now - last_beat > lease_s / 3.0) {
          last_beat = now;
          json ignored;
          const int beat =
              link.post("/v1/worker/runs/" + run.id + "/heartbeat", {{"token", token}}, ignored);
          if (beat == 409) executor.cancel(handle, now);  // canceled, or the lease was lost
        }
        if (stop && !handle.canceled) stopped_by_worker = true, executor.cancel(handle, now);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      report = report_from_exit(*done, handle.out_dir);
      if (stopped_by_worker) {  // not the user's cancel: the run goes back to the queue
        report.state = RunState::SystemError;
        report.retryable = true;
        report.error = "the worker was stopped during the run";
      }
    } catch (const std::exception& e) {
      report.state = RunState::SystemError;
      report.retryable = true;
      report.error = std::string("the worker could not run it: ") + e.what();
    }
    json ignored;
    link.post("/v1/worker/runs/" + run.id + "/finish", report_json(report, token), ignored);
    ++executed;
  }
  return executed;
}

}  // namespace millsim
