#include "gas/pressure_probe.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace millsim {
namespace {

double patch_pressure_pa(const GasSolver& gas, int patch) {
  const GasGrid& g = gas.grid();
  const GasBoundaryPatch& p = gas.config().boundaries[std::size_t(patch)];
  const int a = p.face / 2;
  const bool high = p.face % 2 == 1;
  const std::vector<double>& pressure = gas.pressure();
  double sum = 0.0;
  std::size_t faces = 0;
  g.for_each_ghost(a, [&](std::size_t ghost, std::size_t inner, bool ghost_high) {
    if (ghost_high != high || g.ghost[ghost].patch != patch || !g.fluid[inner]) return;
    double value = pressure[inner];
    if (p.kind == GasBoundaryKind::Outlet) {
      value = p.pressure_pa;
    } else {
      // The weight of the half cell between the face and the first centre (∇p = ρ g there).
      value += gas.config().density_kg_per_m3 * gas.body_force_m_per_s2()[a] * (high ? 0.5 : -0.5) *
               g.h_m[a];
    }
    sum += value;
    ++faces;
  });
  return faces > 0 ? sum / double(faces) : 0.0;
}

double cut_plane_pressure_pa(const GasSolver& gas, const PressurePlane& plane) {
  const GasGrid& g = gas.grid();
  const int a = plane.axis, b = (a + 1) % 3, c = (a + 2) % 3;
  const std::size_t au = std::size_t(a);
  // Cells i0 and i0 + 1 (1-based) have their centres either side of the plane.
  const double s = (plane.at_m - g.origin_m[a]) / g.h_m[a] - 0.5;
  const int i0 = std::clamp(int(std::floor(s)) + 1, 1, std::max(1, g.n[au] - 1));
  const double w = std::clamp(s - (i0 - 1), 0.0, 1.0);
  const std::vector<double>& pressure = gas.pressure();
  double sum = 0.0;
  std::size_t columns = 0;
  for (int jc = 1; jc <= g.n[std::size_t(c)]; ++jc)
    for (int jb = 1; jb <= g.n[std::size_t(b)]; ++jb) {
      std::array<int, 3> ijk{};
      ijk[au] = i0;
      ijk[std::size_t(b)] = jb;
      ijk[std::size_t(c)] = jc;
      const std::size_t c0 = g.index(ijk[0], ijk[1], ijk[2]);
      const std::size_t c1 = g.n[au] >= 2 ? c0 + g.stride[au] : c0;
      const bool f0 = g.fluid[c0], f1 = g.fluid[c1];
      if (!f0 && !f1) continue;
      sum += f0 && f1 ? (1.0 - w) * pressure[c0] + w * pressure[c1] : pressure[f0 ? c0 : c1];
      ++columns;
    }
  return columns > 0 ? sum / double(columns) : 0.0;
}

}  // namespace

double plane_pressure_pa(const GasSolver& gas, const PressurePlane& plane) {
  return plane.patch >= 0 ? patch_pressure_pa(gas, plane.patch) : cut_plane_pressure_pa(gas, plane);
}

}  // namespace millsim
