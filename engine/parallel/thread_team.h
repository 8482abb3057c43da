// The engine's threads: one process-wide team that runs a loop's blocks on every thread. Thread t
// of T starts on its own contiguous share of the blocks ([t·B/T, (t+1)·B/T), or shares the caller
// gives: the same particles every step) and, when done, takes from the back of the others' shares
// the blocks they have not started yet (unless the loop forbids it). Nothing about a
// result may depend on which thread runs a block: a loop writes each block's partial results to
// the block's own slot, and the caller combines the slots in block order, so the numbers are the
// same for any thread count (docs/threads.md).
//
// Why a team of our own rather than OpenMP: the same code and the same behaviour under g++ and
// clang (the sanitized and fuzzing builds use clang, whose OpenMP runtime is another package),
// ThreadSanitizer sees every synchronisation (libgomp is not instrumented and reports its own
// barriers as races), and a loop is a plain function call that a unit test can run at 1, 2 and
// 3 threads in one process.
//
// The team is set once, before a run (set_thread_count), and never from inside a loop. A loop
// started from inside a loop runs on the calling thread alone. Workers wait for work by spinning
// briefly (a step's loops follow each other within microseconds), then sleep on a futex, so an
// idle team costs nothing on a machine that is busy with other runs.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

namespace millsim {

// The cores this process may run on: its affinity mask (which Slurm's and systemd's CPU limits
// set), at least 1.
int usable_core_count();

// Threads the engine's loops use from now on, n ≥ 1 (1: the calling thread alone, no workers).
// Not to be called while a loop runs.
void set_thread_count(int n);
int thread_count();

// Divides the block and piece sizes of the engine's threaded loops (a power of two ≥ 1; 1 unless
// a test sets it), so that a test's small scene runs every loop on several threads. A result may
// depend on the sizes (sums are kept per block), never on the thread count.
void set_block_divisor(std::size_t divisor);
std::size_t block_divisor();
// `nominal` items per block, divided by block_divisor() (at least 1).
inline std::size_t block_items(std::size_t nominal) {
  const std::size_t items = nominal / block_divisor();
  return items > 0 ? items : 1;
}

// The items per piece for a loop over `items` whose result does not depend on where its pieces
// are cut (each writes its own places, joined in piece order): `nominal` (a power of two), halved
// while the loop would make fewer than kPiecesPerThreadToBalance pieces per thread, down to
// `smallest`. Pieces go to whichever thread is free, so a loop of few pieces ends unevenly: 3
// pieces on 2 threads leave one thread two thirds of the work.
inline constexpr std::size_t kPiecesPerThreadToBalance = 4;
inline std::size_t balanced_piece_items(std::size_t items, std::size_t nominal,
                                        std::size_t smallest) {
  const std::size_t wanted = kPiecesPerThreadToBalance * std::size_t(thread_count());
  std::size_t size = std::max<std::size_t>(1, nominal);
  while (size / 2 >= std::max<std::size_t>(1, smallest) && (items + size - 1) / size < wanted)
    size /= 2;
  return size;
}

// The engine's usual block of a loop over items (slots, candidates): 16384, halved down to 2048
// until every thread has a few.
inline std::size_t balanced_block_items(std::size_t items) {
  return balanced_piece_items(items, block_items(16384), block_items(2048));
}

// Loops that ran on more than one thread since the process started (tests: that a loop did).
std::uint64_t loops_run_on_team();

// Loops over fewer items than this (divided by block_divisor()) run on the calling thread alone.
// Below it a step's particles fit in one core's caches, and a loop on two cores moves them from
// cache to cache every step: the shipped mill at 5-15 thousand particles took 1.55x longer on 2
// threads than on 1 (docs/threads.md). The result is the same either way.
inline constexpr std::size_t kMinItemsForThreads = 32768;
// A step's force pass and kick-drift on the same owner shares of the slots
// (parallel/slot_shares.h; a multi-rate step's listed passes cut at the shares' units) keep each
// thread's particles in its own core's caches from step to step, and gain on two threads from
// this many particles on (Simulation::min_items_for_threads; docs/threads.md).
inline constexpr std::size_t kMinSlotsForOwnerPasses = 8192;
namespace detail {
inline std::size_t g_min_items_for_threads = kMinItemsForThreads;
}
inline bool worth_threads(std::size_t items) {
  return thread_count() > 1 && items >= detail::g_min_items_for_threads / block_divisor();
}

// Lowers (or raises) worth_threads()' minimum for the loops started in one scope of the calling
// thread: a single-rate run's rebuild and checks, whose passes split the slots as the owner
// passes do (kMinSlotsForOwnerPasses). Not to be made inside a loop.
class MinItemsForThreadsScope {
 public:
  explicit MinItemsForThreadsScope(std::size_t items) : saved_(detail::g_min_items_for_threads) {
    detail::g_min_items_for_threads = items;
  }
  ~MinItemsForThreadsScope() { detail::g_min_items_for_threads = saved_; }
  MinItemsForThreadsScope(const MinItemsForThreadsScope&) = delete;
  MinItemsForThreadsScope& operator=(const MinItemsForThreadsScope&) = delete;

