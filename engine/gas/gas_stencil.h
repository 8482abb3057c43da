// Stencil: the eight gas-grid nodes (cell centres or the faces of one component) around a
// point with their trilinear weights, keeping only the nodes a predicate accepts (fluid cells,
// solved faces) and renormalising the weights over them. Sampling a field at a particle and
// spreading a particle's impulse onto the grid both use it, so what is read and what is
// deposited share one set of weights. Also the cells a sphere overlaps with its volume's share
// in each (the solids volume per cell), and the vorticity of a sampled velocity field.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

#include "core/vec3.h"
#include "gas/gas_grid.h"

namespace millsim {

struct Stencil {
  std::size_t node[8];
  double weight[8];
  int count = 0;
};

// Adds a node with its weight when `accept` takes it.
template <class Accept>
void keep_if_accepted(Stencil& s, std::size_t node, double weight, Accept& accept) {
  if (!accept(node)) return;
  s.node[s.count] = node;
  s.weight[s.count] = weight;
  ++s.count;
}

// The weights scaled to sum to 1 (the refused nodes' share given to the kept ones).
inline Stencil renormalised(Stencil s) {
  double total = 0.0;
  for (int k = 0; k < s.count; ++k) total += s.weight[k];
  for (int k = 0; k < s.count; ++k) s.weight[k] /= total;
  return s;
}

// The eight grid nodes around x with trilinear weights, for a cell-centred field
// (face_axis = −1) or the faces of component face_axis; periodic nodes are mapped to the
// node that holds the value. Nodes refused by `accept` lose their weight to the others.

template <class Accept>
Stencil make_stencil(const GasGrid& g, const Vec3& x, int face_axis, Accept&& accept) {
  const GridCorner corner = lower_corner(g, x, face_axis);
  const std::array<int, 3>& i0 = corner.index;
  const std::array<double, 3>& w = corner.weight;
  Stencil s;
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
    if (weight > 0.0) keep_if_accepted(s, g.index(ijk[0], ijk[1], ijk[2]), weight, accept);
  }
  return renormalised(s);
}

// The share of a sphere's volume below a plane at signed distance s = t r above its centre: the
// cap's (1 + t)²(2 − t)/4, t clamped to [−1, 1].
inline double sphere_share_below(double t) {
  t = t < -1.0 ? -1.0 : (t > 1.0 ? 1.0 : t);
  return 0.25 * (1.0 + t) * (1.0 + t) * (2.0 - t);
}

// The cells a sphere of radius r at x overlaps and the share of its volume in each. Along each
// axis the sphere meets at most two cells (a gas cell is larger than a particle) and the share
// on either side of the face between them is the cap's; a cell's weight is the product of its
// three axis shares. That is exact where one face cuts the sphere, within a few per cent of the
// sphere's volume where two or three do (tests/gas/void_fraction_test.cpp), and the weights
// always sum to 1. A share off a non-periodic end of the grid goes to the end cell (the part of
// a particle pressed into a flat wall); periodic cells map to the cell that holds them. Cells
// refused by `accept` give their share to the others: on a staircase wall the part of a
// particle in a cell the grid counts as solid stands in for the open part of its fluid
// neighbours, which the grid counts as gas although the true wall cuts it away.
template <class Accept>
Stencil sphere_overlap_stencil(const GasGrid& g, const Vec3& x, double radius_m, Accept&& accept) {
  std::array<std::array<int, 2>, 3> cell{};
  std::array<std::array<double, 2>, 3> share{};
  for (int b = 0; b < 3; ++b) {
    const std::size_t bu = std::size_t(b);
    const int n = g.n[bu];
    const double t = (x[b] - g.origin_m[b]) / g.h_m[b];
    int i = int(std::floor(t - radius_m / g.h_m[b])) + 1;  // the cell holding the lowest point
    const double face_m = g.origin_m[b] + double(i) * g.h_m[b];
    const double below =
        n == 1 && g.periodic[bu] ? 1.0 : sphere_share_below((face_m - x[b]) / radius_m);
    std::array<int, 2> ij{i, i + 1};
    for (int& c : ij) {
      if (g.periodic[bu])
        c = ((c - 1) % n + n) % n + 1;
      else
        c = c < 1 ? 1 : (c > n ? n : c);
    }
    cell[bu] = ij;
    share[bu] = {below, 1.0 - below};
  }
  Stencil s;
  for (int corner = 0; corner < 8; ++corner) {
    const int di = corner & 1, dj = (corner >> 1) & 1, dk = (corner >> 2) & 1;
    const double weight =
        share[0][std::size_t(di)] * share[1][std::size_t(dj)] * share[2][std::size_t(dk)];
    if (weight > 0.0)
      keep_if_accepted(
          s, g.index(cell[0][std::size_t(di)], cell[1][std::size_t(dj)], cell[2][std::size_t(dk)]),
          weight, accept);
  }
  return renormalised(s);
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
