// The penetration limiter of §4, Eq. 8: a contact whose overlap has passed the limit (a fraction
// of the smaller partner's diameter) and is still closing has its normal relative velocity set
// to −e times its current value. Between two particles the change is an equal and opposite
// impulse along the normal (momentum is conserved); against a wall only the particle moves.
// Also the max-overlap predictors of Eq. 12–13 and for the engine's own damping.
#pragma once

#include <cstdint>
#include <vector>

#include "contact/contact_forces.h"

namespace millsim {

// Applies Eq. 8 to the contacts listed in `stats`; returns how many it changed.
std::uint64_t apply_penetration_limiter(const ContactStepStats& stats,
                                        const MaterialTable& materials, const PeriodicBox& box,
                                        const std::vector<Wall>& walls,
                                        const NeighborList& neighbors, ParticleStore& particles);

// Eq. 12: undamped maximum overlap, δ = (5 m* V² / (4 k))^{2/5}.
double hertz_max_overlap_m(double reduced_mass_kg, double stiffness, double speed_m_per_s);

// Eq. 13: δ = (0.73 + 0.27 (e − γ)) (5 m* V² / (4 k))^{2/5}, γ = −ln e/√(π² + ln² e). Fitted by
// the paper for damping α = 2γ (DESIGN.md errata).
double eq13_max_overlap_m(double reduced_mass_kg, double stiffness, double speed_m_per_s,
                          double restitution);

// Maximum overlap for the damping the engine applies: Eq. 13 for DampingModel::Paper; for the
// calibrated damping, the dimensionless solution X_max(α(e)) × (m* V²/k)^{2/5} (restitution.h).
double predicted_max_overlap_m(DampingModel model, double reduced_mass_kg, double stiffness,
                               double speed_m_per_s, double restitution);

}  // namespace millsim