 private:
  std::size_t saved_;
};

namespace detail {
// Runs body(context, block) for every block in [0, blocks) on the team; returns when all have
// run. Thread t's share is [bounds[t], bounds[t + 1]) (bounds: thread_count() + 1 entries, or null
// for equal shares); `steal`: whether a thread done with its share takes the others' blocks. Of
// the blocks that threw, the lowest one's exception is rethrown (a thread stops at its first
// exception; the others go on).
void run_blocks(std::size_t blocks, void (*body)(void*, std::size_t), void* context,
                const std::size_t* bounds, bool steal);

template <class Body>
void run_body(std::size_t blocks, Body& body, const std::size_t* bounds, bool steal) {
  detail::run_blocks(
      blocks, [](void* c, std::size_t b) { (*static_cast<std::remove_reference_t<Body>*>(c))(b); },
      const_cast<void*>(static_cast<const void*>(&body)), bounds, steal);
}
}  // namespace detail

// Runs body(block) for block = 0 .. blocks−1, spread over the team as above.
template <class Body>
void parallel_blocks(std::size_t blocks, Body&& body) {
  if (blocks == 0) return;
  if (blocks == 1 || thread_count() == 1) {
    for (std::size_t b = 0; b < blocks; ++b) body(b);
    return;
  }
  detail::run_body(blocks, body, nullptr, true);
}

// Whether the calling thread is running a block of a loop (a loop started now runs on it alone).
bool inside_parallel_loop();

// Waits (spinning, then yielding the core now and then) until `counter` ≥ `at_least`: thread t of
// a parallel_on_each_thread loop waiting for a higher thread's progress.
void wait_until_at_least(const std::atomic<std::uint32_t>& counter, std::uint32_t at_least);

// Runs body(t) once on each thread t of the team (t = 0 on the calling thread), every one on its
// own thread: for loops whose thread t may write only what it owns (parallel/slot_shares.h). A
// body may wait for the progress of higher threads (never lower ones): started inside a loop,
// the bodies run on the calling thread from the highest t down.
template <class Body>
void parallel_on_each_thread(Body&& body) {
  const std::size_t n = std::size_t(thread_count());
  if (n == 1) return body(std::size_t(0));
  if (inside_parallel_loop()) {
    for (std::size_t t = n; t-- > 0;) body(t);
    return;
  }
  std::size_t bounds[64 + 1];
  std::vector<std::size_t> many;
  std::size_t* b = bounds;
  if (n > 64) many.resize(n + 1), b = many.data();
  for (std::size_t t = 0; t <= n; ++t) b[t] = t;
  detail::run_body(n, body, b, false);
}

// Runs body(block) for block = 0 .. blocks−1 with thread t's share [bounds[t], bounds[t + 1])
// (thread_count() + 1 entries, bounds[0] = 0, the last = blocks): a thread done with its own
// share takes from the back of the others'.
template <class Body>
void parallel_blocks_in_shares(std::size_t blocks, const std::size_t* bounds, Body&& body) {
  if (blocks == 0) return;
  if (blocks == 1 || thread_count() == 1) {
    for (std::size_t b = 0; b < blocks; ++b) body(b);
    return;
  }
  detail::run_body(blocks, body, bounds, true);
}

// parallel_blocks when `on_team` (a caller's worth_threads() of the population the loop serves),
// else the same blocks in order on the calling thread.
template <class Body>
void parallel_blocks_if(bool on_team, std::size_t blocks, Body&& body) {
  if (on_team) return parallel_blocks(blocks, body);
  for (std::size_t b = 0; b < blocks; ++b) body(b);
}

// Runs body(begin, end, block) over [0, n) cut into blocks of `block_size` items (the last one
// shorter): on the team when `on_team` (a caller's worth_threads() of the population the loop
// serves), else in order on the calling thread.
template <class Body>
void parallel_ranges_if(bool on_team, std::size_t n, std::size_t block_size, Body&& body) {
  const std::size_t blocks = (n + block_size - 1) / block_size;
  parallel_blocks_if(on_team, blocks, [&](std::size_t b) {
    const std::size_t begin = b * block_size;
    body(begin, begin + block_size < n ? begin + block_size : n, b);
  });
}

// The same, on the team when worth_threads(n).
template <class Body>
void parallel_ranges(std::size_t n, std::size_t block_size, Body&& body) {
  parallel_ranges_if(worth_threads(n), n, block_size, body);
}

// The lowest i in [0, n) with is_bad(i), or n when none: each block of `block_size` stops at its
// first, and the lowest of the blocks' is what one pass in order finds.
template <class Predicate>
std::size_t first_index_where(bool on_team, std::size_t n, std::size_t block_size,
                              const Predicate& is_bad) {
  std::vector<std::size_t> first((n + block_size - 1) / block_size, n);
  parallel_ranges_if(on_team, n, block_size,
                     [&](std::size_t begin, std::size_t end, std::size_t b) {
                       for (std::size_t i = begin; i < end; ++i)
                         if (is_bad(i)) {
                           first[b] = i;
                           return;
                         }
                     });
  return first.empty() ? n : *std::min_element(first.begin(), first.end());
}

}  // namespace millsim
