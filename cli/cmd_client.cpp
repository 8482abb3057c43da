// The service's client verbs, mirroring the HTTP API (docs/openapi.yaml):
//   millsim submit STUDY.json [--wait] [--idempotency-key K]
//   millsim status [STUDY] [--watch]
//   millsim results STUDY [--format table|json|csv]
//   millsim psd RUN
//   millsim cancel STUDY
// Each takes --server URL (default http://127.0.0.1:8080) and --token T (or MILLSIM_TOKEN).
// `submit` sends the scene inline when the study names a file, so the server needs no access to
// the client's files.
#include <unistd.h>

#include <httplib.h>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "cli_args.h"
#include "commands.h"
#include "results.h"

namespace millsim::cli {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;

struct ClientArgs {
  std::string server = "http://127.0.0.1:8080";
  std::string token;
  std::string target;  // study file, study id or run id
  std::string format = "table";
  std::string idempotency_key;
  bool wait = false, watch = false;
};

bool read_client_args(const char* verb, const std::vector<std::string>& args, ClientArgs& a) {
  if (const char* t = std::getenv("MILLSIM_TOKEN")) a.token = t;
  ArgReader r(verb, args);
  while (r.next()) {
    if (r.option("--server", a.server) || r.option("--token", a.token) ||
        r.option("--format", a.format) || r.option("--idempotency-key", a.idempotency_key) ||
        r.positional(a.target))
      continue;
    if (r.is_flag("--wait")) {
      a.wait = true;
      continue;
    }
    if (r.is_flag("--watch")) {
      a.watch = true;
      continue;
    }
    r.unknown(
        "--server URL, --token T, --format table|json|csv, --wait, --watch, "
        "--idempotency-key K");
  }
  if (a.format != "table" && a.format != "json" && a.format != "csv") {
    std::fprintf(stderr, "millsim %s: --format = %s: expected table, json or csv\n", verb,
                 a.format.c_str());
    return false;
  }
  return r.ok();
}

// One request; prints the server's error and returns nullopt when it is not 2xx.
std::optional<json> request(const char* verb, const ClientArgs& a, const std::string& method,
                            const std::string& path, const std::string& body = "",
                            httplib::Headers headers = {}) {
  httplib::Client client(a.server);
  client.set_connection_timeout(5);
  client.set_tcp_nodelay(true);
  if (!a.token.empty()) headers.emplace("Authorization", "Bearer " + a.token);
  auto res = method == "GET" ? client.Get(path.c_str(), headers)
                             : client.Post(path.c_str(), headers, body, "application/json");
  if (!res) {
    std::fprintf(stderr, "millsim %s: cannot reach the server at %s (%s)\n", verb, a.server.c_str(),
                 httplib::to_string(res.error()).c_str());
    return std::nullopt;
  }
  const json parsed = json::parse(res->body, nullptr, false);
  if (res->status >= 300) {
    std::fprintf(stderr, "millsim %s: HTTP %d: %s\n", verb, res->status,
                 parsed.contains("error") ? parsed["error"].value("message", "").c_str()
                                          : res->body.c_str());
    if (parsed.contains("error") && parsed["error"].contains("details"))
      for (const json& d : parsed["error"]["details"])
        std::fprintf(stderr, "  %s = %s: %s\n", d.value("path", "").c_str(),
                     d.value("value", "").c_str(), d.value("allowed", "").c_str());
    return std::nullopt;
  }
  return parsed;
}

int exit_for(const std::optional<json>& j) {
  return j ? kOk : kEnvironment;
}

void print_results(const ordered_json& table, const std::string& format) {
  if (format == "json")
    std::cout << table.dump(2) << std::endl;
  else if (format == "csv")
    std::cout << results_csv(table);
  else
    std::cout << results_text(table);
}

void print_progress_line(const json& study) {
  const json& p = study["progress"];
  const int total = p["total"].get<int>();
  const json& c = p["counts"];
  const int done =
      total - c["QUEUED"].get<int>() - c["RUNNING"].get<int>() - c["CANCELING"].get<int>();
  const int width = 30, filled = total ? width * done / total : width;
  std::fprintf(
      stderr, "\r%s [%s%s] %d/%d  running %d  failed %d%s   ",
      study["id"].get<std::string>().c_str(), std::string(std::size_t(filled), '#').c_str(),
      std::string(std::size_t(width - filled), '.').c_str(), done, total, c["RUNNING"].get<int>(),
      c["EXECUTOR_ERROR"].get<int>() + c["SYSTEM_ERROR"].get<int>(),
      p["eta_s"].is_number()
          ? ("  ETA " + std::to_string(int(p["eta_s"].get<double>())) + " s").c_str()
          : "");
}

// Polls the study until it is finished; a progress bar on a terminal.
std::optional<json> wait_for(const char* verb, const ClientArgs& a, const std::string& id) {
  while (true) {
    std::optional<json> study = request(verb, a, "GET", "/v1/studies/" + id);
    if (!study) return std::nullopt;
    if (isatty(STDERR_FILENO)) print_progress_line(*study);
    if ((*study)["progress"]["finished"].get<bool>()) {
      if (isatty(STDERR_FILENO)) std::fprintf(stderr, "\n");
      return study;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
}

}  // namespace

int cmd_submit(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("submit", args, a)) return kBadInput;
  if (a.target.empty()) {
    std::fprintf(stderr, "usage: millsim submit STUDY.json [--wait] [--server URL] [--token T]\n");
    return kBadInput;
  }
  std::ifstream in(a.target);
  if (!in) {
    std::fprintf(stderr, "millsim submit: cannot read %s\n", a.target.c_str());
    return kBadInput;
  }
  std::stringstream text;
  text << in.rdbuf();
  json spec = json::parse(text.str(), nullptr, false);
  if (spec.is_discarded()) {
    std::fprintf(stderr, "millsim submit: %s is not valid JSON\n", a.target.c_str());
    return kBadInput;
  }
  if (spec.is_object() && spec.contains("scene") && spec["scene"].is_string()) {
    const std::filesystem::path scene =
        std::filesystem::path(a.target).parent_path() / spec["scene"].get<std::string>();
    std::ifstream s(scene);
    std::stringstream scene_text;
    scene_text << s.rdbuf();
    json inline_scene = json::parse(scene_text.str(), nullptr, false);
    if (!s || inline_scene.is_discarded()) {
      std::fprintf(stderr, "millsim submit: /scene: cannot read the scene %s\n",
                   scene.string().c_str());
      return kBadInput;
    }
    spec["scene"] = inline_scene;
  }
  httplib::Headers headers;
  if (!a.idempotency_key.empty()) headers.emplace("Idempotency-Key", a.idempotency_key);
  std::optional<json> reply = request("submit", a, "POST", "/v1/studies", spec.dump(), headers);
  if (!reply) return kBadInput;
  const std::string id = (*reply)["study"].get<std::string>();
  std::printf("%s\n", id.c_str());
  std::fprintf(stderr, "millsim submit: study %s, %d runs%s\n", id.c_str(),
               (*reply)["runs"].get<int>(), (*reply)["created"].get<bool>() ? "" : " (existing)");
  if (!a.wait) return kOk;
  if (!wait_for("submit", a, id)) return kEnvironment;
  std::optional<json> table = request("submit", a, "GET", "/v1/studies/" + id + "/results");
  if (!table) return kEnvironment;
  print_results(ordered_json(*table), a.format);
  return kOk;
}

int cmd_status(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("status", args, a)) return kBadInput;
  if (a.target.empty()) {
    std::optional<json> list = request("status", a, "GET", "/v1/studies");
    if (!list) return kEnvironment;
    for (const json& s : (*list)["studies"]) {
      const json& c = s["progress"]["counts"];
      std::printf("%s  %-28s %3d runs  complete %d  running %d  queued %d  failed %d%s\n",
                  s["id"].get<std::string>().c_str(), s["name"].get<std::string>().c_str(),
                  s["progress"]["total"].get<int>(), c["COMPLETE"].get<int>(),
                  c["RUNNING"].get<int>(), c["QUEUED"].get<int>(),
                  c["EXECUTOR_ERROR"].get<int>() + c["SYSTEM_ERROR"].get<int>(),
                  s["canceled"].get<bool>() ? "  (canceled)" : "");
    }
    return kOk;
  }
  std::optional<json> study = a.watch ? wait_for("status", a, a.target)
                                      : request("status", a, "GET", "/v1/studies/" + a.target);
  if (!study) return kEnvironment;
  std::cout << study->dump(2) << std::endl;
  return kOk;
}

int cmd_results(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("results", args, a) || a.target.empty()) return kBadInput;
  std::optional<json> table = request("results", a, "GET", "/v1/studies/" + a.target + "/results");
  if (!table) return kEnvironment;
  print_results(ordered_json(*table), a.format);
  return kOk;
}

int cmd_psd(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("psd", args, a) || a.target.empty()) return kBadInput;
  std::optional<json> psd = request("psd", a, "GET", "/v1/runs/" + a.target + "/psd");
  if (psd) std::cout << psd->dump(2) << std::endl;
  return exit_for(psd);
}

int cmd_cancel(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("cancel", args, a) || a.target.empty()) return kBadInput;
  std::optional<json> reply =
      request("cancel", a, "POST", "/v1/studies/" + a.target + "/cancel", "{}");
  if (reply) std::printf("%s canceled\n", a.target.c_str());
  return exit_for(reply);
}

}  // namespace millsim::cli
