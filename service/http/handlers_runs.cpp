// The handlers of runs (state, log tail and attempts, PSD, run.h5, result.json) and of the
// regression history.
#include <fstream>
#include <memory>
#include <vector>

#include "core/errors.h"
#include "executors/executor.h"
#include "http/handlers.h"
#include "process/impact_spectrum_plot.h"
#include "regression/regression.h"
#include "studies/results.h"

namespace millsim {

using httplib::Request;
using httplib::Response;
using nlohmann::json;
using nlohmann::ordered_json;

namespace {

bool with_run(ApiState& api, const Request& req, Response& res, std::optional<RunRecord>& out) {
  const std::string id = req.matches[1];
  if (is_run_id(id)) out = api.store->run(id);
  if (!out) send_error(res, 404, "not_found", "no run \"" + id + "\"");
  return out.has_value();
}

// A run that exists and is COMPLETE (404 or 409 otherwise; `what` names what it lacks).
bool with_complete_run(ApiState& api, const Request& req, Response& res,
                       std::optional<RunRecord>& out, const char* what) {
  if (!with_run(api, req, res, out)) return false;
  if (out->state == RunState::Complete) return true;
  send_error(res, 409, "not_complete",
             "run " + out->id + " is " + std::string(run_state_name(out->state)) + "; its " + what +
                 " exists once it is COMPLETE");
  return false;
}

}  // namespace

void get_run(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<RunRecord> r;
  if (!with_run(api, req, res, r)) return;
  ordered_json body = run_json(*r, false);
  body["log_tail"] = tail_of_file(std::filesystem::path(r->out_dir) / "log.txt", 40);
  ordered_json history = ordered_json::array();
  for (const AttemptRecord& a : api.store->attempts(r->id))
    history.push_back(
        {{"attempt", a.attempt},
         {"worker", a.worker},
         {"started_at", a.started_at},
         {"finished_at", a.finished_at},
         {"state", a.state},
         {"exit_code", a.exit_code ? ordered_json(*a.exit_code) : ordered_json()},
         {"error", a.error},
         {"resumed_from_s", a.resumed_from_s ? ordered_json(*a.resumed_from_s) : ordered_json()}});
  body["attempt_history"] = history;
  send_json(res, 200, body);
}

void get_run_psd(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<RunRecord> r;
  if (!with_complete_run(api, req, res, r, "PSD")) return;
  const json result = json::parse(r->result);
  if (!result.contains("outlet_psd"))
    return send_error(res, 404, "no_psd",
                      "run " + r->id + "'s scene has no outlets or breakage, so no PSD");
  send_json(res, 200, {{"run", r->id}, {"outlet_psd", result["outlet_psd"]}});
}

void get_run_h5(ApiState& api, const Request& req, Response& res) {
  std::optional<RunRecord> r;
  {
    std::lock_guard<std::mutex> lock(api.store_mutex);
    if (!with_run(api, req, res, r)) return;
  }
  const std::filesystem::path file = std::filesystem::path(r->out_dir) / "run.h5";
  std::error_code ec;
  const auto size = std::filesystem::file_size(file, ec);
  if (ec) return send_error(res, 404, "no_h5", "run " + r->id + " has no run.h5");
  auto stream = std::make_shared<std::ifstream>(file, std::ios::binary);
  res.set_content_provider(
      size, "application/x-hdf5",
      [stream](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
        std::vector<char> buffer(std::min<std::size_t>(length, 1 << 16));
        stream->seekg(std::streamoff(offset));
        stream->read(buffer.data(), std::streamsize(buffer.size()));
        sink.write(buffer.data(), std::size_t(stream->gcount()));
        return stream->gcount() > 0;
      });
}

void get_run_impact_spectrum_plot(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<RunRecord> r;
  if (!with_complete_run(api, req, res, r, "impact spectrum")) return;
  const json result = json::parse(r->result);
  const std::string svg = result.contains("impact_spectrum")
                              ? impact_spectrum_svg(result["impact_spectrum"], r->id)
                              : std::string();
  if (svg.empty())
    return send_error(res, 404, "no_impact_spectrum",
                      "run " + r->id +
                          " has no impact spectrum (no impacts counted: the scene "
                          "breaks nothing and output.impact_spectrum is off, or nothing collided)");
  res.status = 200;
  res.set_content(svg, "image/svg+xml");
}

void get_run_result(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<RunRecord> r;
  if (!with_complete_run(api, req, res, r, "result")) return;
  send_json(res, 200, ordered_json::parse(r->result));
}

void post_regression(ApiState& api, const Request& req, Response& res) {
  json record;
  if (!parse_body(req, res, record)) return;
  const InputErrors errors = validate_regression_record(record);
  if (!errors.empty()) {
    ordered_json details = ordered_json::array();
    for (const InputError& err : errors)
      details.push_back({{"path", err.path}, {"value", err.value}, {"allowed", err.allowed}});
    return send_error(res, 400, "invalid_regression",
                      concat(errors.size(), " problem(s) in the record; nothing stored"), details);
  }
  // The server's clock dates a record, not the client's (whatever the body said).
  const double now = wall_clock_s();
  record["created_at"] = now;
  record["created"] = iso_utc(now);
  std::lock_guard<std::mutex> lock(api.store_mutex);
  const std::string id = api.store->add_regression(record, now);
  send_json(res, 201, {{"id", id}});
}

void list_regressions(ApiState& api, const Request& req, Response& res) {
  int limit = 0, offset = 0;
  if (!query_int(req, res, "limit", 100, 1, 1000, limit) ||
      !query_int(req, res, "offset", 0, 0, 1 << 30, offset))
    return;
  const std::string suite = req.has_param("suite") ? req.get_param_value("suite") : "";
  const std::string check = req.has_param("check") ? req.get_param_value("check") : "";
  std::lock_guard<std::mutex> lock(api.store_mutex);
  ordered_json list = ordered_json::array();
  for (const RegressionEntry& e : api.store->regressions(limit, offset, suite)) {
    const ordered_json record = ordered_json::parse(e.record);
    ordered_json item = {{"id", e.id},
                         {"suite", e.suite},
                         {"created_at", e.created_at},
                         {"created", record.value("created", "")},
                         {"passed", e.passed},
                         {"failures", e.failures},
                         {"build", record["build"]}};
    if (!check.empty()) {  // that check's rows, for its history across nights
      ordered_json rows = ordered_json::array();
      for (const ordered_json& row : record["rows"])
        if (row.value("check", "") == check) rows.push_back(row);
      item["rows"] = rows;
    }
    list.push_back(item);
  }
  send_json(res, 200, {{"regressions", list}, {"limit", limit}, {"offset", offset}});
}

void get_regression(ApiState& api, const Request& req, Response& res) {
  const std::string id = req.matches[1];
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<RegressionEntry> e;
  if (is_regression_id(id)) e = api.store->regression(id);
  if (!e) return send_error(res, 404, "not_found", "no regression run \"" + id + "\"");
  ordered_json record = ordered_json::parse(e->record);
  record["id"] = e->id;
  send_json(res, 200, record);
}

}  // namespace millsim
