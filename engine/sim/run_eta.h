// The time left of a run, for its progress lines. The wall time of a step is modelled as
// a + b N (a fixed part: the gas, the schedule; a part per particle), fitted to the most recent
// progress samples, and the particle count N is extrapolated linearly from them, so a run whose
// population grows (a fed mill, breakage) is not promised the speed of its emptier start. The
// average since the start, the estimate this replaced, was 2–5× optimistic on the fed mill.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>

namespace millsim {

class EtaEstimator {
 public:
  // One progress sample: the step reached, the wall time since the start and the particles then.
  void add(std::int64_t step, double elapsed_s, std::size_t particles);
  // Seconds to reach `total_steps` from the last sample; 0 before two samples.
  double eta_s(std::int64_t total_steps) const;

 private:
  struct Sample {
    std::int64_t step;
    double elapsed_s;
    double particles;
  };
  static constexpr std::size_t kWindow = 12;  // samples kept: the recent behaviour only
  std::deque<Sample> samples_;
};

}  // namespace millsim
