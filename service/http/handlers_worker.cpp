// The worker protocol: claim a run with a lease, keep it with heartbeats, report it finished;
// every call after the claim carries the run's fencing token, so a worker whose lease was lost
// cannot change the run.
#include <filesystem>
#include <stdexcept>

#include "executors/executor.h"
#include "http/handlers.h"

namespace millsim {

using httplib::Request;
using httplib::Response;
using nlohmann::json;
using nlohmann::ordered_json;

void worker_claim(ApiState& api, const Request& req, Response& res) {
  json body;
  if (!parse_body(req, res, body)) return;
  if (!body.is_object() || (body.contains("worker") && !body["worker"].is_string()))
    return send_error(res, 400, "invalid_body", "expected {\"worker\": string}");
  const std::string worker = body.value("worker", std::string("worker"));
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<Claim> c = api.store->claim(worker, api.config.lease_s, wall_clock_s());
  if (!c) {
    res.status = 204;
    return;
  }
  c->run.files_root = std::filesystem::absolute(api.config.scenes_root).lexically_normal();
  send_json(
      res, 200,
      {{"run", run_json(c->run, true)}, {"token", c->token}, {"lease_s", api.config.lease_s}});
}

void worker_heartbeat(ApiState& api, const Request& req, Response& res) {
  json body;
  if (!parse_body(req, res, body)) return;
  if (!body.contains("token") || !body["token"].is_number_integer())
    return send_error(res, 400, "invalid_body", "expected {\"token\": integer}");
  std::lock_guard<std::mutex> lock(api.store_mutex);
  if (!api.store->heartbeat(req.matches[1], body["token"].get<std::int64_t>(), api.config.lease_s,
                            wall_clock_s()))
    return send_error(res, 409, "lease_lost",
                      "the run was canceled or given to another worker: stop it");
  send_json(res, 200, {{"lease_s", api.config.lease_s}});
}

void worker_finish(ApiState& api, const Request& req, Response& res) {
  json body;
  if (!parse_body(req, res, body)) return;
  FinishReport report;
  try {
    const std::optional<RunState> state = run_state_from_name(body.at("state").get<std::string>());
    if (!state) throw std::invalid_argument("state");
    report.state = *state;
    report.retryable = body.value("retryable", false);
    if (body.contains("exit_code") && body["exit_code"].is_number_integer())
      report.exit_code = body["exit_code"].get<int>();
    report.error = body.value("error", std::string());
    report.wall_time_s = body.value("wall_time_s", 0.0);
    report.result = body.value("result", std::string());
    const std::int64_t token = body.at("token").get<std::int64_t>();
    std::lock_guard<std::mutex> lock(api.store_mutex);
    if (!api.store->finish(req.matches[1], token, report, wall_clock_s()))
      return send_error(res, 409, "lease_lost",
                        "stale token: this attempt's report was not recorded");
  } catch (const std::exception&) {
    return send_error(res, 400, "invalid_body",
                      "expected {token, state, retryable, exit_code, error, "
                      "wall_time_s, result}");
  }
  send_json(res, 200, {{"recorded", true}});
}

}  // namespace millsim
