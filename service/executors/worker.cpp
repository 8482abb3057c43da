#include "executors/worker.h"

#include <httplib.h>
#include <unistd.h>

#include <thread>
#include <vector>

#include "core/errors.h"

namespace millsim {
namespace {

using nlohmann::json;

class ServerLink {
 public:
  explicit ServerLink(const WorkerConfig& c) : client_(c.server), token_(c.token) {
    client_.set_connection_timeout(30);
    client_.set_read_timeout(30);
    client_.set_tcp_nodelay(true);  // heartbeats are small requests: no Nagle delay
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
  r.threads = run.value("threads", 1);
  if (run.contains("slurm")) r.slurm = SlurmOptions::from_json(run["slurm"]);
  if (run.contains("files_root") && run["files_root"].is_string())
    r.files_root = run["files_root"].get<std::string>();
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

namespace {

struct ActiveRun {
  RunRecord run;
  std::int64_t token = 0;
  double lease_s = 30.0;
  ExecHandle handle;
  double last_beat = 0.0;
  bool stopped_by_worker = false;
};

}  // namespace

int run_worker(const WorkerConfig& config, Executor& executor, const std::atomic<bool>& stop) {
  ServerLink link(config);
  char host[256] = "host";
  gethostname(host, sizeof host - 1);
  const std::string name =
      config.name.empty() ? std::string(host) + "-" + std::to_string(getpid()) : config.name;
  int executed = 0, unreachable = 0;
  bool queue_empty = false;
  std::vector<ActiveRun> active;
  while (true) {
    // Claim while there is a free slot (and we are not stopping).
    while (!stop && int(active.size()) < std::max(1, config.slots)) {
      json claim;
      const int status = link.post("/v1/worker/claim", {{"worker", name}}, claim);
      if (status == 0 || status >= 500) {
        if (++unreachable > 20 || (executed == 0 && active.empty() && unreachable > 10))
          throw IoError("the server at " + config.server + " does not answer");
        break;
      }
      unreachable = 0;
      if (status == 401) throw IoError("the server refused the worker's token (401)");
      if (status == 204) {
        queue_empty = true;
        break;
      }
      if (status != 200) throw IoError(concat("unexpected answer to a claim: HTTP ", status));
      queue_empty = false;
      ActiveRun a;
      a.run = record_from(claim["run"]);
      a.token = claim["token"].get<std::int64_t>();
      a.lease_s = claim["lease_s"].get<double>();
      const double now = wall_clock_s();
      a.last_beat = now;
      try {
        a.handle = executor.start(a.run, now);
      } catch (const std::exception& e) {
        FinishReport failed;
        failed.state = RunState::SystemError;
        failed.retryable = true;
        failed.error = std::string("the worker could not start it: ") + e.what();
        json ignored;
        link.post("/v1/worker/runs/" + a.run.id + "/finish", report_json(failed, a.token), ignored);
        continue;
      }
      active.push_back(std::move(a));
    }
    // Watch the running ones.
    for (std::size_t k = 0; k < active.size();) {
      ActiveRun& a = active[k];
      const double now = wall_clock_s();
      if (std::optional<ChildExit> done = executor.poll(a.handle, now)) {
        FinishReport report = report_from_exit(*done, a.handle.out_dir);
        if (a.stopped_by_worker) {  // not the user's cancel: back to the queue
          report.state = RunState::SystemError;
          report.retryable = true;
          report.error = "the worker was stopped during the run";
        }
        json ignored;
        link.post("/v1/worker/runs/" + a.run.id + "/finish", report_json(report, a.token), ignored);
        ++executed;
        active.erase(active.begin() + std::ptrdiff_t(k));
        continue;
      }
      if (now - a.last_beat > a.lease_s / 3.0) {
        a.last_beat = now;
        json ignored;
        if (link.post("/v1/worker/runs/" + a.run.id + "/heartbeat", {{"token", a.token}},
                      ignored) == 409)
          executor.cancel(a.handle, now);  // canceled, or the lease was lost
      }
      if (stop && !a.handle.canceled) a.stopped_by_worker = true, executor.cancel(a.handle, now);
      ++k;
    }
    if (active.empty() && (stop || (config.until_empty && queue_empty))) break;
    // Wait long only when there is nothing to do; a free slot with work queued claims again soon.
    const bool idle = active.empty() && (queue_empty || unreachable > 0);
    std::this_thread::sleep_for(std::chrono::duration<double>(idle ? config.idle_poll_s : 0.02));
  }
  return executed;
}

}  // namespace millsim
