#include "support/draining_vortex.h"

#include <algorithm>
#include <numbers>
#include <vector>

namespace millsim::test {

GasSolver draining_vortex_gas(const DrainingVortex& v) {
  const int n = v.cells;
  const double h = v.cell_m(), c0 = v.centre_m(), lid = v.layers * h;
  const double q = v.sink_m2_per_s, circulation = v.circulation_m2_per_s;
  GasConfig config;
  config.density_kg_per_m3 = 1.2;
  config.viscosity_pa_s = 1.8e-5;
  config.cells = {n, n, v.layers};
  GasBoundaryPatch outlet;
  outlet.name = "finder", outlet.face = 5, outlet.kind = GasBoundaryKind::Outlet;
  outlet.shape = PatchShape::Circle, outlet.center_m = {c0, c0, lid};
  outlet.radius_m = v.outlet_radius_m;
  config.boundaries = {outlet};
  GasSolver gas(config, build_gas_grid(config, {0, 0, 0}, {v.side_m, v.side_m, lid}, {}), {});
  const GasGrid& grid = gas.grid();
  const auto velocity = [&](double x, double y) {
    const double dx = x - c0, dy = y - c0, r2 = dx * dx + dy * dy;
    const double scale = 1.0 / std::max(r2, v.outlet_radius_m * v.outlet_radius_m);
    return Vec3{(-q * dx - circulation * dy) * scale, (-q * dy + circulation * dx) * scale, 0.0};
  };
  for (int k = 1; k <= v.layers; ++k)
    for (int j = 1; j <= n; ++j)
      for (int i = 1; i < n; ++i) {
        gas.velocity()[0][grid.index(i, j, k)] = velocity(i * h, (j - 0.5) * h).x;
        gas.velocity()[1][grid.index(j, i, k)] = velocity((j - 0.5) * h, i * h).y;
      }
  std::vector<std::size_t> lid_outlet;
  for (std::size_t f = 0; f < grid.padded_size; ++f)
    if (grid.face[2][f] == FaceKind::Outflow) lid_outlet.push_back(f);
  for (std::size_t f : lid_outlet)
    gas.velocity()[2][f] = 2.0 * std::numbers::pi * q * lid / (double(lid_outlet.size()) * h * h);
  return gas;
}

}  // namespace millsim::test
