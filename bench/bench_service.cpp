// Service benchmark: queue throughput and API latency, on this machine, in one process.
//   1. Queue: a study of N trivial runs; 2 claimers, each with its own SQLite connection, claim
//      and finish runs until none is left (runs/s), directly on the Store and over HTTP
//      (the worker protocol against an in-process server on loopback).
//   2. API latency: 1000 completed runs with realistic result.json bodies (an outlet PSD of 40
//      classes); C concurrent clients GET a study's status and its results table; p50/p99.
// Usage: bench_service [--runs N] [--clients C] [--requests R]
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <thread>
#include <vector>

#include "http/api_server.h"
#include "queue/store.h"

using namespace millsim;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

Study trivial_study(int runs) {
  Study s;
  s.name = "bench";
  s.spec = {{"name", "bench"}};
  s.error_metric = "psd_ks";
  s.reference_index = 0;
  for (int k = 0; k < runs; ++k) {
    StudyRun r;
    r.index = k;
    r.params = {{"dust.threshold_diameter_m", 1e-5 * (k + 1)}};
    r.scene = {{"seed", k}};
    r.is_reference = k == 0;
    s.runs.push_back(r);
  }
  return s;
}

std::string fake_result(int k) {
  std::vector<double> edges, cumulative, mass;
  for (int b = 0; b <= 40; ++b) {
    edges.push_back(1e-6 * std::pow(1.2, b));
    cumulative.push_back(std::min(1.0, b / (40.0 - k % 7)));
    if (b < 40) mass.push_back(1e-9);
  }
  json psd = {{"edges_m", edges}, {"cumulative_mass", cumulative},
              {"mass_kg", mass},  {"count", mass},
              {"d10_m", 2e-6},    {"d50_m", 1e-5 * (1 + k % 5)},
              {"d90_m", 4e-5},    {"total_mass_kg", 4e-8}};
  return json({{"status", "ok"},
               {"particle_steps_per_second", 2e7},
               {"phase_seconds", {{"forces", 1.0}, {"neighbors", 0.5}}},
               {"outlet_psd", psd}})
      .dump();
}

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(p * double(v.size())))];
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 2000, clients = 4, requests = 200;
  for (int k = 1; k + 1 < argc; k += 2) {
    if (!std::strcmp(argv[k], "--runs")) runs = std::atoi(argv[k + 1]);
    if (!std::strcmp(argv[k], "--clients")) clients = std::atoi(argv[k + 1]);
    if (!std::strcmp(argv[k], "--requests")) requests = std::atoi(argv[k + 1]);
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("millsim-bench-service-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);

  // 1a. Queue throughput on the Store.
  {
    Store store(dir / "direct.db");
    const std::string id = store.submit(trivial_study(runs), std::nullopt, dir, 0).study_id;
    const auto start = Clock::now();
    std::vector<std::thread> threads;
    for (int w = 0; w < 2; ++w)
      threads.emplace_back([&, w] {
        Store own(dir / "direct.db");
        while (auto c = own.claim(std::string(1, char('a' + w)), 60, 1.0)) {
          FinishReport done;
          done.result = "{}";
          own.finish(c->run.id, c->token, done, 2.0);
        }
      });
    for (auto& t : threads) t.join();
    const double s = seconds_since(start);
    std::printf("queue (Store, 2 claimers): %d runs claimed and finished in %.2f s: %.0f runs/s\n",
                store.progress(id).count(RunState::Complete), s, runs / s);
  }

  // 1b. The same over HTTP, and 2. API latency, against an in-process server.
  ServerConfig config;
  config.port = 0;
  config.db = dir / "http.db";
  config.out_root = dir / "runs";
  config.token = "bench";
  ApiServer server(config);
  server.bind();
  std::thread http([&] { server.serve(); });
  const std::string url = "http://127.0.0.1:" + std::to_string(server.bound_port());
  const httplib::Headers auth = {{"Authorization", "Bearer bench"}};
  std::string id;
  {
    Store store(config.db);
    id = store.submit(trivial_study(runs), std::nullopt, config.out_root, 0).study_id;
  }
  {
    const auto start = Clock::now();
    std::vector<std::thread> threads;
    std::vector<int> done(2, 0);
    for (int w = 0; w < 2; ++w)
      threads.emplace_back([&, w] {
        httplib::Client c(url);
        while (true) {
          auto r = c.Post("/v1/worker/claim", auth,
                          json({{"worker", "w" + std::to_string(w)}}).dump(), "application/json");
          if (!r || r->status != 200) break;
          const json claim = json::parse(r->body);
          const std::string run = claim["run"]["id"];
          const int index = claim["run"]["index"];
          json report = {{"token", claim["token"]},
                         {"state", "COMPLETE"},
                         {"retryable", false},
                         {"exit_code", 0},
                         {"error", ""},
                         {"wall_time_s", 1.0},
                         {"result", fake_result(index)}};
          c.Post(("/v1/worker/runs/" + run + "/finish").c_str(), auth, report.dump(),
                 "application/json");
          ++done[std::size_t(w)];
        }
      });
    for (auto& t : threads) t.join();
    const double s = seconds_since(start);
    std::printf("queue (HTTP worker protocol, 2 workers): %d runs in %.2f s: %.0f runs/s\n",
                done[0] + done[1], s, (done[0] + done[1]) / s);
  }
  for (const bool keep_alive : {false, true})
    for (const char* what : {"status", "results"}) {
      const std::string path =
          std::string("/v1/studies/") + id + (what[0] == 'r' ? "/results" : "");
      std::vector<std::vector<double>> latency(static_cast<std::size_t>(clients));
      const auto start = Clock::now();
      std::vector<std::thread> threads;
      for (int c = 0; c < clients; ++c)
        threads.emplace_back([&, c] {
          httplib::Client client(url);
          client.set_keep_alive(keep_alive);  // one connection for all requests, as browsers do
          for (int k = 0; k < requests; ++k) {
            const auto t = Clock::now();
            auto r = client.Get(path.c_str());
            if (r && r->status == 200) latency[std::size_t(c)].push_back(seconds_since(t) * 1e3);
          }
        });
      for (auto& t : threads) t.join();
      std::vector<double> all;
      for (const auto& l : latency) all.insert(all.end(), l.begin(), l.end());
      std::printf(
          "GET %s with %d runs stored, %d clients x %d requests%s: p50 %.2f ms, p99 %.2f ms, "
          "%.0f requests/s\n",
          what, runs, clients, requests, keep_alive ? " (keep-alive)" : "", percentile(all, 0.5),
          percentile(all, 0.99), double(all.size()) / seconds_since(start));
    }
  server.stop();
  http.join();
  std::filesystem::remove_all(dir);
  return 0;
}
