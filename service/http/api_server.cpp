#include "http/api_server.h"

#include <httplib.h>

#include <fcntl.h>
#include <strings.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <string_view>

#include "core/errors.h"
#include "core/json_reader.h"
#include "executors/executor.h"
#include "regression/regression.h"
#include "sim/run.h"
#include "studies/results.h"

namespace millsim {

extern const char* const kOpenApiYaml;  // docs/openapi.yaml (generated openapi_yaml.cpp)
// The dashboard, service/http/web/ (generated web_*.cpp).
extern const char* const kWeb_index_html;
extern const char* const kWeb_dashboard_js;
extern const char* const kWeb_dashboard_css;

namespace {

using httplib::Request;
using httplib::Response;
using nlohmann::json;
using nlohmann::ordered_json;

thread_local std::chrono::steady_clock::time_point request_started_at;

// Whether `path` has `pattern`'s segments, "*" standing for any one non-empty segment.
bool path_matches(std::string_view pattern, std::string_view path) {
  while (!pattern.empty() && !path.empty()) {
    const std::size_t p_end = std::min(pattern.find('/', 1), pattern.size());
    const std::size_t s_end = std::min(path.find('/', 1), path.size());
    const std::string_view p_segment = pattern.substr(0, p_end);
    const std::string_view s_segment = path.substr(0, s_end);
    if (p_segment == "/*" ? s_segment.size() < 2 : p_segment != s_segment) return false;
    pattern.remove_prefix(p_end);
    path.remove_prefix(s_end);
  }
  return pattern.empty() && path.empty();
}

// A request path for the log: control characters and non-ASCII bytes as %XX, at most 200.
std::string printable(const std::string& path) {
  std::string out;
  for (const unsigned char c : path.substr(0, 200)) {
    if (c < 0x21 || c > 0x7e) {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", c);
      out += hex;
    } else {
      out += char(c);
    }
  }
  return path.size() > 200 ? out + "..." : out;
}

bool all_digits(std::string_view s) {
  return !s.empty() && s.find_first_not_of("0123456789") == std::string_view::npos;
}

// "s" and six digits: the only study ids there are (anything else, e.g. a path trick, is 404).
bool is_study_id(std::string_view s) {
  return s.size() == 7 && s[0] == 's' && all_digits(s.substr(1));
}

// A study id, "-r" and 1–9 digits.
bool is_run_id(std::string_view s) {
  return s.size() >= 10 && s.size() <= 18 && is_study_id(s.substr(0, 7)) &&
         s.substr(7, 2) == "-r" && all_digits(s.substr(9));
}

void send_json(Response& res, int status, const ordered_json& body) {
  res.status = status;
  // Stored text is valid UTF-8 (checked on input); `replace` is the net under that.
  res.set_content(body.dump(2, ' ', false, ordered_json::error_handler_t::replace) + "\n",
                  "application/json");
}

void send_error(Response& res, int status, const std::string& code, const std::string& message,
                const ordered_json& details = nullptr) {
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
                    {"memory_limit_mb", r.memory_limit_mb}};
  if (with_scene) {
    j["scene"] = json::parse(r.scene);
    j["out_dir"] = r.out_dir;
    j["slurm"] = r.slurm.to_json();
    j["files_root"] = r.files_root;
  }
  return j;
}

const char* const kUnauthorized =
    "this endpoint needs the header \"Authorization: Bearer <token>\" with the server's token";

bool equals_ignoring_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() && strncasecmp(a.data(), b.data(), a.size()) == 0;
}

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// What the body guard says of a request's head: 0 go on; -1 go on and close the connection
// after (a body that httplib will not read on this method); else the refusal.
struct BodyVerdict {
  int status = 0;
  std::string code, message;
};

