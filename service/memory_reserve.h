// A reserve of memory that keeps the server alive when one request runs it out of memory. At
// start-up `arm` sets aside a block and installs a new-handler: the first allocation that fails
// (in any thread: the greedy handler's, or the accept loop's, a logger's, a worker lease's)
// releases the block instead of throwing, so that allocation and every other thread's go on, and
// marks the reserve tapped. The greedy work checks `memory_reserve_tapped()` as it grows (study
// expansion does, per run) and gives up with std::bad_alloc, answered 503 for its request
// alone; `rearm` after that request sets the block aside again. Without it, under load the
// failing allocation was as often another thread's, and std::terminate ended the server.
#pragma once

#include <cstddef>

namespace millsim {

// Sets aside `bytes` and installs the new-handler (once per process; later calls re-arm).
void arm_memory_reserve(std::size_t bytes);
// Whether an allocation has failed since the reserve was last armed.
bool memory_reserve_tapped();
// Sets the reserve aside again after its tap was answered (a no-op when it is in place or the
// memory is still short: the next failure then throws std::bad_alloc as usual).
void rearm_memory_reserve();

}  // namespace millsim
