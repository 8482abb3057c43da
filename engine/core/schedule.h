// Schedule: a value that changes during a run, given as a table of (time, value) rows. Between
// rows the value is interpolated linearly; two rows at the same time make a step; before the
// first row and after the last the value holds. Used for inlet velocities and mass flows (steps
// and ramps of a fluidization curve, a mill's start-up).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace millsim {

struct Schedule {
  std::vector<double> time_s;  // non-decreasing
  std::vector<double> value;   // same length, at least one row

  double at(double t) const {
    if (t <= time_s.front()) return value.front();
    if (t >= time_s.back()) return value.back();
    // The last row at or before t: after a step (equal times) the later row holds.
    const std::size_t k =
        std::size_t(std::upper_bound(time_s.begin(), time_s.end(), t) - time_s.begin()) - 1;
    const double span = time_s[k + 1] - time_s[k];
    const double w = span > 0.0 ? (t - time_s[k]) / span : 1.0;
    return value[k] + w * (value[k + 1] - value[k]);
  }
  double max_abs() const {
    double m = 0.0;
    for (double v : value) m = std::max(m, v < 0.0 ? -v : v);
    return m;
  }
};

}  // namespace millsim
