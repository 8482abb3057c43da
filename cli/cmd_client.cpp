// The service's client verbs, mirroring the HTTP API (docs/openapi.yaml):
//   millsim submit STUDY.json [--wait] [--idempotency-key K]
//   millsim status [STUDY] [--watch]
//   millsim results STUDY [--format table|json|csv]
//   millsim psd RUN
//   millsim cancel STUDY
// Each takes --server URL (default http://127.0.0.1:8080) and --token-file FILE (or MILLSIM_TOKEN).
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
#include "core/json_reader.h"
#include "help.h"
#include "studies/results.h"

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
    if (r.option("--server", a.server) || r.token_option(a.token) ||
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
        "--server URL, --token-file FILE, --format table|json|csv, --wait, --watch, "
        "--idempotency-key K");
  }
  if (a.format != "table" && a.format != "json" && a.format != "csv") {
    std::fprintf(stderr, "millsim %s: --format = %s: expected table, json or csv\n", verb,
                 a.format.c_str());
    return false;
  }
  return r.ok();
}

// One request's outcome: the reply's JSON when 2xx, else the exit code of the failure (4 for a
// server that cannot be reached, 2 for a 4xx: the request was wrong, 1 for a 5xx).
struct Reply {
  std::optional<json> body;
  int exit_code = kOk;
  explicit operator bool() const { return body.has_value(); }
  const json& operator*() const { return *body; }
  const json* operator->() const { return &*body; }
};

// One request; prints the server's error when it is not 2xx.
Reply request(const char* verb, const ClientArgs& a, const std::string& method,
              const std::string& path, const std::string& body = "",
              httplib::Headers headers = {}) {
  httplib::Client client(a.server);
  client.set_connection_timeout(30);  // a busy server or machine is slow, not gone
  client.set_read_timeout(60);
  client.set_tcp_nodelay(true);
  if (!a.token.empty()) headers.emplace("Authorization", "Bearer " + a.token);
  auto res = method == "GET" ? client.Get(path.c_str(), headers)
                             : client.Post(path.c_str(), headers, body, "application/json");
  if (!res) {
    std::fprintf(stderr, "millsim %s: cannot reach the server at %s (%s)\n", verb, a.server.c_str(),
                 httplib::to_string(res.error()).c_str());
    return {std::nullopt, kEnvironment};
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
    return {std::nullopt, res->status >= 500 ? kUnexpected : kBadInput};
  }
  return {parsed, kOk};
}

void print_results(const ordered_json& table, const std::string& format) {
  if (format == "json")
    std::cout << table.dump(2) << std::endl;
  else if (format == "csv")
    std::cout << results_csv(table);
  else
    std::cout << results_text(table);
}

