#include "memory_reserve.h"

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <new>

namespace millsim {
namespace {

std::mutex g_mutex;
void* g_block = nullptr;
std::size_t g_bytes = 0;
std::atomic<bool> g_tapped{false};

// Called by operator new when an allocation fails: the first failure releases the reserve (the
// allocation is then retried); with no reserve left it throws, as without a handler.
void on_allocation_failure() {
  void* block = nullptr;
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    block = g_block;
    g_block = nullptr;
  }
  if (!block) throw std::bad_alloc();
  std::free(block);
  g_tapped.store(true, std::memory_order_release);
}

}  // namespace

void arm_memory_reserve(std::size_t bytes) {
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_bytes = bytes;
  }
  std::set_new_handler(on_allocation_failure);
  rearm_memory_reserve();
}

bool memory_reserve_tapped() {
  return g_tapped.load(std::memory_order_acquire);
}

void rearm_memory_reserve() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_block || g_bytes == 0) return;
  g_block = std::malloc(g_bytes);
  if (g_block) g_tapped.store(false, std::memory_order_release);
}

}  // namespace millsim
