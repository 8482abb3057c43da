#include "comminution/fragment_spawn.h"

#include <algorithm>
#include <cmath>

namespace millsim {
namespace {

Vec3 uniform_in_ball(double radius, Rng& rng) {
  while (true) {
    const Vec3 p{2 * uniform01(rng) - 1, 2 * uniform01(rng) - 1, 2 * uniform01(rng) - 1};
    if (norm2(p) <= 1.0) return p * radius;
  }
}

}  // namespace

std::vector<Vec3> place_fragments(const std::vector<double>& d, double parent_d, int attempts,
                                  Rng& rng) {
  std::vector<Vec3> offset;
  offset.reserve(d.size());
  const double parent_r = 0.5 * parent_d;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double r = 0.5 * d[k];
    Vec3 best{};
    double best_overlap = 1e300;
    for (int a = 0; a < attempts && best_overlap > 0.0; ++a) {
      const Vec3 candidate = uniform_in_ball(std::max(parent_r - r, 0.0), rng);
      double worst = 0.0;  // deepest overlap with a placed sibling
      for (std::size_t m = 0; m < k; ++m)
        worst = std::max(worst, r + 0.5 * d[m] - norm(candidate - offset[m]));
      if (worst < best_overlap) best_overlap = worst, best = candidate;
    }
    offset.push_back(best);
  }
  // Keep the centre of mass at the parent's centre.
  Vec3 moment{};
  double mass = 0.0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double w = d[k] * d[k] * d[k];
    moment += offset[k] * w;
    mass += w;
  }
  const Vec3 shift = moment * (1.0 / mass);
  for (Vec3& o : offset) o -= shift;
  return offset;
}

}  // namespace millsim
