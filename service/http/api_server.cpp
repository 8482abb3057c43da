#include "http/api_server.h"

#include <strings.h>
#include <sys/socket.h>

#include <chrono>
#include <cstdio>
#include <string_view>

#include "core/errors.h"
#include "core/json_reader.h"
#include "executors/executor.h"
#include "http/handlers.h"
#include "http/http_limits.h"
#include "http/request_log.h"
#include "memory_reserve.h"
#include "regression/regression.h"

namespace millsim {

// The dashboard, service/http/web/ (generated web_*.cpp).
extern const char* const kWeb_index_html;
extern const char* const kWeb_dashboard_js;
extern const char* const kWeb_dashboard_css;

namespace {

using httplib::Request;
using httplib::Response;

// Who may call a route: anyone on loopback and with the token beyond it (Read), or only with
// the token (Token: every write).
enum class Access { Read, Token };

struct Route {
  const char* method;  // GET or POST
  const char* path;    // httplib's pattern; ([^/]+) is the {id}
  Access access;
  Handler handler;
};

// The API (docs/openapi.yaml). The worker protocol is served on the worker port too, alone.
constexpr Route kRoutes[] = {
    {"GET", "/v1/health", Access::Read, get_health},
    {"GET", "/v1/info", Access::Read, get_info},
    {"GET", "/v1/openapi.yaml", Access::Read, get_openapi},
    {"GET", "/v1/studies", Access::Read, list_studies},
    {"POST", "/v1/studies", Access::Token, post_study},
    {"GET", R"(/v1/studies/([^/]+))", Access::Read, get_study},
    {"GET", R"(/v1/studies/([^/]+)/runs)", Access::Read, list_study_runs},
    {"GET", R"(/v1/studies/([^/]+)/results)", Access::Read, get_study_results},
    {"GET", R"(/v1/studies/([^/]+)/plot/error-vs-time)", Access::Read, get_error_vs_time_plot},
    {"GET", R"(/v1/studies/([^/]+)/plot/psd)", Access::Read, get_psd_plot},
    {"POST", R"(/v1/studies/([^/]+)/cancel)", Access::Token, cancel_study},
    {"GET", R"(/v1/runs/([^/]+))", Access::Read, get_run},
    {"GET", R"(/v1/runs/([^/]+)/psd)", Access::Read, get_run_psd},
    {"GET", R"(/v1/runs/([^/]+)/h5)", Access::Read, get_run_h5},
    {"GET", R"(/v1/runs/([^/]+)/result)", Access::Read, get_run_result},
    {"GET", R"(/v1/runs/([^/]+)/plot/impact-spectrum)", Access::Read, get_run_impact_spectrum_plot},
    {"GET", "/v1/regressions", Access::Read, list_regressions},
    {"POST", "/v1/regressions", Access::Token, post_regression},
    {"GET", R"(/v1/regressions/([^/]+))", Access::Read, get_regression},
};
constexpr Route kWorkerRoutes[] = {
    {"POST", "/v1/worker/claim", Access::Token, worker_claim},
    {"POST", R"(/v1/worker/runs/([^/]+)/heartbeat)", Access::Token, worker_heartbeat},
    {"POST", R"(/v1/worker/runs/([^/]+)/finish)", Access::Token, worker_finish},
};

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
    const std::string length = req.get_header_value("Content-Length");  // owns what text views
    const std::string_view text = trimmed(length);
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

}  // namespace

bool is_loopback_host(const std::string& host) {
  return host == "127.0.0.1" || host == "localhost" || host == "::1";
}

ApiServer::ApiServer(ServerConfig config)
    : state_(std::make_unique<ApiState>(std::move(config))),
      http_(std::make_unique<GuardedHttpServer>(state_->config.limits)) {
  const ServerConfig& c = state_->config;
  lock_ = std::make_unique<DatabaseLock>(c.db);
  state_->store = std::make_unique<Store>(c.db);
  // The health probe is answered even over the connection cap (with the token off loopback).
  http_->answer_health_when_busy({"/v1/health", is_loopback_host(c.host) ? "" : "Bearer " + c.token,
                                  "{\"status\": \"ok\"}\n"});
  if (c.worker_port >= 0) {
    // The workers all come from the machines that run them: no per-address share there.
    ConnectionLimits worker_limits = c.limits;
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

std::string ApiServer::serve_bytes(std::string_view request) {
  return http_->serve_bytes(request);
}

ConnectionStats ApiServer::connection_stats() const {
  return http_->stats();
}

void ApiServer::bind() {
  const ServerConfig& c = state_->config;
  const auto bind_one = [&c](httplib::Server& http, int port) {
    // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, with which a second server on the
    // same port would start silently and take half the traffic.
    http.set_socket_options([](int sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    const int bound =
        port == 0 ? http.bind_to_any_port(c.host) : (http.bind_to_port(c.host, port) ? port : -1);
    if (bound < 0)
      throw IoError(concat("cannot listen on ", c.host, ":", port,
                           " (in use, or not an address of this machine)"));
    return bound;
  };
  port_ = bind_one(*http_, c.port);
  http_->widen_backlog();
  if (worker_http_) {
    state_->worker_port = bind_one(*worker_http_, c.worker_port);
    worker_http_->widen_backlog();
  }
}

int ApiServer::bound_worker_port() const {
  return state_->worker_port;
}

void ApiServer::serve() {
  reaper_ = std::thread([this] {
    while (!stopping_) {
      {
        std::lock_guard<std::mutex> lock(state_->store_mutex);
        state_->store->requeue_expired(wall_clock_s());
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

void ApiServer::routes(httplib::Server& s, bool worker_only) {
  // Small replies on a kept-alive connection otherwise wait for Nagle's algorithm and the
  // client's delayed ACK: about 40 ms each from the second request on.
  s.set_tcp_nodelay(true);
  s.set_payload_max_length(state_->config.max_body_bytes);
  s.set_error_handler([this](const Request&, Response& res) {
    if (!res.body.empty()) return;
    if (res.status == 413)
      send_error(res, 413, "body_too_large",
                 concat("the request body exceeds ", state_->config.max_body_bytes, " bytes"));
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
      rearm_memory_reserve();  // the request's memory is freed by now (service/memory_reserve.h)
      return;
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    send_error(res, 500, "internal", what);
  });
  const bool public_reads = !is_loopback_host(state_->config.host);
  const std::string expected = "Bearer " + state_->config.token;
  // Before any body is read (httplib reads it after this handler), for every method alike: a
  // request that carries a body, or whose method takes one, needs the token (401 unread); its
  // Content-Length must be one number (400); a Transfer-Encoding (411: send a Content-Length) or
  // a Content-Encoding other than identity (415: decoded it could be a thousand times the limit)
  // is refused, their names and values compared case-insensitively. The body is then held to
  // max_body_bytes by httplib, and its decoded size is its size.
  s.set_pre_routing_handler([expected](const Request& req, Response& res) {
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
  // One line per request on stderr; a worker's idle polls at most once a minute (request_log.h).
  if (state_->config.request_log)
    s.set_logger([idle_polls = idle_polls_](const Request& req, const Response& res) {
      const double now_s = wall_clock_s();
      std::string note;
      if (is_idle_poll(req.method, req.path, res.status)) {
        const std::optional<long> left_out = idle_polls->note(now_s);
        if (!left_out) return;
        note = concat(" (idle poll; ", *left_out,
                      " more since the last such line, logged at most once a minute)");
      }
      const double ms = GuardedHttpServer::current_request_ms();
      // One write per line, so lines of concurrent requests never interleave.
      char millis[32];
      std::snprintf(millis, sizeof millis, "%.3f", ms);
      const std::string line = concat(iso_utc(now_s), " ", req.method, " ", printable(req.path),
                                      " ", res.status, " ", millis, " ms", note, "\n");
      std::fputs(line.c_str(), stderr);
    });
  // Each route: the request has arrived whole (its receive deadline stops), then the token check
  // (always for writes; for reads off loopback), then the handler.
  const auto add = [&](const Route& r) {
    const bool needs_token = r.access == Access::Token || public_reads;
    auto call = [state = state_.get(), expected, needs_token, handler = r.handler](
                    const Request& req, Response& res) {
      GuardedHttpServer::mark_handler_started();
      if (needs_token && req.get_header_value("Authorization") != expected)
        return send_error(res, 401, "unauthorized", kUnauthorized);
      handler(*state, req, res);
    };
    if (std::string_view(r.method) == "GET")
      s.Get(r.path, call);
    else
      s.Post(r.path, call);
  };
  if (!worker_only)
    for (const Route& r : kRoutes) add(r);
  for (const Route& r : kWorkerRoutes) add(r);
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
      {"/v1/runs/*/plot/impact-spectrum", "GET"},
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
