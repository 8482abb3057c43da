// Replies of the HTTP API: JSON bodies, errors, query parameters, ids, runs as JSON.
#include <cstdio>
#include <cstdlib>

#include "core/errors.h"
#include "core/json_reader.h"
#include "http/handlers.h"
#include "studies/results.h"

namespace millsim {

using httplib::Request;
using httplib::Response;
using nlohmann::json;
using nlohmann::ordered_json;

namespace {

bool all_digits(std::string_view s) {
  return !s.empty() && s.find_first_not_of("0123456789") == std::string_view::npos;
}

}  // namespace

bool is_study_id(std::string_view s) {
  return s.size() == 7 && s[0] == 's' && all_digits(s.substr(1));
}

bool is_run_id(std::string_view s) {
  return s.size() >= 10 && s.size() <= 18 && is_study_id(s.substr(0, 7)) &&
         s.substr(7, 2) == "-r" && all_digits(s.substr(9));
}

bool is_regression_id(std::string_view s) {
  return s.size() == 7 && s[0] == 'g' && all_digits(s.substr(1));
}

void send_json(Response& res, int status, const ordered_json& body) {
  res.status = status;
  // Stored text is valid UTF-8 (checked on input); `replace` is the net under that.
  res.set_content(body.dump(2, ' ', false, ordered_json::error_handler_t::replace) + "\n",
                  "application/json");
}

void send_error(Response& res, int status, const std::string& code, const std::string& message,
                const ordered_json& details) {
  ordered_json error = {{"code", code}, {"message", message}};
  if (!details.is_null()) error["details"] = details;
  send_json(res, status, {{"error", error}});
}

// Reads a non-negative integer query parameter within [lo, hi]; reports 400 when bad.
bool query_int(const Request& req, Response& res, const char* name, int fallback, int lo, int hi,
               int& out) {
  out = fallback;
  if (!req.has_param(name)) return true;
  const std::string text = req.get_param_value(name);
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < lo || v > hi) {
    send_error(res, 400, "bad_parameter",
               concat("query parameter ", name, " = \"", text, "\": expected an integer in [", lo,
                      ", ", hi, "]"));
    return false;
  }
  out = int(v);
  return true;
}

bool parse_body(const Request& req, Response& res, json& out) {
  try {
    out = parse_untrusted_json(req.body);
    return true;
  } catch (const JsonTooDeep& e) {
    send_error(res, 400, "invalid_json", std::string("the body is too deeply nested: ") + e.what());
    return false;
  } catch (const json::exception& e) {  // syntax, or a number beyond a double (1e999)
    send_error(res, 400, "invalid_json", std::string("the body is not valid JSON: ") + e.what());
    return false;
  }
}

ordered_json run_json(const RunRecord& r, bool with_scene) {
  ordered_json j = {{"id", r.id},
                    {"study", r.study_id},
                    {"index", r.index},
                    {"params", r.params},
                    {"seed", r.seed},
                    {"reference", r.is_reference},
                    {"state", std::string(run_state_name(r.state))},
                    {"attempts", r.attempts},
                    {"max_attempts", r.max_attempts},
                    {"created_at", r.created_at},
                    {"started_at", r.started_at},
                    {"finished_at", r.finished_at},
                    {"exit_code", r.exit_code ? ordered_json(*r.exit_code) : ordered_json(nullptr)},
                    {"error", r.error},
                    {"wall_time_s", r.wall_time_s},
                    {"wall_limit_s", r.wall_limit_s},
                    {"memory_limit_mb", r.memory_limit_mb},
                    {"threads", r.threads}};
  if (with_scene) {
    j["scene"] = json::parse(r.scene);
    j["out_dir"] = r.out_dir;
    j["slurm"] = r.slurm.to_json();
    j["files_root"] = r.files_root;
  }
  return j;
}

const nlohmann::ordered_json& ApiState::cached_results(const std::string& study_id) {
  // Rebuilt only when a run of the study changed state or finished since the last build.
  const std::string signature = store->change_signature(study_id);
  CachedTable& cached = results_cache[study_id];
  if (cached.signature != signature || cached.table.is_null()) {
    cached.table = results_table(*store, study_id);
    cached.signature = signature;
  }
  return cached.table;
}

}  // namespace millsim
