// Study validation against hostile studies (issue 33): how long expand_study() takes and how
// much memory it holds to refuse each, every case in a child process of its own so its peak
// resident set is its own (getrusage of the child).
//   1. N identical parameters (N = 1000, 2000, 4000): refused as repeats.
//   2. 2,000 parameters the scene does not know: refused, each problem named.
//   3. A 900 kB inline scene x 10,000 runs against the default --max-study-bytes (256 MiB):
//      refused as too large.
// Usage: bench_study_validation
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>

#include "studies/study.h"

using millsim::expand_study;
using nlohmann::json;

namespace {

json small_scene() {
  return json::parse(R"({
    "domain": {"min_m": [0,0,0], "max_m": [1e-3,1e-3,1e-3]},
    "materials": [{"name": "m", "youngs_modulus_pa": 1e9, "poisson_ratio": 0.3,
                   "density_kg_per_m3": 2000, "restitution": 0.5}],
    "sources": [{"type": "list", "material": "m",
                 "particles": [{"position_m": [5e-4,5e-4,5e-4], "diameter_m": 1e-4}]}],
    "seed": 10,
    "time": {"end_s": 1e-5}
  })");
}

json repeated_parameters(int n) {
  json parameters = json::array();
  for (int k = 0; k < n; ++k)
    parameters.push_back({{"path", "time.safety_factor"}, {"values", {0.2}}});
  return {{"name", "repeats"}, {"scene", small_scene()}, {"parameters", parameters}};
}

json unknown_parameters(int n) {
  json parameters = json::array();
  for (int k = 0; k < n; ++k)
    parameters.push_back({{"path", "unknown_" + std::to_string(k)}, {"values", {k}}});
  return {{"name", "unknown"}, {"scene", small_scene()}, {"parameters", parameters}};
}

json huge_scene_many_runs() {
  json scene = small_scene();
  json particles = json::array();
  while (particles.dump().size() < 900000)
    particles.push_back({{"position_m", {5e-4, 5e-4, 5e-4}}, {"diameter_m", 1e-5}});
  scene["sources"][0]["particles"] = particles;
  return {
      {"name", "huge"},
      {"scene", scene},
      {"parameters", {{{"path", "seed"}, {"range", {{"from", 1}, {"to", 10000}, {"step", 1}}}}}}};
}

// Runs `work` in a child; prints its wall time, peak resident set and outcome.
void measure(const char* name, const std::function<json()>& make) {
  const json spec = make();  // built in the parent, so the child's peak is the validation's
  const std::size_t bytes = spec.dump().size();
  int pipe_fd[2];
  if (pipe(pipe_fd) != 0) return;
  const pid_t pid = fork();
  if (pid == 0) {
    close(pipe_fd[0]);
    std::string outcome;
    const auto start = std::chrono::steady_clock::now();
    try {
      const millsim::Study s = expand_study(spec, ".", 10000, nullptr, std::size_t(256) << 20);
      outcome = "accepted (" + std::to_string(s.runs.size()) + " runs)";
    } catch (const millsim::StudyTooLarge&) {
      outcome = "refused: too large (413)";
    } catch (const millsim::InputErrorList& e) {
      outcome = "refused: " + std::to_string(e.errors().size()) + " problems (400)";
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    char line[256];
    const int n = std::snprintf(line, sizeof line, "%.1f|%s", ms, outcome.c_str());
    if (write(pipe_fd[1], line, std::size_t(n)) < 0) _exit(1);
    _exit(0);
  }
  close(pipe_fd[1]);
  char line[256] = {};
  const ssize_t n = read(pipe_fd[0], line, sizeof line - 1);
  close(pipe_fd[0]);
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  const std::string text = n > 0 ? std::string(line, std::size_t(n)) : "?|child failed";
  const std::size_t bar = text.find('|');
  std::printf("| %-36s | %9zu | %9s | %8.1f | %s |\n", name, bytes, text.substr(0, bar).c_str(),
              double(usage.ru_maxrss) / 1024.0, text.substr(bar + 1).c_str());
  std::fflush(stdout);
}

}  // namespace

int main() {
  std::printf("| study | body bytes | ms | peak MB | outcome |\n| --- | --- | --- | --- | --- |\n");
  measure("1,000 identical parameters", [] { return repeated_parameters(1000); });
  measure("2,000 identical parameters", [] { return repeated_parameters(2000); });
  measure("4,000 identical parameters", [] { return repeated_parameters(4000); });
  measure("2,000 unknown parameters", [] { return unknown_parameters(2000); });
  measure("900 kB scene x 10,000 runs", [] { return huge_scene_many_runs(); });
  return 0;
}
