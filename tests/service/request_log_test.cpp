// The request log's rule for a worker's idle polls (service/http/request_log.h): at most one
// line a minute, each saying how many idle polls were left out since the one before.
#include "http/request_log.h"

#include <gtest/gtest.h>

#include <vector>

namespace millsim {
namespace {

TEST(RequestLog, IdlePollsAreClaimsAnswered204Only) {
  EXPECT_TRUE(is_idle_poll("POST", "/v1/worker/claim", 204));
  EXPECT_FALSE(is_idle_poll("POST", "/v1/worker/claim", 200));  // a run handed out
  EXPECT_FALSE(is_idle_poll("POST", "/v1/worker/claim", 401));
  EXPECT_FALSE(is_idle_poll("POST", "/v1/worker/runs/s000001-r0/heartbeat", 204));
  EXPECT_FALSE(is_idle_poll("GET", "/v1/worker/claim", 204));
}

TEST(RequestLog, IdlePollsGetOneLineAMinuteWithTheCountLeftOut) {
  IdlePollSummary summary(60.0);
  // One poll a second for three minutes (181 polls, t = 0 … 180 s).
  std::vector<double> logged_at_s;
  std::vector<long> left_out;
  for (int t = 0; t <= 180; ++t)
    if (const std::optional<long> n = summary.note(double(t))) {
      logged_at_s.push_back(t);
      left_out.push_back(*n);
    }
  EXPECT_EQ(logged_at_s, (std::vector<double>{0, 60, 120, 180}));
  EXPECT_EQ(left_out, (std::vector<long>{0, 59, 59, 59}));
}

}  // namespace
}  // namespace millsim
