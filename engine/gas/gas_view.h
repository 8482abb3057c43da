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
  double cell_volume_fraction(std::size_t c) const {
    return compressible ? compressible->volume_fraction()[c] : incompressible->volume_fraction()[c];
  }
};

}  // namespace millsim
