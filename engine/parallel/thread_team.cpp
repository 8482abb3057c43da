#include "parallel/thread_team.h"

#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <thread>
#include <vector>

namespace millsim {
namespace {

inline void spin_pause() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

// Waits until `value` no longer holds `old`: spins for up to kSpinSeconds (the next loop of a
// step usually comes within that: the serial work between two loops is some microseconds to a
// fraction of a millisecond, and a futex wake-up costs 30-40 us here, as much as a whole loop),
// yielding now and then so that a busy machine's other threads get the core, then sleeps on the
// futex.
constexpr double kSpinSeconds = 2e-3;

template <class T>
T wait_while_equal(const std::atomic<T>& value, T old) {
  constexpr int kYieldEvery = 256;
  const auto spin_end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(kSpinSeconds);
  for (int spin = 1;; ++spin) {
    const T now = value.load(std::memory_order_acquire);
    if (now != old) return now;
    if (spin % kYieldEvery != 0) {
      spin_pause();
      continue;
    }
    if (std::chrono::steady_clock::now() > spin_end) break;
    std::this_thread::yield();
  }
  for (;;) {
    value.wait(old, std::memory_order_acquire);
    const T now = value.load(std::memory_order_acquire);
    if (now != old) return now;
  }
}

thread_local bool t_inside_loop = false;

class Team {
 public:
  ~Team() { stop_workers(); }

  int threads() const { return threads_; }
  std::uint64_t loops_run() const { return loops_run_; }

  void resize(int n) {
    if (n == threads_) return;
    stop_workers();
    threads_ = n;
    errors_.assign(std::size_t(n), nullptr);
    stop_.store(false, std::memory_order_relaxed);
    // A new worker waits for the loop after the last one started.
    const std::uint32_t epoch = epoch_.load(std::memory_order_relaxed);
    for (int t = 1; t < n; ++t) workers_.emplace_back([this, t, epoch] { work(t, epoch); });
  }

  void run(std::size_t blocks, void (*body)(void*, std::size_t), void* context) {
    ++loops_run_;
    blocks_ = blocks, body_ = body, context_ = context;
    pending_.store(threads_ - 1, std::memory_order_relaxed);
    epoch_.fetch_add(1, std::memory_order_release);
    epoch_.notify_all();
    run_share(0);
    for (int left = pending_.load(std::memory_order_acquire); left != 0;)
      left = wait_while_equal(pending_, left);
    for (std::exception_ptr& e : errors_)
      if (e) {
        std::exception_ptr first = e;
        for (std::exception_ptr& x : errors_) x = nullptr;
        std::rethrow_exception(first);
      }
  }

 private:
  void run_share(int t) {
    const std::size_t n = std::size_t(threads_);
    const std::size_t begin = blocks_ * std::size_t(t) / n, end = blocks_ * std::size_t(t + 1) / n;
    t_inside_loop = true;
    try {
      for (std::size_t b = begin; b < end; ++b) body_(context_, b);
    } catch (...) {
      errors_[std::size_t(t)] = std::current_exception();
    }
    t_inside_loop = false;
  }

  void work(int t, std::uint32_t seen) {
    for (;;) {
      seen = wait_while_equal(epoch_, seen);
      if (stop_.load(std::memory_order_acquire)) return;
      run_share(t);
      if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) pending_.notify_one();
    }
  }

  void stop_workers() {
    if (workers_.empty()) return;
    stop_.store(true, std::memory_order_release);
    epoch_.fetch_add(1, std::memory_order_release);
    epoch_.notify_all();
    for (std::thread& w : workers_) w.join();
    workers_.clear();
  }

  int threads_ = 1;
  std::uint64_t loops_run_ = 0;
  std::vector<std::thread> workers_;
  std::vector<std::exception_ptr> errors_{nullptr};
  // The loop under way: written before epoch_ moves on, read by the workers after they see it.
  std::size_t blocks_ = 0;
  void (*body_)(void*, std::size_t) = nullptr;
  void* context_ = nullptr;
  std::atomic<std::uint32_t> epoch_{0};
  std::atomic<int> pending_{0};
  std::atomic<bool> stop_{false};
};

Team& team() {
  static Team t;
  return t;
}

}  // namespace

int usable_core_count() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return n;
  }
  const unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? int(n) : 1;
}

void set_thread_count(int n) {
  team().resize(n < 1 ? 1 : n);
}

int thread_count() {
  return team().threads();
}

std::uint64_t loops_run_on_team() {
  return team().loops_run();
}

namespace {
std::size_t g_block_divisor = 1;
}

void set_block_divisor(std::size_t divisor) {
  g_block_divisor = divisor > 0 ? divisor : 1;
}

std::size_t block_divisor() {
  return g_block_divisor;
}

namespace detail {

void run_blocks(std::size_t blocks, void (*body)(void*, std::size_t), void* context) {
  if (t_inside_loop) {  // a loop inside a loop: this thread alone
    for (std::size_t b = 0; b < blocks; ++b) body(context, b);
    return;
  }
  team().run(blocks, body, context);
}

}  // namespace detail
}  // namespace millsim
