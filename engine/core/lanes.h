// Lanes: two doubles side by side for loops whose every element takes the same operations and
// only the choice of operands depends on the element (a face's upwind cell by the sign of its
// flux). GCC's and clang's vector extensions, so it builds for any target (SSE2 on x86-64, NEON
// on AArch64); each lane is the IEEE operation a scalar loop would do, so a loop over lanes gives
// the scalar loop's bits. A choice is a select of both operands by a mask, not a branch: where
// the sign flips from element to element, a branch is mispredicted half the time.
#pragma once

#include <cstdint>
#include <cstring>

namespace millsim {

using Lanes = double __attribute__((vector_size(16)));
using LaneMask = std::int64_t __attribute__((vector_size(16)));  // all bits set, or none, per lane
constexpr std::size_t kLanes = 2;

// Every lane x.
inline Lanes splat_lanes(double x) {
  Lanes v;
  for (std::size_t i = 0; i < kLanes; ++i) v[i] = x;
  return v;
}
inline Lanes load_lanes(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store_lanes(double* p, Lanes v) {
  std::memcpy(p, &v, sizeof v);
}
// A lane mask from flags that are 0 or 1 (one byte each).
inline LaneMask load_flag_lanes(const std::uint8_t* p) {
  return LaneMask{-std::int64_t(p[0] != 0), -std::int64_t(p[1] != 0)};
}
// Per lane: `when` where the mask is set, else `otherwise` (bit for bit either operand).
inline Lanes select_lanes(LaneMask mask, Lanes when, Lanes otherwise) {
  return Lanes((LaneMask(when) & mask) | (LaneMask(otherwise) & ~mask));
}
inline LaneMask select_masks(LaneMask mask, LaneMask when, LaneMask otherwise) {
  return (when & mask) | (otherwise & ~mask);
}

}  // namespace millsim
