#include "particles/restitution.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>

namespace millsim {

DimensionlessImpact simulate_dimensionless_impact(double alpha) {
  // State (X, V). The force term X^{1/4} has an infinite derivative at X = 0, so the first steps
  // are taken very small; h = 2e-4 elsewhere keeps e accurate to ~1e-6 (checked by halving h).
  auto accel = [alpha](double x, double v) {
    if (x <= 0.0) return 0.0;
    const double a = -x * std::sqrt(x) - alpha * std::sqrt(std::sqrt(x)) * v;
    return a < 0.0 ? a : 0.0;  // clipped: the contact may push, never pull
  };
  double x = 0.0, v = 1.0, t = 0.0, x_max = 0.0;
  const double h_main = 2e-4;
  while (true) {
    const double h = t < 1e-2 ? h_main * 0.01 : h_main;
    const double k1x = v, k1v = accel(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = accel(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = accel(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = accel(x + h * k3x, v + h * k3v);
    const double x_next = x + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
    const double v_next = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    if (x_next <= 0.0 && t > 0.0) {
      // Linear interpolation of the exit instant.
      const double frac = x / (x - x_next);
      return {-(v + frac * (v_next - v)), x_max, t + frac * h};
    }
    x = x_next, v = v_next, t += h;
    if (x > x_max) x_max = x;
    if (t > 1e3) return {0.0, x_max, t};
  }
}

double damping_ratio_for_restitution(double restitution) {
  if (restitution >= 1.0) return 0.0;
  restitution = std::max(restitution, kLowestDampedRestitution);
  static std::mutex mutex;
  static std::map<double, double> cache;
  {
    std::lock_guard lock(mutex);
    if (auto it = cache.find(restitution); it != cache.end()) return it->second;
  }
  double lo = 0.0, hi = 1.0;
  while (simulate_dimensionless_impact(hi).restitution > restitution && hi < 1e3) hi *= 2.0;
  for (int iter = 0; iter < 60 && hi - lo > 1e-9 * hi; ++iter) {
    const double mid = 0.5 * (lo + hi);
    if (simulate_dimensionless_impact(mid).restitution > restitution)
      lo = mid;
    else
      hi = mid;
  }
  const double alpha = 0.5 * (lo + hi);
  std::lock_guard lock(mutex);
  cache[restitution] = alpha;
  return alpha;
}

}  // namespace millsim
