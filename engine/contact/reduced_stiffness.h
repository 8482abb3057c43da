// Reduced stiffness for the finest particles (§4, Eq. 6–7): a particle of diameter d below the
// threshold d_th has its Young's modulus (so k_n, k_t and its compliance) scaled by
// s = (d/d_th)^{2.5}, which keeps √(m/k) — the time-step requirement — at the threshold's value.
// The cost is deeper penetration: δ_max/d grows as d_th/d below the threshold. The automatic
// threshold is the largest d_th for which the smallest particle, at the expected impact speed
// against the stiffest partner, penetrates at most the allowed fraction of its diameter
// (predicted with the max-overlap predictor, contact/penetration_limit.h).
#pragma once

#include "particles/materials.h"
#include "scene/scene_config.h"

namespace millsim {

inline double stiffness_scale(double diameter_m, double threshold_diameter_m) {
  if (diameter_m >= threshold_diameter_m) return 1.0;
  const double ratio = diameter_m / threshold_diameter_m;
  return ratio * ratio * std::sqrt(ratio);
}

struct PenetrationCase {
  const MaterialConstants* particle;  // material of the smallest particle
  double diameter_m;                  // smallest diameter
  double partner_compliance;  // the stiffest wall's (1−ν²)/E; < 0: no walls, an equal particle
  double restitution;         // of that contact
  double impact_speed_m_per_s;
  DampingModel damping;
};

// Predicted δ_max/d for the case with the particle's stiffness scaled by `scale`.
double predicted_penetration_ratio(const PenetrationCase& c, double scale);

struct ThresholdChoice {
  double threshold_diameter_m;
  double penetration_ratio;        // predicted δ_max/d of the smallest particle with it
  bool limited_by_real_stiffness;  // even s = 1 exceeds the limit: no reduction is possible
};

// The largest d_th in [d_min, d_max] keeping the predicted ratio at or below `limit`.
ThresholdChoice automatic_threshold(const PenetrationCase& c, double d_max, double limit);

}  // namespace millsim
