// How far apart this machine's cores are: two threads pinned to two CPUs pass one cache line
// back and forth, and the round trip's mean is printed (issue 35). A thread team's hand-over
// (the epoch a worker waits on, the count the caller waits on) and every cache line one thread
// writes and the other reads cost about one such trip, so the figure bounds what a second core
// can give a run whose step is short: on a machine whose two CPUs share a core complex a trip
// is tens of ns, across complexes or sockets hundreds.
//
//   build/bench/core_to_core [CPU_A CPU_B] [ROUND_TRIPS]      (default: 0 1 2000000)
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

namespace {

alignas(64) std::atomic<long> g_ball{0};

bool pin_to(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  const int cpu_a = argc > 2 ? std::atoi(argv[1]) : 0, cpu_b = argc > 2 ? std::atoi(argv[2]) : 1;
  const long trips = argc > 3 ? std::atol(argv[3]) : 2000000;
  if (cpu_a < 0 || cpu_b < 0 || cpu_a == cpu_b || trips < 1) {
    std::fprintf(stderr, "usage: core_to_core [CPU_A CPU_B] [ROUND_TRIPS]: two different CPUs\n");
    return 2;
  }
  bool pinned_b = true;
  std::thread other([&] {
    pinned_b = pin_to(cpu_b);
    for (long i = 0; i < trips; ++i) {
      while (g_ball.load(std::memory_order_acquire) != 2 * i + 1) {
      }
      g_ball.store(2 * i + 2, std::memory_order_release);
    }
  });
  const bool pinned_a = pin_to(cpu_a);
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < trips; ++i) {
    g_ball.store(2 * i + 1, std::memory_order_release);
    while (g_ball.load(std::memory_order_acquire) != 2 * i + 2) {
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  other.join();
  if (!pinned_a || !pinned_b) {
    std::fprintf(stderr, "core_to_core: cannot pin to CPUs %d and %d\n", cpu_a, cpu_b);
    return 2;
  }
  std::printf("CPUs %d and %d: round trip %.1f ns, one way %.1f ns (%ld trips)\n", cpu_a, cpu_b,
              seconds / double(trips) * 1e9, seconds / double(trips) * 0.5e9, trips);
  return 0;
}
