// The engine's only source of randomness: one seeded generator per run (scene "seed").
// Same scene + same seed → same particles, same results.
#pragma once

#include <cstdint>
#include <random>

namespace millsim {

using Rng = std::mt19937_64;

inline double uniform01(Rng& rng) {
  return std::uniform_real_distribution<double>(0.0, 1.0)(rng);
}
inline double gaussian(Rng& rng, double mean, double std_dev) {
  return std::normal_distribution<double>(mean, std_dev)(rng);
}

}  // namespace millsim
