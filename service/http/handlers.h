// What the HTTP API's handlers share, and the handlers themselves, one named function per
// route (the route table in api_server.cpp maps methods and paths to them). Internal to http/;
// cpp-httplib's types come through http_limits.h, the one file of the server that includes it.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "http/api_server.h"
#include "http/http_limits.h"
#include "queue/store.h"

namespace millsim {

// The state every handler reads: the configuration, the store behind its one mutex, and the
// results tables cached per study.
struct ApiState {
  explicit ApiState(ServerConfig c) : config(std::move(c)) {}
  ServerConfig config;
  std::unique_ptr<Store> store;
  std::mutex store_mutex;  // every use of the store holds it
  int worker_port = -1;    // the bound worker port, for /v1/info
  struct CachedTable {
    std::string signature;
    nlohmann::ordered_json table;
  };
  std::map<std::string, CachedTable> results_cache;
  // The study's results table, rebuilt only when one of its runs changed (store_mutex held).
  const nlohmann::ordered_json& cached_results(const std::string& study_id);
};

using Handler = void (*)(ApiState&, const httplib::Request&, httplib::Response&);

// Replies (http/replies.cpp).
void send_json(httplib::Response& res, int status, const nlohmann::ordered_json& body);
void send_error(httplib::Response& res, int status, const std::string& code,
                const std::string& message, const nlohmann::ordered_json& details = nullptr);
// An integer query parameter within [lo, hi] (default `fallback`); false after a 400.
bool query_int(const httplib::Request& req, httplib::Response& res, const char* name, int fallback,
               int lo, int hi, int& out);
// The body as JSON; false after a 400.
bool parse_body(const httplib::Request& req, httplib::Response& res, nlohmann::json& out);
nlohmann::ordered_json run_json(const RunRecord& r, bool with_scene);
bool is_study_id(std::string_view s);       // "s" and six digits
bool is_run_id(std::string_view s);         // a study id, "-r" and 1-9 digits
bool is_regression_id(std::string_view s);  // "g" and six digits

// Studies (http/handlers_studies.cpp).
void get_health(ApiState&, const httplib::Request&, httplib::Response&);
void get_info(ApiState&, const httplib::Request&, httplib::Response&);
void get_openapi(ApiState&, const httplib::Request&, httplib::Response&);
void post_study(ApiState&, const httplib::Request&, httplib::Response&);
void list_studies(ApiState&, const httplib::Request&, httplib::Response&);
void get_study(ApiState&, const httplib::Request&, httplib::Response&);
void list_study_runs(ApiState&, const httplib::Request&, httplib::Response&);
void get_study_results(ApiState&, const httplib::Request&, httplib::Response&);
void get_error_vs_time_plot(ApiState&, const httplib::Request&, httplib::Response&);
void get_psd_plot(ApiState&, const httplib::Request&, httplib::Response&);
void cancel_study(ApiState&, const httplib::Request&, httplib::Response&);

// Runs and regression records (http/handlers_runs.cpp).
void get_run(ApiState&, const httplib::Request&, httplib::Response&);
void get_run_psd(ApiState&, const httplib::Request&, httplib::Response&);
void get_run_h5(ApiState&, const httplib::Request&, httplib::Response&);
void get_run_result(ApiState&, const httplib::Request&, httplib::Response&);
void get_run_impact_spectrum_plot(ApiState&, const httplib::Request&, httplib::Response&);
void post_regression(ApiState&, const httplib::Request&, httplib::Response&);
void list_regressions(ApiState&, const httplib::Request&, httplib::Response&);
void get_regression(ApiState&, const httplib::Request&, httplib::Response&);

// The worker protocol (http/handlers_worker.cpp): claim, heartbeat, finish, each with the
// run's fencing token.
void worker_claim(ApiState&, const httplib::Request&, httplib::Response&);
void worker_heartbeat(ApiState&, const httplib::Request&, httplib::Response&);
void worker_finish(ApiState&, const httplib::Request&, httplib::Response&);

}  // namespace millsim
