// Outlets: a plane (particles whose centre is behind it, against its normal, have left), a box or
// a finite cylinder (particles whose centre is inside have left; a mill's outlet tube). The
// simulation removes such particles and bins them into the outlet PSD (sim/simulation.cpp).
#pragma once

#include <vector>

#include "core/vec3.h"
#include "scene/scene_config.h"

namespace millsim {

inline bool outlet_contains(const OutletConfig& o, const Vec3& x) {
  if (o.kind == OutletKind::Plane) return dot(x - o.point_m, o.normal) < 0.0;
  if (o.kind == OutletKind::Cylinder) {
    const Vec3 d = x - o.point_m;
    const double axial = dot(d, o.normal);
    return axial >= o.axial_min_m && axial <= o.axial_max_m &&
           norm2(d - o.normal * axial) < o.radius_m * o.radius_m;
  }
  for (int a = 0; a < 3; ++a)
    if (x[a] < o.min_m[a] || x[a] > o.max_m[a]) return false;
  return true;
}

// Index of the first outlet containing x, or −1.
inline int outlet_of(const std::vector<OutletConfig>& outlets, const Vec3& x) {
  for (std::size_t k = 0; k < outlets.size(); ++k)
    if (outlet_contains(outlets[k], x)) return int(k);
  return -1;
}

}  // namespace millsim
