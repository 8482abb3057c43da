// The server's request log: one line per request on stderr (time, method, path, status,
// milliseconds), except a worker's idle polls. A worker with nothing to do asks for a run every
// half second or so (POST /v1/worker/claim answered 204); each of those would be a line (about 52 a
// minute were measured for one idle worker) that says nothing. They are logged at most once a
// minute: the first idle poll after a minute without such a line is logged, with how many idle
// polls were left out since the last one. Claims that hand out a run, and every other request, are
// logged as they come.
#pragma once

#include <limits>
#include <mutex>
#include <optional>
#include <string>

namespace millsim {

// True for a worker's idle poll: a claim answered 204 (no run to take).
bool is_idle_poll(const std::string& method, const std::string& path, int status);

// Decides which idle polls get a line: at most one per `interval_s`. Thread-safe (the server's
// threads log concurrently).
class IdlePollSummary {
 public:
  explicit IdlePollSummary(double interval_s = 60.0) : interval_s_(interval_s) {}
  // One idle poll at `now_s`: the number of idle polls left out since the last line when this
  // one is to be logged, or nothing when it is only counted.
  std::optional<long> note(double now_s);

 private:
  std::mutex mutex_;
  double interval_s_;
  double last_line_s_ = -std::numeric_limits<double>::infinity();
  long left_out_ = 0;
};

}  // namespace millsim