BodyVerdict check_body_headers(const Request& req, const std::string& expected_authorization) {
  // httplib reads a body on these, and on DELETE when one is announced (as for any method).
  const bool body_method = req.method == "POST" || req.method == "PUT" || req.method == "PATCH";
  const std::size_t lengths = req.get_header_value_count("Content-Length");
  const bool has_transfer = req.has_header("Transfer-Encoding");
  bool has_body = has_transfer;
  for (std::size_t k = 0; k < lengths; ++k)
    has_body = has_body || trimmed(req.get_header_value("Content-Length", k)) != "0";
  if (!body_method && !has_body) return {};
  if (req.get_header_value("Authorization") != expected_authorization)
    return {401, "unauthorized", kUnauthorized};
  if (lengths > 1)
    return {400, "bad_length", "give one Content-Length header; this request has several"};
  if (lengths == 1) {
    const std::string_view text = trimmed(req.get_header_value("Content-Length"));
    if (text.empty() || text.size() > 18 ||
        text.find_first_not_of("0123456789") != std::string_view::npos)
      return {400, "bad_length",
              concat("Content-Length \"", utf8_prefix(valid_utf8(std::string(text)), 40),
                     "\" is not a byte count")};
  }
  if (has_transfer)
    return {411, "length_required",
            concat("send the body with a Content-Length; Transfer-Encoding \"",
                   utf8_prefix(valid_utf8(req.get_header_value("Transfer-Encoding")), 40),
                   "\" is not accepted")};
  for (std::size_t k = 0; k < req.get_header_value_count("Content-Encoding"); ++k) {
    const std::string value = req.get_header_value("Content-Encoding", k);
    if (!equals_ignoring_case(trimmed(value), "identity"))
      return {415, "encoded_body",
              concat("request bodies are accepted as they are, not with Content-Encoding: ",
                     utf8_prefix(valid_utf8(value), 40))};
  }
  if (!body_method && req.method != "DELETE") return {-1, "", ""};
  return {};
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

}  // namespace

bool is_loopback_host(const std::string& host) {
  return host == "127.0.0.1" || host == "localhost" || host == "::1";
}

ApiServer::ApiServer(ServerConfig config)
    : config_(std::move(config)), http_(std::make_unique<GuardedHttpServer>(config_.limits)) {
  lock_ = std::make_unique<DatabaseLock>(config_.db);
  store_ = std::make_unique<Store>(config_.db);
  // The health probe is answered even over the connection cap (with the token off loopback).
  http_->answer_health_when_busy({"/v1/health",
                                  is_loopback_host(config_.host) ? "" : "Bearer " + config_.token,
                                  "{\"status\": \"ok\"}\n"});
  if (config_.worker_port >= 0) {
    // The workers all come from the machines that run them: no per-address share there.
    ConnectionLimits worker_limits = config_.limits;
    worker_limits.max_connections_per_client = worker_limits.max_connections;
    worker_http_ = std::make_unique<GuardedHttpServer>(worker_limits);
  }
  routes(*http_, false);
  if (worker_http_) routes(*worker_http_, true);
}
ApiServer::~ApiServer() {
  stop();
  if (reaper_.joinable()) reaper_.join();
  if (worker_thread_.joinable()) worker_thread_.join();
}