// On a terminal a bar redrawn; off one (a log, CI) a line each time a run starts or ends.
void print_progress_line(const json& study) {
  static int last_done = -1, last_running = -1;
  const json& p = study["progress"];
  const int total = p["total"].get<int>();
  const json& c = p["counts"];
  const int done =
      total - c["QUEUED"].get<int>() - c["RUNNING"].get<int>() - c["CANCELING"].get<int>();
  if (!isatty(STDERR_FILENO)) {
    if (done == last_done && c["RUNNING"].get<int>() == last_running) return;
    last_done = done, last_running = c["RUNNING"].get<int>();
    std::fprintf(stderr, "%s %d/%d done, running %d, failed %d\n",
                 study["id"].get<std::string>().c_str(), done, total, c["RUNNING"].get<int>(),
                 c["EXECUTOR_ERROR"].get<int>() + c["SYSTEM_ERROR"].get<int>());
    return;
  }
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

// Polls the study until it is finished, with its progress on stderr.
Reply wait_for(const char* verb, const ClientArgs& a, const std::string& id) {
  while (true) {
    Reply study = request(verb, a, "GET", "/v1/studies/" + id);
    if (!study) return study;
    print_progress_line(*study);
    if ((*study)["progress"]["finished"].get<bool>()) {
      if (isatty(STDERR_FILENO)) std::fprintf(stderr, "\n");
      return study;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
}

int failed_runs(const json& study) {
  const json& c = study["progress"]["counts"];
  return c["EXECUTOR_ERROR"].get<int>() + c["SYSTEM_ERROR"].get<int>();
}

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// The study list as a table or CSV (JSON is printed as it came).
void print_study_list(const json& list, const std::string& format) {
  static const char* kStates[] = {"COMPLETE",       "RUNNING",      "QUEUED",
                                  "EXECUTOR_ERROR", "SYSTEM_ERROR", "CANCELED"};
  if (format == "csv") {
    std::printf(
        "study,name,runs,complete,running,queued,executor_error,system_error,canceled,"
        "study_canceled\n");
    for (const json& s : list["studies"]) {
      std::printf("%s,%s,%d", s["id"].get<std::string>().c_str(),
                  csv_field(s["name"].get<std::string>()).c_str(),
                  s["progress"]["total"].get<int>());
      for (const char* state : kStates)
        std::printf(",%d", s["progress"]["counts"][state].get<int>());
      std::printf(",%s\n", s["canceled"].get<bool>() ? "true" : "false");
    }
    return;
  }
  std::printf("%-8s %-32s %5s %9s %8s %7s %7s\n", "study", "name", "runs", "complete", "running",
              "queued", "failed");
  for (const json& s : list["studies"]) {
    const json& c = s["progress"]["counts"];
    std::printf("%-8s %-32s %5d %9d %8d %7d %7d%s\n", s["id"].get<std::string>().c_str(),
                std::string(utf8_prefix(s["name"].get<std::string>(), 32)).c_str(),
                s["progress"]["total"].get<int>(), c["COMPLETE"].get<int>(),
                c["RUNNING"].get<int>(), c["QUEUED"].get<int>(), failed_runs(s),
                s["canceled"].get<bool>() ? "  (canceled)" : "");
  }
}

// One study's progress and runs as a table or CSV.
void print_study(const json& study, const json& runs, const std::string& format) {
  if (format == "csv") {
    std::printf("run,state,attempts,wall_time_s,params,error\n");
    for (const json& r : runs["runs"])
      std::printf("%s,%s,%d,%.6g,%s,%s\n", r["id"].get<std::string>().c_str(),
                  r["state"].get<std::string>().c_str(), r["attempts"].get<int>(),
                  r["wall_time_s"].get<double>(), csv_field(r["params"].dump()).c_str(),
                  csv_field(r["error"].get<std::string>().substr(
                                0, r["error"].get<std::string>().find('\n')))
                      .c_str());
    return;
  }
  const json& p = study["progress"];
  std::printf("study %s  %s%s\n", study["id"].get<std::string>().c_str(),
              study["name"].get<std::string>().c_str(),
              study["canceled"].get<bool>() ? "  (canceled)" : "");
  std::printf("runs %d:", p["total"].get<int>());
  for (const auto& [state, count] : p["counts"].items())
    if (count.get<int>() > 0) std::printf("  %s %d", state.c_str(), count.get<int>());
  std::printf("%s\n", p["finished"].get<bool>() ? "  (finished)" : "");
  if (p["eta_s"].is_number() && !p["finished"].get<bool>())
    std::printf("ETA %.0f s\n", p["eta_s"].get<double>());
  std::printf("\n%-18s %-15s %8s %10s  %s\n", "run", "state", "attempts", "wall s", "params");
  for (const json& r : runs["runs"]) {
    std::printf("%-18s %-15s %8d %10.1f  %s\n", r["id"].get<std::string>().c_str(),
                r["state"].get<std::string>().c_str(), r["attempts"].get<int>(),
                r["wall_time_s"].get<double>(), r["params"].dump().c_str());
    const std::string error = r["error"].get<std::string>();
    if (!error.empty() && r["state"] != "COMPLETE")
      std::printf("%18s %s\n", "", error.substr(0, error.find('\n')).c_str());
  }
  if (runs["runs"].size() < std::size_t(p["total"].get<int>()))
    std::printf("(the first %zu runs; millsim results %s for all)\n", runs["runs"].size(),
                study["id"].get<std::string>().c_str());
}

// A missing argument: the verb's usage, exit 2.
int missing(const char* verb, const char* what) {
  std::fprintf(stderr, "millsim %s: missing %s\n", verb, what);
  print_verb_usage(verb, stderr);
  return kBadInput;
}

}  // namespace

int cmd_submit(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("submit", args, a)) return kBadInput;
  if (a.target.empty()) return missing("submit", "the study file");
  std::ifstream in(a.target);
  if (!in) {
    std::fprintf(stderr, "millsim submit: cannot read %s\n", a.target.c_str());
    return kBadInput;
  }
  std::stringstream text;
  text << in.rdbuf();
  // The study and its scene as the server will parse them (nesting at most kMaxJsonDepth).
  auto parse = [](const std::string& t) {
    try {
      return parse_untrusted_json(t);
    } catch (const std::exception&) {
      return json(json::value_t::discarded);
    }
  };
  json spec = parse(text.str());
  if (spec.is_discarded()) {
    std::fprintf(stderr, "millsim submit: %s is not valid JSON (or nests deeper than %d levels)\n",
                 a.target.c_str(), kMaxJsonDepth);
    return kBadInput;
  }
  if (spec.is_object() && spec.contains("scene") && spec["scene"].is_string()) {
    const std::filesystem::path scene =
        std::filesystem::path(a.target).parent_path() / spec["scene"].get<std::string>();
    std::ifstream s(scene);
    std::stringstream scene_text;
    scene_text << s.rdbuf();
    json inline_scene = parse(scene_text.str());
    if (!s || inline_scene.is_discarded()) {
      std::fprintf(stderr, "millsim submit: /scene: cannot read the scene %s\n",
                   scene.string().c_str());
      return kBadInput;
    }
    spec["scene"] = inline_scene;
  }
  httplib::Headers headers;
  if (!a.idempotency_key.empty()) headers.emplace("Idempotency-Key", a.idempotency_key);
  Reply reply = request("submit", a, "POST", "/v1/studies", spec.dump(), headers);
  if (!reply) return reply.exit_code;
  const std::string id = (*reply)["study"].get<std::string>();
  std::printf("%s\n", id.c_str());
  std::fprintf(stderr, "millsim submit: study %s, %d runs%s\n", id.c_str(),
               (*reply)["runs"].get<int>(), (*reply)["created"].get<bool>() ? "" : " (existing)");
  if (!a.wait) return kOk;
  Reply study = wait_for("submit", a, id);
  if (!study) return study.exit_code;
  Reply table = request("submit", a, "GET", "/v1/studies/" + id + "/results");
  if (!table) return table.exit_code;
  print_results(ordered_json(*table), a.format);
  return failed_runs(*study) > 0 ? kUnexpected : kOk;
}

int cmd_status(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("status", args, a)) return kBadInput;
  if (a.target.empty()) {
    Reply list = request("status", a, "GET", "/v1/studies");
    if (!list) return list.exit_code;
    if (a.format == "json")
      std::cout << list->dump(2) << std::endl;
    else
      print_study_list(*list, a.format);
    return kOk;
  }
  Reply study = a.watch ? wait_for("status", a, a.target)
                        : request("status", a, "GET", "/v1/studies/" + a.target);
  if (!study) return study.exit_code;
  if (a.format == "json") {
    std::cout << study->dump(2) << std::endl;
    return kOk;
  }
  Reply runs = request("status", a, "GET", "/v1/studies/" + a.target + "/runs?limit=1000");
  if (!runs) return runs.exit_code;
  print_study(*study, *runs, a.format);
  return kOk;
}

int cmd_results(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("results", args, a)) return kBadInput;
  if (a.target.empty()) return missing("results", "the study id");
  Reply table = request("results", a, "GET", "/v1/studies/" + a.target + "/results");
  if (!table) return table.exit_code;
  print_results(ordered_json(*table), a.format);
  return kOk;
}

int cmd_psd(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("psd", args, a)) return kBadInput;
  if (a.target.empty()) return missing("psd", "the run id");
  Reply psd = request("psd", a, "GET", "/v1/runs/" + a.target + "/psd");
  if (!psd) return psd.exit_code;
  std::cout << psd->dump(2) << std::endl;
  return kOk;
}

int cmd_cancel(const std::vector<std::string>& args) {
  ClientArgs a;
  if (!read_client_args("cancel", args, a)) return kBadInput;
  if (a.target.empty()) return missing("cancel", "the study id");
  Reply reply = request("cancel", a, "POST", "/v1/studies/" + a.target + "/cancel", "{}");
  if (!reply) return reply.exit_code;
  std::printf("%s canceled\n", a.target.c_str());
  return kOk;
}

}  // namespace millsim::cli
