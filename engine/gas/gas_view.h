// GasView: read access to the gas of a coupled run, whichever model solves it (the
// incompressible projection of gas/gas_solver.h or the compressible finite volumes of
// gas/compressible/compressible_solver.h), for what samples the gas: the DEM-cell table of
// gas/coupling.h, the mill's vortex samples (process/classification.h) and the run's output.
// One branch per sample; nothing per contact goes through it.
#pragma once

#include "core/vec3.h"
#include "gas/compressible/compressible_solver.h"
#include "gas/gas_grid.h"
#include "gas/gas_solver.h"

namespace millsim {

struct GasView {
  const GasSolver* incompressible = nullptr;
  const CompressibleSolver* compressible = nullptr;

  // A solver is a view of itself (implicit on purpose: functions that sample the gas take either).
  GasView(const GasSolver& solver) : incompressible(&solver) {}         // NOLINT
  GasView(const CompressibleSolver& solver) : compressible(&solver) {}  // NOLINT
  GasView(const GasSolver* i, const CompressibleSolver* c) : incompressible(i), compressible(c) {}

  const GasGrid& grid() const {
    return compressible ? compressible->grid() : incompressible->grid();
  }
  double time_s() const { return compressible ? compressible->time_s() : incompressible->time_s(); }
  double viscosity_pa_s() const {
    return compressible ? compressible->viscosity_pa_s() : incompressible->viscosity_pa_s();
  }
  Vec3 velocity_at(const Vec3& x) const {
    return compressible ? compressible->velocity_at(x) : incompressible->velocity_at(x);
  }
  Vec3 pressure_gradient_at(const Vec3& x) const {
    return compressible ? compressible->pressure_gradient_at(x)
                        : incompressible->pressure_gradient_at(x);
  }
  double volume_fraction_at(const Vec3& x) const {
    return compressible ? compressible->volume_fraction_at(x)
                        : incompressible->volume_fraction_at(x);
  }
  Vec3 vorticity_at(const Vec3& x) const {
    return compressible ? compressible->vorticity_at(x) : incompressible->vorticity_at(x);
  }
  double density_at(const Vec3& x) const {
    return compressible ? compressible->density_at(x) : incompressible->density_kg_per_m3();
  }
  // The pressure of fluid cell c: absolute in the compressible model, relative to the outlets'
  // reference in the incompressible one.
  double cell_pressure_pa(std::size_t c) const {
    return compressible ? compressible->pressure_pa(c) : incompressible->pressure()[c];
  }
  // The gas velocity of fluid cell c: the mean of its two faces per axis (incompressible), its
  // momentum over its density (compressible).
  Vec3 cell_velocity_m_per_s(std::size_t c) const {
    if (compressible) return compressible->velocity_m_per_s(c);
    const GasGrid& g = incompressible->grid();
    Vec3 u;
    for (int a = 0; a < 3; ++a) {
      const std::vector<double>& component = incompressible->velocity()[std::size_t(a)];
      const std::size_t below = g.canonical_face(c - g.stride[std::size_t(a)], a);
      u[a] = 0.5 * (component[below] + component[c]);
    }
    return u;
  }
  // The normal gas velocity on `face` of component `axis`, between cells low and high (either
  // may be a ghost): the stored face value (incompressible), the mean of the fluid cells'
  // velocities (compressible).
  double face_velocity_m_per_s(int axis, std::size_t face, std::size_t low,
                               std::size_t high) const {
    if (!compressible) return incompressible->velocity()[std::size_t(axis)][face];
    const GasGrid& g = compressible->grid();
    const bool has_low = g.fluid[low] != 0, has_high = g.fluid[high] != 0;
    if (has_low && has_high)
      return 0.5 * (compressible->velocity_m_per_s(low)[axis] +
                    compressible->velocity_m_per_s(high)[axis]);
    return compressible->velocity_m_per_s(has_low ? low : high)[axis];
  }
  double cell_volume_fraction(std::size_t c) const {
    return compressible ? compressible->volume_fraction()[c] : incompressible->volume_fraction()[c];
  }
};

}  // namespace millsim
