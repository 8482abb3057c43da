#include "sim/run_eta.h"

#include <algorithm>
#include <cmath>

namespace millsim {

void EtaEstimator::add(std::int64_t step, double elapsed_s, std::size_t particles) {
  if (!samples_.empty() && step <= samples_.back().step) return;
  samples_.push_back({step, elapsed_s, double(particles)});
  if (samples_.size() > kWindow) samples_.pop_front();
}

double EtaEstimator::eta_s(std::int64_t total_steps) const {
  if (samples_.size() < 2) return 0.0;
  const Sample& first = samples_.front();
  const Sample& last = samples_.back();
  const double remaining = double(std::max<std::int64_t>(0, total_steps - last.step));
  if (remaining == 0.0) return 0.0;

  // Least squares of Δt = a Δs + b Δs N̄ over the intervals between samples (N̄ the interval's
  // mean particle count), a and b not negative.
  double s11 = 0.0, s12 = 0.0, s22 = 0.0, r1 = 0.0, r2 = 0.0;
  for (std::size_t k = 1; k < samples_.size(); ++k) {
    const Sample& p = samples_[k - 1];
    const Sample& q = samples_[k];
    const double x1 = double(q.step - p.step), x2 = x1 * 0.5 * (p.particles + q.particles);
    const double y = q.elapsed_s - p.elapsed_s;
    s11 += x1 * x1, s12 += x1 * x2, s22 += x2 * x2, r1 += x1 * y, r2 += x2 * y;
  }
  double a = 0.0, b = 0.0;
  const double det = s11 * s22 - s12 * s12;
  if (det > 1e-12 * s11 * s22) {
    a = (r1 * s22 - r2 * s12) / det;
    b = (r2 * s11 - r1 * s12) / det;
  }
  if (!(det > 1e-12 * s11 * s22) || a < 0.0 || b < 0.0) {
    // One of the two parts alone: the one that fits the samples better.
    const double a_only = r1 / s11, b_only = s22 > 0.0 ? r2 / s22 : 0.0;
    const double residual_a = -2.0 * a_only * r1 + a_only * a_only * s11;
    const double residual_b = s22 > 0.0 ? -2.0 * b_only * r2 + b_only * b_only * s22 : 1e300;
    a = residual_a <= residual_b ? std::max(0.0, a_only) : 0.0;
    b = residual_a <= residual_b ? 0.0 : std::max(0.0, b_only);
  }

  // The particle count from here on: its recent linear trend, never below zero.
  const double growth =
      std::max(0.0, (last.particles - first.particles) /
                        double(std::max<std::int64_t>(1, last.step - first.step)));
  const double particle_steps = remaining * last.particles + 0.5 * growth * remaining * remaining;
  return a * remaining + b * particle_steps;
}

}  // namespace millsim
