// Stencil: the eight gas-grid nodes (cell centres or the faces of one component) around a
// point with their trilinear weights, keeping only the nodes a predicate accepts (fluid cells,
// solved faces) and renormalising the weights over them. Sampling a field at a particle and
// spreading a particle's volume or impulse onto the grid both use it, so what is read and what
// is deposited share one set of weights. Also the vorticity of a sampled velocity field.
#pragma once

#include <array>
#include <cstddef>

#include "core/vec3.h"
#include "gas/gas_grid.h"

namespace millsim {

struct Stencil {
  std::size_t node[8];
  double weight[8];
  int count = 0;
};

// The eight grid nodes around x with trilinear weights, for a cell-centred field
// (face_axis = −1) or the faces of component face_axis; periodic nodes are mapped to the
// node that holds the value. Nodes refused by `accept` lose their weight to the others.

template <class Accept>
Stencil make_stencil(const GasGrid& g, const Vec3& x, int face_axis, Accept&& accept) {
  const GridCorner corner = lower_corner(g, x, face_axis);
  const std::array<int, 3>& i0 = corner.index;
  const std::array<double, 3>& w = corner.weight;
  Stencil s;
  double total = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    std::array<int, 3> ijk{};
    double weight = 1.0;
    for (int b = 0; b < 3; ++b) {
      const std::size_t bu = std::size_t(b);
      const int d = (corner >> b) & 1;
      int i = i0[bu] + d;
      weight *= d ? w[bu] : 1.0 - w[bu];
      if (g.periodic[bu]) {
        if (b == face_axis) {
          if (i == 0) i = g.n[bu];
        } else if (i == 0) {
          i = g.n[bu];
        } else if (i == g.n[bu] + 1) {
          i = 1;
        }
      }
      ijk[bu] = i;
    }
    if (weight <= 0.0) continue;
    const std::size_t node = g.index(ijk[0], ijk[1], ijk[2]);
    if (!accept(node)) continue;
    s.node[s.count] = node;
    s.weight[s.count] = weight;
    ++s.count;
    total += weight;
  }
  for (int k = 0; k < s.count; ++k) s.weight[k] /= total;
  return s;
}

// ∇×u at x by central differences half a cell either side along each axis of a sampled velocity
// field (an axis of one periodic cell has no variation).
template <class VelocityAt>
Vec3 vorticity_by_central_differences(const GasGrid& g, const Vec3& x, VelocityAt&& velocity_at) {
  std::array<Vec3, 3> d{};  // d[b] = ∂u/∂x_b
  for (int b = 0; b < 3; ++b) {
    if (g.n[std::size_t(b)] == 1 && g.periodic[std::size_t(b)]) continue;
    Vec3 plus = x, minus = x;
    plus[b] += 0.5 * g.h_m[b];
    minus[b] -= 0.5 * g.h_m[b];
    d[std::size_t(b)] = (velocity_at(plus) - velocity_at(minus)) * (1.0 / g.h_m[b]);
  }
  return {d[1].z - d[2].y, d[2].x - d[0].z, d[0].y - d[1].x};
}

}  // namespace millsim
