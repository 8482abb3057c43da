// Stencil: the eight gas-grid nodes (cell centres or the faces of one component) around a
// point with their trilinear weights, keeping only the nodes a predicate accepts (fluid cells,
// solved faces) and renormalising the weights over them. Sampling a field at a particle and
// spreading a particle's volume or impulse onto the grid both use it, so what is read and what
// is deposited share one set of weights.
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

}  // namespace millsim
