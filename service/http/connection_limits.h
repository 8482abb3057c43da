// What a port of the server admits (plain settings, read by ApiServer's configuration and
// served by /v1/info) and what it counted; the guard itself is http_limits.h.
#pragma once

#include <cstddef>
#include <cstdint>

namespace millsim {

struct ConnectionLimits {
  std::size_t max_connections = 64;             // open at once; more are answered busy (503)
  std::size_t max_connections_per_client = 32;  // from one source address
  double receive_timeout_s = 10.0;              // for a request's head and body
};

struct ConnectionStats {
  std::uint64_t accepted = 0;
  std::uint64_t refused = 0;     // over a cap: answered busy (or the health probe's 200)
  std::uint64_t timed_out = 0;   // cut by the receive deadline
  std::uint64_t exceptions = 0;  // a request that threw past its handler: connection closed
};

}  // namespace millsim
