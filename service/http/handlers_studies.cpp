// The handlers of studies: health and info, the spec, submitting, listing, following and
// canceling a study, its results table and plots.
#include <algorithm>

#include "core/errors.h"
#include "executors/executor.h"
#include "http/handlers.h"
#include "parallel/thread_team.h"
#include "sim/run.h"
#include "studies/results.h"
#include "studies/study.h"

namespace millsim {

extern const char* const kOpenApiYaml;  // docs/openapi.yaml (generated openapi_yaml.cpp)

using httplib::Request;
using httplib::Response;
using nlohmann::json;
using nlohmann::ordered_json;

namespace {

ordered_json progress_json(const Progress& p, double mean_wall_s, int workers) {
  ordered_json counts = ordered_json::object();
  for (int s = 0; s <= int(RunState::Canceled); ++s)
    counts[std::string(run_state_name(RunState(s)))] = p.by_state[s];
  const int left = p.count(RunState::Queued) + p.count(RunState::Running);
  return {{"total", p.total},
          {"counts", counts},
          {"finished", p.finished()},
          {"eta_s", mean_wall_s > 0 ? ordered_json(mean_wall_s * left / std::max(1, workers))
                                    : ordered_json(nullptr)}};
}

// Scene paths in submitted studies must stay under the server's scenes root.
bool scene_path_allowed(const json& spec, std::string& problem) {
  if (!spec.is_object() || !spec.contains("scene") || !spec["scene"].is_string()) return true;
  const std::filesystem::path p = spec["scene"].get<std::string>();
  if (p.is_absolute()) {
    problem = "the scene path must be relative to the server's scenes root";
    return false;
  }
  for (const auto& part : p)
    if (part == "..") {
      problem = "the scene path must not leave the server's scenes root (no \"..\")";
      return false;
    }
  return true;
}

ordered_json study_summary(ApiState& api, const StudyRecord& st) {
  const Progress p = api.store->progress(st.id);
  const double mean_wall = api.store->mean_wall_time_s(st.id);
  return ordered_json{
      {"id", st.id},
      {"name", st.name},
      {"created_at", st.created_at},
      {"canceled", st.canceled},
      {"reference_run", st.reference_run ? ordered_json(*st.reference_run) : ordered_json(nullptr)},
      {"error_metric", st.error_metric},
      {"progress", progress_json(p, mean_wall, std::max(1, api.config.workers))}};
}

// Resolves {id} of a study route; 404 for an unknown or malformed id.
bool with_study(ApiState& api, const Request& req, Response& res, std::optional<StudyRecord>& out) {
  const std::string id = req.matches[1];
  if (is_study_id(id)) out = api.store->study(id);
  if (!out) send_error(res, 404, "not_found", "no study \"" + id + "\"");
  return out.has_value();
}

}  // namespace

void get_health(ApiState&, const Request&, Response& res) {
  send_json(res, 200, {{"status", "ok"}});
}

void get_info(ApiState& api, const Request&, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  send_json(res, 200,
            {{"millsim_version", kMillsimVersion},
             {"schema_version", api.store->schema_version()},
             {"workers", api.config.workers},
             {"worker_port", api.worker_port >= 0 ? json(api.worker_port) : json(nullptr)},
             {"limits",
              {{"max_body_bytes", api.config.max_body_bytes},
               {"max_runs_per_study", api.config.max_runs_per_study},
               {"max_study_bytes", api.config.max_study_bytes},
               {"lease_s", api.config.lease_s},
               {"max_connections", api.config.limits.max_connections},
               {"max_connections_per_client", api.config.limits.max_connections_per_client},
               {"receive_timeout_s", api.config.limits.receive_timeout_s}}}});
}

void get_openapi(ApiState&, const Request&, Response& res) {
  res.set_content(kOpenApiYaml, "application/yaml");
}

void post_study(ApiState& api, const Request& req, Response& res) {
  json spec;
  if (!parse_body(req, res, spec)) return;
  std::string problem;
  if (!scene_path_allowed(spec, problem)) return send_error(res, 400, "invalid_study", problem);
  Study study;
  try {
    study = expand_study(spec, api.config.scenes_root, api.config.max_runs_per_study,
                         &api.config.scenes_root, api.config.max_study_bytes);
  } catch (const StudyTooLarge& e) {
    return send_error(res, 413, "study_too_large", e.what());
  } catch (const InputErrorList& e) {
    ordered_json details = ordered_json::array();
    const std::size_t shown = std::min(e.errors().size(), kMaxReportedErrors);
    for (std::size_t k = 0; k < shown; ++k) {
      const InputError& err = e.errors()[k];
      details.push_back({{"path", err.path}, {"value", err.value}, {"allowed", err.allowed}});
    }
    return send_error(
        res, 400, "invalid_study",
        concat(e.errors().size(), " problem(s) in the study",
               shown < e.errors().size() ? concat(" (the first ", shown, " are listed)")
                                         : std::string(),
               "; nothing was queued"),
        details);
  }
  if (const std::optional<InputError> p = thread_budget_problem(
          study.limits.threads_per_run, api.config.workers, usable_core_count()))
    return send_error(
        res, 400, "invalid_study",
        "1 problem(s) in the study: its runs' threads do not fit this server's "
        "cores; nothing was queued",
        ordered_json::array({{{"path", p->path}, {"value", p->value}, {"allowed", p->allowed}}}));
  std::optional<std::string> key;
  if (req.has_header("Idempotency-Key")) key = req.get_header_value("Idempotency-Key");
  std::lock_guard<std::mutex> lock(api.store_mutex);
  const Store::Submitted sub =
      api.store->submit(study, key, std::filesystem::absolute(api.config.out_root), wall_clock_s());
  send_json(res, sub.created ? 201 : 200,
            {{"study", sub.study_id},
             {"runs", api.store->progress(sub.study_id).total},
             {"created", sub.created}});
}

void list_studies(ApiState& api, const Request& req, Response& res) {
  int limit = 0, offset = 0;
  if (!query_int(req, res, "limit", 100, 1, 1000, limit) ||
      !query_int(req, res, "offset", 0, 0, 1 << 30, offset))
    return;
  std::lock_guard<std::mutex> lock(api.store_mutex);
  ordered_json list = ordered_json::array();
  for (const StudyRecord& st : api.store->studies(limit, offset))
    list.push_back(study_summary(api, st));
  send_json(res, 200, {{"studies", list}, {"limit", limit}, {"offset", offset}});
}

void get_study(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<StudyRecord> st;
  if (!with_study(api, req, res, st)) return;
  ordered_json body = study_summary(api, *st);
  body["spec"] = json::parse(st->spec);
  send_json(res, 200, body);
}

void list_study_runs(ApiState& api, const Request& req, Response& res) {
  int limit = 0, offset = 0;
  if (!query_int(req, res, "limit", 100, 1, 1000, limit) ||
      !query_int(req, res, "offset", 0, 0, 1 << 30, offset))
    return;
  std::optional<RunState> state;
  if (req.has_param("state")) {
    state = run_state_from_name(req.get_param_value("state"));
    if (!state)
      return send_error(res, 400, "bad_parameter",
                        "query parameter state = \"" + req.get_param_value("state") +
                            "\": expected QUEUED, RUNNING, COMPLETE, EXECUTOR_ERROR, "
                            "SYSTEM_ERROR, CANCELING or CANCELED");
  }
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<StudyRecord> st;
  if (!with_study(api, req, res, st)) return;
  ordered_json list = ordered_json::array();
  for (const RunRecord& r : api.store->runs(st->id, state, limit, offset))
    list.push_back(run_json(r, false));
  send_json(res, 200, {{"runs", list}, {"limit", limit}, {"offset", offset}});
}

void get_study_results(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<StudyRecord> st;
  if (!with_study(api, req, res, st)) return;
  send_json(res, 200, api.cached_results(st->id));
}

void get_error_vs_time_plot(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<StudyRecord> st;
  if (!with_study(api, req, res, st)) return;
  res.set_content(error_vs_time_svg(api.cached_results(st->id)), "image/svg+xml");
}

void get_psd_plot(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<StudyRecord> st;
  if (!with_study(api, req, res, st)) return;
  const std::string svg = psd_svg(*api.store, st->id);
  if (svg.empty())
    return send_error(res, 404, "no_psd", "no complete run of study " + st->id + " has a PSD yet");
  res.set_content(svg, "image/svg+xml");
}

void cancel_study(ApiState& api, const Request& req, Response& res) {
  std::lock_guard<std::mutex> lock(api.store_mutex);
  std::optional<StudyRecord> st;
  if (!with_study(api, req, res, st)) return;
  if (api.store->progress(st->id).finished())
    return send_error(
        res, 409, "finished",
        "study " + st->id + " has finished (no run queued or running): nothing to cancel");
  api.store->cancel_study(st->id, wall_clock_s());
  send_json(res, 200, {{"study", st->id}, {"canceled", true}});
}

}  // namespace millsim
