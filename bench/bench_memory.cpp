// What this machine's memory gives a second thread: a streaming pass (c = a + s·b over doubles,
// 24 bytes moved per element, the shape of the integrator's passes) run through the engine's own
// team (parallel/thread_team.h, blocks of 4096 elements) at 1 and 2 threads, on arrays that fit
// one core's L2, the shared L3, or neither. The ratio is the most a pass bound by that level of
// memory can gain from threads here, whatever the code (docs/threads.md, "What the machine
// allows").
//
//   bench_memory [--rounds N] [--json]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "parallel/thread_team.h"

namespace {

using Clock = std::chrono::steady_clock;

// Bytes per second of `passes` triads over arrays of n doubles on the current team.
double triad_bytes_per_s(std::size_t n, int passes) {
  std::vector<double> a(n, 1.0), b(n, 2.0), c(n, 0.0);
  constexpr std::size_t kBlock = 4096;
  auto pass = [&] {
    millsim::parallel_ranges_if(millsim::thread_count() > 1, n, kBlock,
                                [&](std::size_t begin, std::size_t end, std::size_t) {
                                  for (std::size_t i = begin; i < end; ++i)
                                    c[i] = a[i] + 1.5 * b[i];
                                });
  };
  pass();  // pages touched, caches warm
  const auto start = Clock::now();
  for (int p = 0; p < passes; ++p) pass();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (c[n / 2] != 4.0) std::abort();  // keeps the passes
  return 3.0 * 8.0 * double(n) * passes / seconds;
}

}  // namespace

int main(int argc, char** argv) {
  int rounds = 3;
  bool as_json = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--rounds") == 0 && i + 1 < argc) {
      rounds = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--json") == 0) {
      as_json = true;
    } else {
      std::fprintf(stderr, "usage: bench_memory [--rounds N] [--json]\n");
      return 2;
    }
  }
  if (rounds < 1) rounds = 1;
  struct Size {
    const char* level;
    std::size_t elements;
    int passes;
  };
  // Three arrays: 1.5 MB (inside one core's 2 MB L2 at one thread, half of it on each of two),
  // 12 MB (inside the 32 MB L3), 768 MB (memory).
  const Size sizes[] = {{"L2", std::size_t(1) << 16, 4000},
                        {"L3", std::size_t(1) << 19, 400},
                        {"DRAM", std::size_t(1) << 25, 8}};
  if (as_json) std::printf("[");
  bool first = true;
  for (const Size& s : sizes)
    for (int round = 0; round < rounds; ++round) {
      // One and two threads alternate within a round, so the machine's drift hits both.
      millsim::set_thread_count(1);
      const double one = triad_bytes_per_s(s.elements, s.passes);
      millsim::set_thread_count(2);
      const double two = triad_bytes_per_s(s.elements, s.passes);
      if (as_json) {
        std::printf(
            "%s\n {\"level\": \"%s\", \"bytes\": %zu, \"round\": %d, "
            "\"one_thread_gb_per_s\": %.2f, \"two_threads_gb_per_s\": %.2f, "
            "\"ratio\": %.3f}",
            first ? "" : ",", s.level, 24 * s.elements, round, one / 1e9, two / 1e9, two / one);
      } else {
        std::printf("%-5s %8.1f MB  1 thread %7.2f GB/s  2 threads %7.2f GB/s  ratio %.2f\n",
                    s.level, 24.0 * double(s.elements) / 1e6, one / 1e9, two / 1e9, two / one);
      }
      first = false;
    }
  if (as_json) std::printf("\n]\n");
  millsim::set_thread_count(1);
  return 0;
}
