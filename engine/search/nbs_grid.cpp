#include "search/nbs_grid.h"

#include <algorithm>
#include <cmath>

namespace millsim {

void NbsGrid::find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r,
                         const PeriodicBox& box, double skin_m, PairList& out) {
  out.clear();
  stats_ = {};
  const std::size_t n = x.size();
  double r_max = 0.0;
  for (double ri : r) r_max = std::max(r_max, ri);
  double cell = std::max(2.0 * r_max + skin_m, 1e-300);
  long dims[3];
  for (;;) {
    std::uint64_t total = 1;
    for (int a = 0; a < 3; ++a) {
      dims[a] = std::max(1L, long(box.length(a) / cell));
      if (!box.periodic[a]) dims[a] = std::max(1L, long(std::ceil(box.length(a) / cell)));
      total *= std::uint64_t(dims[a]);
    }
    if (total <= kMaxNbsCells) {
      stats_.cells = total;
      break;
    }
    cell *= 1.25;
  }
  stats_.cell_m = cell;
  // On a periodic axis the cells are stretched to fill the box exactly.
  double edge[3];
  for (int a = 0; a < 3; ++a) edge[a] = box.periodic[a] ? box.length(a) / dims[a] : cell;
  auto index_of = [&](const Vec3& p, int a) {
    const long i = long(std::floor((p[a] - box.min_m[a]) / edge[a]));
    return std::clamp(i, 0L, dims[a] - 1);
  };
  head_.assign(stats_.cells, -1);
  next_.assign(n, -1);
  for (std::size_t i = n; i-- > 0;) {
    const std::size_t c =
        std::size_t(index_of(x[i], 0)) +
        std::size_t(dims[0]) * (std::size_t(index_of(x[i], 1)) +
                                std::size_t(dims[1]) * std::size_t(index_of(x[i], 2)));
    next_[i] = head_[c];
    head_[c] = std::int32_t(i);
  }
  // With fewer than three cells along a periodic axis two half-shell offsets can reach the same
  // cell: the pairs are then made unique at the end.
  bool may_repeat = false;
  for (int a = 0; a < 3; ++a) may_repeat = may_repeat || (box.periodic[a] && dims[a] < 3);
  auto test = [&](std::int32_t i, std::int32_t j) {
    ++stats_.distance_tests;
    const double reach = r[std::size_t(i)] + r[std::size_t(j)] + skin_m;
    if (norm2(box.minimum_image(x[std::size_t(i)] - x[std::size_t(j)])) < reach * reach)
      out.push(std::uint32_t(std::max(i, j)), std::uint32_t(std::min(i, j)));
  };
  static constexpr int kHalfShell[13][3] = {
      {1, 0, 0},  {-1, 1, 0}, {0, 1, 0}, {1, 1, 0},  {-1, -1, 1}, {0, -1, 1}, {1, -1, 1},
      {-1, 0, 1}, {0, 0, 1},  {1, 0, 1}, {-1, 1, 1}, {0, 1, 1},   {1, 1, 1}};
  for (long k = 0; k < dims[2]; ++k)
    for (long j = 0; j < dims[1]; ++j)
      for (long i = 0; i < dims[0]; ++i) {
        const std::int32_t first = head_[std::size_t(i + dims[0] * (j + dims[1] * k))];
        if (first < 0) continue;
        for (std::int32_t a = first; a >= 0; a = next_[std::size_t(a)])
          for (std::int32_t b = next_[std::size_t(a)]; b >= 0; b = next_[std::size_t(b)])
            test(a, b);
        for (const auto& o : kHalfShell) {
          long c[3] = {i + o[0], j + o[1], k + o[2]};
          bool outside = false;
          for (int a = 0; a < 3; ++a) {
            if (c[a] >= 0 && c[a] < dims[a]) continue;
            if (!box.periodic[a] || dims[a] < 2) {
              outside = true;
              break;
            }
            c[a] = (c[a] + dims[a]) % dims[a];
          }
          if (outside) continue;
          const std::int32_t other = head_[std::size_t(c[0] + dims[0] * (c[1] + dims[1] * c[2]))];
          for (std::int32_t a = first; a >= 0; a = next_[std::size_t(a)])
            for (std::int32_t b = other; b >= 0; b = next_[std::size_t(b)]) test(a, b);
        }
      }
  if (may_repeat) {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> unique;
    for (std::size_t k = 0; k < out.size(); ++k) unique.push_back({out.first[k], out.second[k]});
    std::sort(unique.begin(), unique.end());
    unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
    out.clear();
    for (const auto& [a, b] : unique) out.push(a, b);
  }
}

}  // namespace millsim
