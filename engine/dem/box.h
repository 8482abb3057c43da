// PeriodicBox: the domain box and which axes wrap. Owns the minimum-image convention and the
// wrap of positions into [min, max) on periodic axes. Walls of non-periodic axes live in
// contact/walls.h.
#pragma once

#include <array>
#include <cmath>

#include "core/vec3.h"

namespace millsim {

struct PeriodicBox {
  Vec3 min_m, max_m;
  std::array<bool, 3> periodic{false, false, false};

  double length(int axis) const { return max_m[axis] - min_m[axis]; }
  bool any_periodic() const { return periodic[0] || periodic[1] || periodic[2]; }

  // Shortest separation vector under the periodic axes (valid while |d| < L/2 per axis).
  Vec3 minimum_image(Vec3 d) const {
    for (int a = 0; a < 3; ++a)
      if (periodic[a]) d[a] -= length(a) * std::nearbyint(d[a] / length(a));
    return d;
  }

  // Periodic image count per axis (−1, 0 or 1) of a separation between two wrapped positions
  // (|d| < L): the minimum image is d − n·L. Cheaper than minimum_image's rounding.
  int image_of(double d, int axis) const {
    if (!periodic[axis]) return 0;
    const double half = 0.5 * length(axis);
    return d > half ? 1 : (d < -half ? -1 : 0);
  }
  Vec3 minimum_image_wrapped(Vec3 d) const {
    for (int a = 0; a < 3; ++a) d[a] -= image_of(d[a], a) * length(a);
    return d;
  }

  void wrap(Vec3& x) const {
    for (int a = 0; a < 3; ++a)
      if (periodic[a]) wrap_axis(x, a);
  }

  void wrap_axis(Vec3& x, int a) const {
    const double L = length(a);
    double v = x[a] - min_m[a];
    v -= L * std::floor(v / L);
    if (v >= L) v -= L;  // rounding can land exactly on L
    x[a] = min_m[a] + v;
  }
};

}  // namespace millsim
