#include "http/request_log.h"

namespace millsim {

bool is_idle_poll(const std::string& method, const std::string& path, int status) {
  return status == 204 && method == "POST" && path == "/v1/worker/claim";
}

std::optional<long> IdlePollSummary::note(double now_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (now_s - last_line_s_ < interval_s_) {
    ++left_out_;
    return std::nullopt;
  }
  const long left_out = left_out_;
  last_line_s_ = now_s;
  left_out_ = 0;
  return left_out;
}

}  // namespace millsim
