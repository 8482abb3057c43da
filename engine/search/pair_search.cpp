#include "search/pair_search.h"

#include <algorithm>
#include <cmath>

namespace millsim {

void find_pairs_all_pairs(const std::vector<Vec3>& x, const std::vector<double>& r,
                          const PeriodicBox& box, double skin, PairList& out) {
  out.clear();
  const std::size_t n = x.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const Vec3 d = box.minimum_image(x[i] - x[j]);
      const double reach = r[i] + r[j] + skin;
      if (norm2(d) < reach * reach) out.push(std::uint32_t(i), std::uint32_t(j));
    }
}

namespace {

struct Grid {
  Vec3 origin;
  double cell[3];
  int n[3];
  std::vector<std::uint32_t> cell_start;  // n_cells + 1 offsets into `order`
  std::vector<std::uint32_t> order;       // particle slots grouped by cell
  std::vector<std::uint32_t> cell_of;     // per particle

  std::size_t cell_count() const { return std::size_t(n[0]) * n[1] * n[2]; }
  std::uint32_t index(int i, int j, int k) const {
    return std::uint32_t((k * n[1] + j) * n[0] + i);
  }
};

void layout_grid(const std::vector<Vec3>& x, const PeriodicBox& box, double min_cell, Grid& g) {
  Vec3 lo = box.min_m, hi = box.max_m;
  for (int a = 0; a < 3; ++a) {
    if (box.periodic[a]) continue;
    lo[a] = 1e300, hi[a] = -1e300;
    for (const Vec3& p : x) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  }
  double cell = min_cell;
  const std::size_t max_cells = std::max<std::size_t>(64, 2 * x.size());
  for (;;) {
    std::size_t total = 1;
    for (int a = 0; a < 3; ++a) {
      const double extent = hi[a] - lo[a];
      g.n[a] =
          box.periodic[a] ? std::max(1, int(extent / cell)) : int(std::min(extent / cell, 1e6)) + 1;
      g.cell[a] = box.periodic[a] ? extent / g.n[a] : cell;
      total *= std::size_t(g.n[a]);
    }
    if (total <= max_cells) break;
    cell *= std::cbrt(double(total) / double(max_cells)) * 1.01;
  }
  g.origin = lo;
}

void bin_particles(const std::vector<Vec3>& x, Grid& g) {
  const std::size_t n_cells = g.cell_count();
  g.cell_start.assign(n_cells + 1, 0);
  g.cell_of.resize(x.size());
  for (std::size_t p = 0; p < x.size(); ++p) {
    int c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp(int(std::floor((x[p][a] - g.origin[a]) / g.cell[a])), 0, g.n[a] - 1);
    g.cell_of[p] = g.index(c[0], c[1], c[2]);
    ++g.cell_start[g.cell_of[p] + 1];
  }
  for (std::size_t c = 0; c < n_cells; ++c) g.cell_start[c + 1] += g.cell_start[c];
  g.order.resize(x.size());
  std::vector<std::uint32_t> fill(g.cell_start.begin(), g.cell_start.end() - 1);
  for (std::size_t p = 0; p < x.size(); ++p) g.order[fill[g.cell_of[p]]++] = std::uint32_t(p);
}

// The 13 offsets of the half shell: each neighbour pair of cells is visited from one side only.
constexpr int kHalfShell[13][3] = {{1, 0, 0},  {-1, 1, 0}, {0, 1, 0},  {1, 1, 0}, {-1, -1, 1},
                                   {0, -1, 1}, {1, -1, 1}, {-1, 0, 1}, {0, 0, 1}, {1, 0, 1},
                                   {-1, 1, 1}, {0, 1, 1},  {1, 1, 1}};

}  // namespace

