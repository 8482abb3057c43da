#include "parallel/thread_team.h"

#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <memory>
#include <stdexcept>
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
    error_block_.assign(std::size_t(n), 0);
    shares_ = std::make_unique<Share[]>(std::size_t(n));
    stop_.store(false, std::memory_order_relaxed);
    // A new worker waits for the loop after the last one started.
    const std::uint32_t epoch = epoch_.load(std::memory_order_relaxed);
    for (int t = 1; t < n; ++t) workers_.emplace_back([this, t, epoch] { work(t, epoch); });
  }

  // `bounds` (threads + 1 entries, or null for equal shares): thread t's share is blocks
  // [bounds[t], bounds[t + 1]). `steal`: whether a thread done with its own share takes blocks
  // from the others'.
  void run(std::size_t blocks, void (*body)(void*, std::size_t), void* context,
           const std::size_t* bounds, bool steal) {
    ++loops_run_;
    body_ = body, context_ = context, steal_ = steal;
    const std::size_t n = std::size_t(threads_);
    for (std::size_t t = 0; t < n; ++t) {
      const std::uint64_t begin = bounds ? bounds[t] : blocks * t / n;
      const std::uint64_t end = bounds ? bounds[t + 1] : blocks * (t + 1) / n;
      shares_[t].range.store(begin | end << 32, std::memory_order_relaxed);
    }
    pending_.store(threads_ - 1, std::memory_order_relaxed);
    epoch_.fetch_add(1, std::memory_order_release);
    epoch_.notify_all();
    run_share(0);
    for (int left = pending_.load(std::memory_order_acquire); left != 0;)
      left = wait_while_equal(pending_, left);
    std::size_t first = n;
    for (std::size_t t = 0; t < n; ++t)
      if (errors_[t] && (first == n || error_block_[t] < error_block_[first])) first = t;
    if (first == n) return;
    std::exception_ptr error = errors_[first];
    for (std::exception_ptr& e : errors_) e = nullptr;
    std::rethrow_exception(error);
  }

 private:
  // A share's blocks not yet claimed, [begin, end), packed as begin | end << 32: its owner claims
  // from the front, a thread done with its own share from the back, so that the owner keeps the
  // particles it runs every step and a thief takes the ones it would reach last.
  static bool claim_front(std::atomic<std::uint64_t>& range, std::size_t& block) {
    std::uint64_t r = range.load(std::memory_order_relaxed);
    for (;;) {
      const std::uint64_t begin = r & 0xffffffffu, end = r >> 32;
      if (begin >= end) return false;
      if (range.compare_exchange_weak(r, (begin + 1) | end << 32, std::memory_order_relaxed)) {
        block = std::size_t(begin);
        return true;
      }
    }
  }
  static bool claim_back(std::atomic<std::uint64_t>& range, std::size_t& block) {
    std::uint64_t r = range.load(std::memory_order_relaxed);
    for (;;) {
      const std::uint64_t begin = r & 0xffffffffu, end = r >> 32;
      if (begin >= end) return false;
      if (range.compare_exchange_weak(r, begin | (end - 1) << 32, std::memory_order_relaxed)) {
        block = std::size_t(end - 1);
        return true;
      }
    }
  }

  // Thread t's blocks: its own share from the front, then (when the loop allows it) what is
  // left of the others' shares, from their backs, so that a thread held up (a slower block, a
  // core lent to another process for a moment) does not hold up the loop. Which thread runs a
  // block never changes what the block computes.
  void run_share(int t) {
    const std::size_t n = std::size_t(threads_);
    t_inside_loop = true;
    std::size_t b = 0;
    try {
      while (claim_front(shares_[std::size_t(t)].range, b)) body_(context_, b);
      for (std::size_t k = 1; steal_ && k < n; ++k) {
        Share& share = shares_[(std::size_t(t) + k) % n];
        while (claim_back(share.range, b)) body_(context_, b);
      }
    } catch (...) {
      errors_[std::size_t(t)] = std::current_exception();
      error_block_[std::size_t(t)] = b;
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
  std::vector<std::size_t> error_block_{0};  // the block that threw errors_[t]
  // The loop under way: written before epoch_ moves on, read by the workers after they see it.
  struct alignas(64) Share {
    std::atomic<std::uint64_t> range{0};  // unclaimed blocks (claim_front, claim_back)
  };
  std::unique_ptr<Share[]> shares_ = std::make_unique<Share[]>(1);
  void (*body_)(void*, std::size_t) = nullptr;
  void* context_ = nullptr;
  bool steal_ = true;
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

bool inside_parallel_loop() {
  return t_inside_loop;
}

void wait_until_at_least(const std::atomic<std::uint32_t>& counter, std::uint32_t at_least) {
  constexpr int kYieldEvery = 256;
  for (int spin = 1; counter.load(std::memory_order_acquire) < at_least; ++spin) {
    if (spin % kYieldEvery == 0)
      std::this_thread::yield();
    else
      spin_pause();
  }
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

void run_blocks(std::size_t blocks, void (*body)(void*, std::size_t), void* context,
                const std::size_t* bounds, bool steal) {
  if (t_inside_loop) {  // a loop inside a loop: this thread alone
    for (std::size_t b = 0; b < blocks; ++b) body(context, b);
    return;
  }
  if (blocks >= (std::size_t(1) << 32))
    throw std::length_error("a threaded loop of more than 2^32 blocks");
  team().run(blocks, body, context, bounds, steal);
}

}  // namespace detail
}  // namespace millsim