void ApiServer::bind() {
  const auto bind_one = [this](httplib::Server& http, int port) {
    // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second server on the
    // same port would start silently and take half the traffic.
    http.set_socket_options([](int sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    const int bound = port == 0 ? http.bind_to_any_port(config_.host)
                                : (http.bind_to_port(config_.host, port) ? port : -1);
    if (bound < 0)
      throw IoError(concat("cannot listen on ", config_.host, ":", port,
                           " (in use, or not an address of this machine)"));
    return bound;
  };
  port_ = bind_one(*http_, config_.port);
  http_->widen_backlog();
  if (worker_http_) {
    worker_port_ = bind_one(*worker_http_, config_.worker_port);
    worker_http_->widen_backlog();
  }
}

void ApiServer::serve() {
  reaper_ = std::thread([this] {
    while (!stopping_) {
      {
        std::lock_guard<std::mutex> lock(store_mutex_);
        store_->requeue_expired(wall_clock_s());
      }
      for (int k = 0; k < 10 && !stopping_; ++k)
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  if (worker_http_) worker_thread_ = std::thread([this] { worker_http_->listen_after_bind(); });
  http_->listen_after_bind();
}

void ApiServer::stop() {
  stopping_ = true;
  if (http_) http_->stop();
  if (worker_http_) worker_http_->stop();
}

const nlohmann::ordered_json& ApiServer::cached_results(const std::string& study_id) {
  // Rebuilt only when a run of the study changed state or finished since the last build.
  const std::string signature = store_->change_signature(study_id);
  CachedTable& cached = results_cache_[study_id];
  if (cached.signature != signature || cached.table.is_null()) {
    cached.table = results_table(*store_, study_id);
    cached.signature = signature;
  }
  return cached.table;
}

void ApiServer::routes(httplib::Server& s, bool worker_only) {
  // Small replies on a kept-alive connection otherwise wait for Nagle's algorithm and the
  // client's delayed ACK: about 40 ms each from the second request on.
  s.set_tcp_nodelay(true);
  s.set_payload_max_length(config_.max_body_bytes);
  s.set_error_handler([this](const Request&, Response& res) {
    if (!res.body.empty()) return;
    if (res.status == 413)
      send_error(res, 413, "body_too_large",
                 concat("the request body exceeds ", config_.max_body_bytes, " bytes"));
    else if (res.status == 404)
      send_error(res, 404, "not_found", "no such endpoint");
    else
      send_error(res, res.status, "http_error", concat("HTTP status ", res.status));
  });
  // Out of memory in a handler fails that request alone (503: the server is short of memory,
  // try later), never the server.
  s.set_exception_handler([](const Request&, Response& res, std::exception_ptr ep) {
    std::string what = "unknown";
    try {
      std::rethrow_exception(ep);
    } catch (const std::bad_alloc&) {
      res.body.clear();
      res.body.shrink_to_fit();
      res.status = 503;
      res.set_header("Retry-After", "10");
      res.set_content(
          "{\"error\": {\"code\": \"out_of_memory\", \"message\": \"the server ran out "
          "of memory answering this request; nothing was stored\"}}\n",
          "application/json");
      return;
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    send_error(res, 500, "internal", what);
  });
  const bool public_reads = !is_loopback_host(config_.host);
  const std::string expected = "Bearer " + config_.token;
  // Before any body is read (httplib reads it after this handler), for every method alike: a
  // request that carries a body, or whose method takes one, needs the token (401 unread); its
  // Content-Length must be one number (400); a Transfer-Encoding (411: send a Content-Length) or
  // a Content-Encoding other than identity (415: decoded it could be a thousand times the limit)
  // is refused, their names and values compared case-insensitively. The body is then held to
  // max_body_bytes by httplib, and its decoded size is its size.
  s.set_pre_routing_handler([expected](const Request& req, Response& res) {
    request_started_at = std::chrono::steady_clock::now();
    const BodyVerdict verdict = check_body_headers(req, expected);
    if (verdict.status == 0) return httplib::Server::HandlerResponse::Unhandled;
    // The unread body must not become the next request: the connection ends after the reply.
    res.set_header("Connection", "close");
    GuardedHttpServer::close_after_response();
    if (verdict.status < 0)  // a body on a method that takes none: answered, then closed
      return httplib::Server::HandlerResponse::Unhandled;
    send_error(res, verdict.status, verdict.code, verdict.message);
    return httplib::Server::HandlerResponse::Handled;
  });
  // One line per request on stderr.
  if (config_.request_log)
    s.set_logger([](const Request& req, const Response& res) {
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                                  request_started_at)
                            .count();
      // One write per line, so lines of concurrent requests never interleave.
      char millis[32];
      std::snprintf(millis, sizeof millis, "%.3f", ms);
      const std::string line = concat(iso_utc(wall_clock_s()), " ", req.method, " ",
                                      printable(req.path), " ", res.status, " ", millis, " ms\n");
      std::fputs(line.c_str(), stderr);
    });
  // Wraps a handler with the token check (always for writes; for reads off loopback). The
  // request has arrived whole: its receive deadline stops.
  auto guard = [expected](bool needs_token, auto handler) {
    return [expected, needs_token, handler](const Request& req, Response& res) {
      GuardedHttpServer::mark_handler_started();
      if (needs_token && req.get_header_value("Authorization") != expected)
        return send_error(res, 401, "unauthorized", kUnauthorized);
      handler(req, res);
    };
  };

  if (!worker_only) {
    s.Get("/v1/health", guard(public_reads, [](const Request&, Response& res) {
            send_json(res, 200, {{"status", "ok"}});
          }));

    s.Get("/v1/info", guard(public_reads, [this](const Request&, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            send_json(res, 200,
                      {{"millsim_version", kMillsimVersion},
                       {"schema_version", store_->schema_version()},
                       {"workers", config_.workers},
                       {"worker_port", worker_port_ >= 0 ? json(worker_port_) : json(nullptr)},
                       {"limits",
                        {{"max_body_bytes", config_.max_body_bytes},
                         {"max_runs_per_study", config_.max_runs_per_study},
                         {"max_study_bytes", config_.max_study_bytes},
                         {"lease_s", config_.lease_s},
                         {"max_connections", config_.limits.max_connections},
                         {"max_connections_per_client", config_.limits.max_connections_per_client},
                         {"receive_timeout_s", config_.limits.receive_timeout_s}}}});
          }));

    s.Post("/v1/studies", guard(true, [this](const Request& req, Response& res) {
             json spec;
             if (!parse_body(req, res, spec)) return;
             std::string problem;
             if (!scene_path_allowed(spec, problem))
               return send_error(res, 400, "invalid_study", problem);
             Study study;
             try {
               study = expand_study(spec, config_.scenes_root, config_.max_runs_per_study,
                                    &config_.scenes_root, config_.max_study_bytes);
             } catch (const StudyTooLarge& e) {
               return send_error(res, 413, "study_too_large", e.what());
             } catch (const InputErrorList& e) {
               ordered_json details = ordered_json::array();
               const std::size_t shown = std::min(e.errors().size(), kMaxReportedErrors);
               for (std::size_t k = 0; k < shown; ++k) {
                 const InputError& err = e.errors()[k];
                 details.push_back(
                     {{"path", err.path}, {"value", err.value}, {"allowed", err.allowed}});
               }
               return send_error(
                   res, 400, "invalid_study",
                   concat(e.errors().size(), " problem(s) in the study",
                          shown < e.errors().size() ? concat(" (the first ", shown, " are listed)")
                                                    : std::string(),
                          "; nothing was queued"),
                   details);
             }
             std::optional<std::string> key;
             if (req.has_header("Idempotency-Key")) key = req.get_header_value("Idempotency-Key");
             std::lock_guard<std::mutex> lock(store_mutex_);
             const Store::Submitted sub = store_->submit(
                 study, key, std::filesystem::absolute(config_.out_root), wall_clock_s());
             send_json(res, sub.created ? 201 : 200,
                       {{"study", sub.study_id},
                        {"runs", store_->progress(sub.study_id).total},
                        {"created", sub.created}});
           }));

    auto study_summary = [this](const StudyRecord& st) {
      const Progress p = store_->progress(st.id);
      const double mean_wall = store_->mean_wall_time_s(st.id);
      return ordered_json{{"id", st.id},
                          {"name", st.name},
                          {"created_at", st.created_at},
                          {"canceled", st.canceled},
                          {"reference_run", st.reference_run ? ordered_json(*st.reference_run)
                                                             : ordered_json(nullptr)},
                          {"error_metric", st.error_metric},
                          {"progress", progress_json(p, mean_wall, std::max(1, config_.workers))}};
    };

    s.Get("/v1/studies",
          guard(public_reads, [this, study_summary](const Request& req, Response& res) {
            int limit = 0, offset = 0;
            if (!query_int(req, res, "limit", 100, 1, 1000, limit) ||
                !query_int(req, res, "offset", 0, 0, 1 << 30, offset))
              return;
            std::lock_guard<std::mutex> lock(store_mutex_);
            ordered_json list = ordered_json::array();
            for (const StudyRecord& st : store_->studies(limit, offset))
              list.push_back(study_summary(st));
            send_json(res, 200, {{"studies", list}, {"limit", limit}, {"offset", offset}});
          }));

    // Resolves {id} of a study route; 404 for an unknown or malformed id.
    auto with_study = [this](const Request& req, Response& res, std::optional<StudyRecord>& out) {
      const std::string id = req.matches[1];
      if (is_study_id(id)) out = store_->study(id);
      if (!out) send_error(res, 404, "not_found", "no study \"" + id + "\"");
      return out.has_value();
    };
    auto with_run = [this](const Request& req, Response& res, std::optional<RunRecord>& out) {
      const std::string id = req.matches[1];
      if (is_run_id(id)) out = store_->run(id);
      if (!out) send_error(res, 404, "not_found", "no run \"" + id + "\"");
      return out.has_value();
    };
    // A run that exists and is COMPLETE (404 or 409 otherwise; `what` names what it lacks).
    auto with_complete_run = [with_run](const Request& req, Response& res,
                                        std::optional<RunRecord>& out, const char* what) {
      if (!with_run(req, res, out)) return false;
      if (out->state == RunState::Complete) return true;
      send_error(res, 409, "not_complete",
                 "run " + out->id + " is " + std::string(run_state_name(out->state)) + "; its " +
                     what + " exists once it is COMPLETE");
      return false;
    };

    s.Get(R"(/v1/studies/([^/]+))",
          guard(public_reads, [this, with_study, study_summary](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<StudyRecord> st;
            if (!with_study(req, res, st)) return;
            ordered_json body = study_summary(*st);
            body["spec"] = json::parse(st->spec);
            send_json(res, 200, body);
          }));

    s.Get(R"(/v1/studies/([^/]+)/runs)",
          guard(public_reads, [this, with_study](const Request& req, Response& res) {
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
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<StudyRecord> st;
            if (!with_study(req, res, st)) return;
            ordered_json list = ordered_json::array();
            for (const RunRecord& r : store_->runs(st->id, state, limit, offset))
              list.push_back(run_json(r, false));
            send_json(res, 200, {{"runs", list}, {"limit", limit}, {"offset", offset}});
          }));

    s.Get(R"(/v1/studies/([^/]+)/results)",
          guard(public_reads, [this, with_study](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<StudyRecord> st;
            if (!with_study(req, res, st)) return;
            send_json(res, 200, cached_results(st->id));
          }));

    s.Get(R"(/v1/studies/([^/]+)/plot/error-vs-time)",
          guard(public_reads, [this, with_study](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<StudyRecord> st;
            if (!with_study(req, res, st)) return;
            res.set_content(error_vs_time_svg(cached_results(st->id)), "image/svg+xml");
          }));

    s.Get(R"(/v1/studies/([^/]+)/plot/psd)",
          guard(public_reads, [this, with_study](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<StudyRecord> st;
            if (!with_study(req, res, st)) return;
            const std::string svg = psd_svg(*store_, st->id);
            if (svg.empty())
              return send_error(res, 404, "no_psd",
                                "no complete run of study " + st->id + " has a PSD yet");
            res.set_content(svg, "image/svg+xml");
          }));

    s.Post(R"(/v1/studies/([^/]+)/cancel)",
           guard(true, [this, with_study](const Request& req, Response& res) {
             std::lock_guard<std::mutex> lock(store_mutex_);
             std::optional<StudyRecord> st;
             if (!with_study(req, res, st)) return;
             if (store_->progress(st->id).finished())
               return send_error(res, 409, "finished",
                                 "study " + st->id +
                                     " has finished (no run queued or running): nothing to cancel");
             store_->cancel_study(st->id, wall_clock_s());
             send_json(res, 200, {{"study", st->id}, {"canceled", true}});
           }));

    s.Get(R"(/v1/runs/([^/]+))",
          guard(public_reads, [this, with_run](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<RunRecord> r;
            if (!with_run(req, res, r)) return;
            ordered_json body = run_json(*r, false);
            body["log_tail"] = tail_of_file(std::filesystem::path(r->out_dir) / "log.txt", 40);
            ordered_json history = ordered_json::array();
            for (const AttemptRecord& a : store_->attempts(r->id))
              history.push_back(
                  {{"attempt", a.attempt},
                   {"worker", a.worker},
                   {"started_at", a.started_at},
                   {"finished_at", a.finished_at},
                   {"state", a.state},
                   {"exit_code", a.exit_code ? ordered_json(*a.exit_code) : ordered_json()},
                   {"error", a.error},
                   {"resumed_from_s",
                    a.resumed_from_s ? ordered_json(*a.resumed_from_s) : ordered_json()}});
            body["attempt_history"] = history;
            send_json(res, 200, body);
          }));

    s.Get(R"(/v1/runs/([^/]+)/psd)",
          guard(public_reads, [this, with_complete_run](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<RunRecord> r;
            if (!with_complete_run(req, res, r, "PSD")) return;
            const json result = json::parse(r->result);
            if (!result.contains("outlet_psd"))
              return send_error(res, 404, "no_psd",
                                "run " + r->id + "'s scene has no outlets or breakage, so no PSD");
            send_json(res, 200, {{"run", r->id}, {"outlet_psd", result["outlet_psd"]}});
          }));

    s.Get(R"(/v1/runs/([^/]+)/h5)",
          guard(public_reads, [this, with_run](const Request& req, Response& res) {
            std::optional<RunRecord> r;
            {
              std::lock_guard<std::mutex> lock(store_mutex_);
              if (!with_run(req, res, r)) return;
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
          }));

    s.Get(R"(/v1/runs/([^/]+)/result)",
          guard(public_reads, [this, with_complete_run](const Request& req, Response& res) {
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<RunRecord> r;
            if (!with_complete_run(req, res, r, "result")) return;
            send_json(res, 200, ordered_json::parse(r->result));
          }));

    // The regression history (millsim regress): the client runs the checks as studies through
    // this server, compares, and records the outcome here.
    s.Post("/v1/regressions", guard(true, [this](const Request& req, Response& res) {
             json record;
             if (!parse_body(req, res, record)) return;
             const InputErrors errors = validate_regression_record(record);
             if (!errors.empty()) {
               ordered_json details = ordered_json::array();
               for (const InputError& err : errors)
                 details.push_back(
                     {{"path", err.path}, {"value", err.value}, {"allowed", err.allowed}});
               return send_error(res, 400, "invalid_regression",
                                 concat(errors.size(), " problem(s) in the record; nothing stored"),
                                 details);
             }
             // The server's clock dates a record, not the client's (whatever the body said).
             const double now = wall_clock_s();
             record["created_at"] = now;
             record["created"] = iso_utc(now);
             std::lock_guard<std::mutex> lock(store_mutex_);
             const std::string id = store_->add_regression(record, now);
             send_json(res, 201, {{"id", id}});
           }));

    s.Get("/v1/regressions", guard(public_reads, [this](const Request& req, Response& res) {
            int limit = 0, offset = 0;
            if (!query_int(req, res, "limit", 100, 1, 1000, limit) ||
                !query_int(req, res, "offset", 0, 0, 1 << 30, offset))
              return;
            const std::string suite = req.has_param("suite") ? req.get_param_value("suite") : "";
            const std::string check = req.has_param("check") ? req.get_param_value("check") : "";
            std::lock_guard<std::mutex> lock(store_mutex_);
            ordered_json list = ordered_json::array();
            for (const RegressionEntry& e : store_->regressions(limit, offset, suite)) {
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
          }));

    s.Get(R"(/v1/regressions/([^/]+))",
          guard(public_reads, [this](const Request& req, Response& res) {
            const std::string id = req.matches[1];
            std::lock_guard<std::mutex> lock(store_mutex_);
            std::optional<RegressionEntry> e;
            if (id.size() == 7 && id[0] == 'g' && all_digits(id.substr(1)))
              e = store_->regression(id);
            if (!e) return send_error(res, 404, "not_found", "no regression run \"" + id + "\"");
            ordered_json record = ordered_json::parse(e->record);
            record["id"] = e->id;
            send_json(res, 200, record);
          }));
  }

  // Worker protocol: claim, heartbeat, finish (each with the run's fencing token).
  s.Post(
      "/v1/worker/claim", guard(true, [this](const Request& req, Response& res) {
        json body;
        if (!parse_body(req, res, body)) return;
        if (!body.is_object() || (body.contains("worker") && !body["worker"].is_string()))
          return send_error(res, 400, "invalid_body", "expected {\"worker\": string}");
        const std::string worker = body.value("worker", std::string("worker"));
        std::lock_guard<std::mutex> lock(store_mutex_);
        std::optional<Claim> c = store_->claim(worker, config_.lease_s, wall_clock_s());
        if (!c) {
          res.status = 204;
          return;
        }
        c->run.files_root = std::filesystem::absolute(config_.scenes_root).lexically_normal();
        send_json(
            res, 200,
            {{"run", run_json(c->run, true)}, {"token", c->token}, {"lease_s", config_.lease_s}});
      }));

  s.Post(R"(/v1/worker/runs/([^/]+)/heartbeat)",
         guard(true, [this](const Request& req, Response& res) {
           json body;
           if (!parse_body(req, res, body)) return;
           if (!body.contains("token") || !body["token"].is_number_integer())
             return send_error(res, 400, "invalid_body", "expected {\"token\": integer}");
           std::lock_guard<std::mutex> lock(store_mutex_);
           if (!store_->heartbeat(req.matches[1], body["token"].get<std::int64_t>(),
                                  config_.lease_s, wall_clock_s()))
             return send_error(res, 409, "lease_lost",
                               "the run was canceled or given to another worker: stop it");
           send_json(res, 200, {{"lease_s", config_.lease_s}});
         }));

  s.Post(R"(/v1/worker/runs/([^/]+)/finish)",
         guard(true, [this](const Request& req, Response& res) {
           json body;
           if (!parse_body(req, res, body)) return;
           FinishReport report;
           try {
             const std::optional<RunState> state =
                 run_state_from_name(body.at("state").get<std::string>());
             if (!state) throw std::invalid_argument("state");
             report.state = *state;
             report.retryable = body.value("retryable", false);
             if (body.contains("exit_code") && body["exit_code"].is_number_integer())
               report.exit_code = body["exit_code"].get<int>();
             report.error = body.value("error", std::string());
             report.wall_time_s = body.value("wall_time_s", 0.0);
             report.result = body.value("result", std::string());
             const std::int64_t token = body.at("token").get<std::int64_t>();
             std::lock_guard<std::mutex> lock(store_mutex_);
             if (!store_->finish(req.matches[1], token, report, wall_clock_s()))
               return send_error(res, 409, "lease_lost",
                                 "stale token: this attempt's report was not recorded");
           } catch (const std::exception&) {
             return send_error(res, 400, "invalid_body",
                               "expected {token, state, retryable, exit_code, error, "
                               "wall_time_s, result}");
           }
           send_json(res, 200, {{"recorded", true}});
         }));

  // The worker server takes the worker protocol only: anything else is a 404 there.
  if (worker_only) return;

  // The dashboard: static files, no data (its script reads the API with the token it is given).
  // The policy lets the page load only its own script, style and images (plots as blobs).
  auto web = [](const char* body, const char* type) {
    return [body, type](const Request&, Response& res) {
      res.set_header("Content-Security-Policy",
                     "default-src 'none'; script-src 'self'; style-src 'self'; "
                     "img-src 'self' blob:; connect-src 'self'; form-action 'none'; "
                     "frame-ancestors 'none'; base-uri 'none'");
      res.set_header("X-Content-Type-Options", "nosniff");
      res.set_header("Cache-Control", "no-cache");
      res.set_content(body, type);
    };
  };
  s.Get("/", web(kWeb_index_html, "text/html; charset=utf-8"));
  s.Get("/dashboard.js", web(kWeb_dashboard_js, "text/javascript; charset=utf-8"));
  s.Get("/dashboard.css", web(kWeb_dashboard_css, "text/css; charset=utf-8"));

  s.Get("/v1/openapi.yaml", guard(public_reads, [](const Request&, Response& res) {
          res.set_content(kOpenApiYaml, "application/yaml");
        }));

  // A known path with a method it does not take: 405 with Allow. Registered last, so every real
  // route matched first; anything else is a 404.
  struct Route {
    const char* path;  // "*" matches one path segment
    const char* allow;
  };
  static constexpr Route kKnown[] = {
      {"/", "GET"},
      {"/dashboard.js", "GET"},
      {"/dashboard.css", "GET"},
      {"/v1/health", "GET"},
      {"/v1/info", "GET"},
      {"/v1/openapi.yaml", "GET"},
      {"/v1/studies", "GET, POST"},
      {"/v1/studies/*", "GET"},
      {"/v1/studies/*/runs", "GET"},
      {"/v1/studies/*/results", "GET"},
      {"/v1/studies/*/plot/error-vs-time", "GET"},
      {"/v1/studies/*/plot/psd", "GET"},
      {"/v1/studies/*/cancel", "POST"},
      {"/v1/runs/*", "GET"},
      {"/v1/runs/*/psd", "GET"},
      {"/v1/runs/*/h5", "GET"},
      {"/v1/runs/*/result", "GET"},
      {"/v1/regressions", "GET, POST"},
      {"/v1/regressions/*", "GET"},
      {"/v1/worker/claim", "POST"},
      {"/v1/worker/runs/*/heartbeat", "POST"},
      {"/v1/worker/runs/*/finish", "POST"},
  };
  auto not_allowed = [](const Request& req, Response& res) {
    for (const Route& r : kKnown)
      if (path_matches(r.path, req.path)) {
        res.set_header("Allow", r.allow);
        return send_error(res, 405, "method_not_allowed",
                          req.method + " is not allowed on " + req.path + "; allowed: " + r.allow);
      }
    send_error(res, 404, "not_found", "no endpoint " + req.path);
  };
  s.Get(".*", not_allowed);
  s.Post(".*", not_allowed);
  s.Put(".*", not_allowed);
  s.Patch(".*", not_allowed);
  s.Delete(".*", not_allowed);
}

}  // namespace millsim