void find_pairs_grid(const std::vector<Vec3>& x, const std::vector<double>& r,
                     const PeriodicBox& box, double skin, std::optional<double> min_cell_m,
                     PairList& out, SearchStats& stats) {
  out.clear();
  if (x.size() < 2) return;
  const double r_max = *std::max_element(r.begin(), r.end());
  Grid g;
  layout_grid(x, box, std::max(2.0 * r_max + skin, min_cell_m.value_or(0.0)), g);
  bin_particles(x, g);
  stats.cells = g.cell_count();
  for (int a = 0; a < 3; ++a) stats.cells_per_axis[a] = g.n[a];
  stats.half_shell = true;
  for (int a = 0; a < 3; ++a)
    if (box.periodic[a] && g.n[a] < 3) stats.half_shell = false;

  std::uint64_t tests = 0;
  auto test = [&](std::uint32_t i, std::uint32_t j) {
    ++tests;
    const Vec3 d = box.minimum_image(x[i] - x[j]);
    const double reach = r[i] + r[j] + skin;
    if (norm2(d) < reach * reach) out.push(std::min(i, j), std::max(i, j));
  };
  // Neighbour cell of (ci, cj, ck) at offset o, or -1 when off a non-periodic edge.
  auto neighbour = [&](const int c[3], const int o[3]) -> long {
    int m[3];
    for (int a = 0; a < 3; ++a) {
      m[a] = c[a] + o[a];
      if (m[a] < 0 || m[a] >= g.n[a]) {
        if (!box.periodic[a]) return -1;
        m[a] = (m[a] + g.n[a]) % g.n[a];
      }
    }
    return g.index(m[0], m[1], m[2]);
  };

  for (int ck = 0; ck < g.n[2]; ++ck)
    for (int cj = 0; cj < g.n[1]; ++cj)
      for (int ci = 0; ci < g.n[0]; ++ci) {
        const int c[3] = {ci, cj, ck};
        const std::uint32_t cell = g.index(ci, cj, ck);
        const std::uint32_t begin = g.cell_start[cell], end = g.cell_start[cell + 1];
        if (begin == end) continue;
        const Vec3 cell_lo{g.origin.x + ci * g.cell[0], g.origin.y + cj * g.cell[1],
                           g.origin.z + ck * g.cell[2]};
        if (stats.half_shell) {
          for (std::uint32_t a = begin; a < end; ++a) {
            const std::uint32_t i = g.order[a];
            for (std::uint32_t b = a + 1; b < end; ++b) test(i, g.order[b]);
            // Proximity check (§2.1): sweep a neighbour cell only if the particle can reach it.
            const double reach = r[i] + r_max + skin;
            double gap_lo[3], gap_hi[3];
            for (int ax = 0; ax < 3; ++ax) {
              gap_lo[ax] = std::max(0.0, x[i][ax] - cell_lo[ax]);
              gap_hi[ax] = std::max(0.0, cell_lo[ax] + g.cell[ax] - x[i][ax]);
            }
            for (const auto& o : kHalfShell) {
              double gap2 = 0.0;
              for (int ax = 0; ax < 3; ++ax) {
                const double gap = o[ax] > 0 ? gap_hi[ax] : (o[ax] < 0 ? gap_lo[ax] : 0.0);
                gap2 += gap * gap;
              }
              if (gap2 >= reach * reach) continue;
              const long nb = neighbour(c, o);
              if (nb < 0) continue;
              for (std::uint32_t b = g.cell_start[nb]; b < g.cell_start[nb + 1]; ++b)
                test(i, g.order[b]);
            }
          }
        } else {
          // Fewer than 3 cells on a periodic axis: offsets ±1 may be the same cell, so visit
          // each distinct neighbour cell once and keep pairs with j > i.
          std::vector<long> cells;
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const int o[3] = {dx, dy, dz};
                const long nb = neighbour(c, o);
                if (nb >= 0) cells.push_back(nb);
              }
          std::sort(cells.begin(), cells.end());
          cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
          for (std::uint32_t a = begin; a < end; ++a) {
            const std::uint32_t i = g.order[a];
            for (long nb : cells)
              for (std::uint32_t b = g.cell_start[nb]; b < g.cell_start[nb + 1]; ++b)
                if (g.order[b] > i) test(i, g.order[b]);
          }
        }
      }
  stats.distance_tests += tests;
}

}  // namespace millsim
