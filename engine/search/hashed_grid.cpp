#include "search/hashed_grid.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace millsim {
namespace {

constexpr int kAxisBits = 21;
constexpr long kAxisLimit = (1L << kAxisBits) - 1;

// LSD radix sort of (key, value) by key, 16 bits per pass, only as many passes as the keys need.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& values) {
  const std::size_t n = keys.size();
  std::uint64_t max_key = 0;
  for (std::uint64_t k : keys) max_key |= k;
  std::vector<std::uint64_t> keys_tmp(n);
  std::vector<std::uint32_t> values_tmp(n);
  for (int shift = 0; shift < 64 && (max_key >> shift) != 0; shift += 16) {
    std::vector<std::uint32_t> count(65537, 0);
    for (std::uint64_t k : keys) ++count[((k >> shift) & 0xFFFF) + 1];
    for (std::size_t d = 0; d < 65536; ++d) count[d + 1] += count[d];
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t pos = count[(keys[i] >> shift) & 0xFFFF]++;
      keys_tmp[pos] = keys[i];
      values_tmp[pos] = values[i];
    }
    keys.swap(keys_tmp);
    values.swap(values_tmp);
  }
}

inline std::uint64_t hash_key(std::uint64_t key) {
  return key * 0x9E3779B97F4A7C15ULL;
}

// The 13 offsets of the half shell: each neighbouring pair of cells is visited from one side.
constexpr int kHalfShell[13][3] = {{1, 0, 0},  {-1, 1, 0}, {0, 1, 0},  {1, 1, 0}, {-1, -1, 1},
                                   {0, -1, 1}, {1, -1, 1}, {-1, 0, 1}, {0, 0, 1}, {1, 0, 1},
                                   {-1, 1, 1}, {0, 1, 1},  {1, 1, 1}};

struct PairTester {
  const std::vector<Vec3>& x;
  const std::vector<double>& r;
  const PeriodicBox& box;
  double skin;
  PairList& out;
  std::uint64_t tests = 0;
  bool periodic = box.any_periodic();

  void operator()(std::uint32_t i, std::uint32_t j) {
    ++tests;
    Vec3 d = x[i] - x[j];
    if (periodic) d = box.minimum_image_wrapped(d);  // positions are wrapped before a build
    const double reach = r[i] + r[j] + skin;
    if (norm2(d) < reach * reach) out.push(std::min(i, j), std::max(i, j));
  }
};

// All pairs within one level: own cell + half shell with the proximity check; when a periodic
// axis has fewer than 3 cells, every distinct neighbour cell once with j > i instead.
void same_level_pairs(const CellLevel& level, const std::vector<Vec3>& x,
                      const std::vector<double>& r, double reach_extra, PairTester& test) {
  bool half_shell = true;
  for (int a = 0; a < 3; ++a)
    if (level.periodic_cells(a) != 0 && level.periodic_cells(a) < 3) half_shell = false;
  std::vector<long> neighbours;
  for (std::size_t cell = 0; cell < level.cell_count(); ++cell) {
    long c[3];
    level.coordinates(cell, c);
    const std::uint32_t* first = level.begin(cell);
    const std::uint32_t* last = level.end(cell);
    if (!half_shell) {
      neighbours.clear();
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const long nb = level.find(c[0] + dx, c[1] + dy, c[2] + dz);
            if (nb >= 0) neighbours.push_back(nb);
          }
      std::sort(neighbours.begin(), neighbours.end());
      neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
      for (const std::uint32_t* a = first; a != last; ++a)
        for (long nb : neighbours)
          for (const std::uint32_t* b = level.begin(std::size_t(nb));
               b != level.end(std::size_t(nb)); ++b)
            if (*b > *a) test(*a, *b);
      continue;
    }
    // Neighbour cells of the half shell, looked up once per cell.
    long shell[13];
    for (int s = 0; s < 13; ++s)
      shell[s] =
          level.find(c[0] + kHalfShell[s][0], c[1] + kHalfShell[s][1], c[2] + kHalfShell[s][2]);
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) lo[a] = level.lower(c[a], a), hi[a] = lo[a] + level.edge(a);
    for (const std::uint32_t* a = first; a != last; ++a) {
      const std::uint32_t i = *a;
      for (const std::uint32_t* b = a + 1; b != last; ++b) test(i, *b);
      // Proximity check (§2.1): sweep a neighbour only if the particle's reach crosses into it.
      const double reach = r[i] + reach_extra;
      double gap_lo[3], gap_hi[3];
      for (int ax = 0; ax < 3; ++ax) {
        gap_lo[ax] = std::max(0.0, x[i][ax] - lo[ax]);
        gap_hi[ax] = std::max(0.0, hi[ax] - x[i][ax]);
      }
      for (int s = 0; s < 13; ++s) {
        if (shell[s] < 0) continue;
        double gap2 = 0.0;
        for (int ax = 0; ax < 3; ++ax) {
          const int o = kHalfShell[s][ax];
          const double gap = o > 0 ? gap_hi[ax] : (o < 0 ? gap_lo[ax] : 0.0);
          gap2 += gap * gap;
        }
        if (gap2 >= reach * reach) continue;
        for (const std::uint32_t* b = level.begin(std::size_t(shell[s]));
             b != level.end(std::size_t(shell[s])); ++b)
          test(i, *b);
      }
    }
  }
}

// Distinct wrapped cell indices along one axis covering [x − reach, x + reach], each with the
// smallest gap from x to that cell (over its periodic images).
void axis_cover(const CellLevel& level, int axis, double x, double reach,
                std::vector<std::pair<long, double>>& out) {
  out.clear();
  const long lo = level.index_of(x - reach, axis), hi = level.index_of(x + reach, axis);
  const long n = level.periodic_cells(axis);
  for (long index = lo; index <= hi; ++index) {
    const double cell_lo = level.lower(index, axis), cell_hi = cell_lo + level.edge(axis);
    const double gap = x < cell_lo ? cell_lo - x : (x > cell_hi ? x - cell_hi : 0.0);
    const long wrapped = n > 0 ? ((index % n) + n) % n : index;
    auto it =
        std::find_if(out.begin(), out.end(), [&](const auto& e) { return e.first == wrapped; });
    if (it == out.end())
      out.emplace_back(wrapped, gap);
    else
      it->second = std::min(it->second, gap);
  }
}

}  // namespace

std::uint64_t CellLevel::pack(long ix, long iy, long iz) {
  return (std::uint64_t(ix) << (2 * kAxisBits)) | (std::uint64_t(iy) << kAxisBits) |
         std::uint64_t(iz);
}

long CellLevel::index_of(double coordinate, int axis) const {
  return long(std::floor((coordinate - origin_[axis]) / edge_[axis]));
}

void CellLevel::build(const std::vector<Vec3>& x, const std::vector<std::uint32_t>& members,
                      const PeriodicBox& box, const Vec3& origin, double cell_m) {
  origin_ = origin;
  for (int a = 0; a < 3; ++a) {
    if (box.periodic[a]) {
      periodic_cells_[a] = std::max(1L, long(box.length(a) / cell_m));
      periodic_cells_[a] = std::min(periodic_cells_[a], kAxisLimit);
      edge_[a] = box.length(a) / double(periodic_cells_[a]);
      origin_[a] = box.min_m[a];
    } else {
      periodic_cells_[a] = 0;
      edge_[a] = cell_m;
    }
  }
  // Cell coordinates of every member, and the box of cells they occupy.
  std::vector<std::uint64_t> keys(members.size());
  long max_index[3] = {0, 0, 0};
  for (std::size_t k = 0; k < members.size(); ++k) {
    long c[3];
    for (int a = 0; a < 3; ++a) {
      c[a] = index_of(x[members[k]][a], a);
      if (periodic_cells_[a]) c[a] = std::clamp(c[a], 0L, periodic_cells_[a] - 1);
      c[a] = std::clamp(c[a], 0L, kAxisLimit);
      max_index[a] = std::max(max_index[a], c[a]);
    }
    keys[k] = pack(c[0], c[1], c[2]);
  }
  double box_cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    dims_[a] = periodic_cells_[a] ? periodic_cells_[a] : max_index[a] + 1;
    box_cells *= double(dims_[a]);
  }
  direct_ = box_cells <= std::max(1024.0, 8.0 * double(members.size()));
  cell_key_.clear();
  start_.clear();
  if (direct_) {
    // Counting sort on the linear cell index: one pass, and the direct table falls out of it.
    auto linear = [this](std::uint64_t key) {
      const long ix = long(key >> (2 * kAxisBits)), iy = long((key >> kAxisBits) & kAxisLimit),
                 iz = long(key & kAxisLimit);
      return std::size_t((iz * dims_[1] + iy) * dims_[0] + ix);
    };
    direct_cell_.assign(std::size_t(box_cells), -1);
    std::vector<std::uint32_t> count(std::size_t(box_cells) + 1, 0);
    for (std::uint64_t key : keys) ++count[linear(key) + 1];
    for (std::size_t b = 0; b < std::size_t(box_cells); ++b) {
      if (count[b + 1] != 0) {
        direct_cell_[b] = std::int32_t(cell_key_.size());
        cell_key_.push_back(0);  // filled below
        start_.push_back(count[b]);
      }
      count[b + 1] += count[b];
    }
    start_.push_back(std::uint32_t(keys.size()));
    members_.resize(members.size());
    for (std::size_t k = 0; k < members.size(); ++k) {
      const std::size_t b = linear(keys[k]);
      cell_key_[std::size_t(direct_cell_[b])] = keys[k];
      members_[count[b]++] = members[k];
    }
    return;
  }
  std::vector<std::uint32_t> slots(members);
  radix_sort(keys, slots);
  members_ = std::move(slots);
  for (std::size_t k = 0; k < keys.size(); ++k)
    if (k == 0 || keys[k] != keys[k - 1])
      cell_key_.push_back(keys[k]), start_.push_back(std::uint32_t(k));
  start_.push_back(std::uint32_t(keys.size()));
  const std::size_t capacity = std::bit_ceil(std::max<std::size_t>(16, 2 * cell_key_.size()));
  table_mask_ = capacity - 1;
  table_key_.assign(capacity, ~std::uint64_t(0));
  table_cell_.assign(capacity, 0);
  for (std::size_t cell = 0; cell < cell_key_.size(); ++cell) {
    std::uint64_t slot = (hash_key(cell_key_[cell]) >> 20) & table_mask_;
    while (table_key_[slot] != ~std::uint64_t(0)) slot = (slot + 1) & table_mask_;
    table_key_[slot] = cell_key_[cell];
    table_cell_[slot] = std::uint32_t(cell);
  }
}

long CellLevel::find(long ix, long iy, long iz) const {
  long c[3] = {ix, iy, iz};
  for (int a = 0; a < 3; ++a) {
    const long n = periodic_cells_[a];
    if (n) {
      if (c[a] < 0)
        c[a] += n;
      else if (c[a] >= n)
        c[a] -= n;
    }
  }
  return find_wrapped(c[0], c[1], c[2]);
}

long CellLevel::find_wrapped(long ix, long iy, long iz) const {
  if (ix < 0 || iy < 0 || iz < 0) return -1;
  if (direct_) {
    if (ix >= dims_[0] || iy >= dims_[1] || iz >= dims_[2]) return -1;
    return direct_cell_[std::size_t((iz * dims_[1] + iy) * dims_[0] + ix)];
  }
  if (ix > kAxisLimit || iy > kAxisLimit || iz > kAxisLimit) return -1;
  const std::uint64_t key = pack(ix, iy, iz);
  for (std::uint64_t slot = (hash_key(key) >> 20) & table_mask_;; slot = (slot + 1) & table_mask_) {
    if (table_key_[slot] == key) return long(table_cell_[slot]);
    if (table_key_[slot] == ~std::uint64_t(0)) return -1;
  }
}

void CellLevel::coordinates(std::size_t cell, long out[3]) const {
  const std::uint64_t key = cell_key_[cell];
  out[0] = long(key >> (2 * kAxisBits));
  out[1] = long((key >> kAxisBits) & kAxisLimit);
  out[2] = long(key & kAxisLimit);
}

void HashedGrid::find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r,
                            const PeriodicBox& box, const HashedGridSettings& settings,
                            PairList& out) {
  out.clear();
  stats_ = {};
  const std::size_t n = x.size();
  if (n < 2) return;
  const double skin = settings.skin_m;
  const double r_max = *std::max_element(r.begin(), r.end());
  Vec3 origin = box.min_m;
  for (int a = 0; a < 3; ++a) {
    if (box.periodic[a]) continue;
    origin[a] = 1e300;
    for (const Vec3& p : x) origin[a] = std::min(origin[a], p[a]);
  }
  // Level-0 edge: the reach of the largest pair, and no more cells per axis than the keys hold.
  double c0 = std::max(2.0 * r_max + skin, settings.min_cell_m.value_or(0.0));
  for (int a = 0; a < 3; ++a) {
    if (box.periodic[a]) continue;
    double extent = 0.0;
    for (const Vec3& p : x) extent = std::max(extent, p[a] - origin[a]);
    c0 = std::max(c0, extent / double(kAxisLimit - 2));
  }
  const int k = std::max(1, settings.subcells_per_axis);
  const double c1 = c0 / double(k);

  coarse_members_.clear();
  fine_members_.clear();
  double r_fine_max = 0.0, r_coarse_max = 0.0;
  for (std::uint32_t i = 0; i < n; ++i) {
    if (k > 1 && 2.0 * r[i] + skin <= c1) {
      fine_members_.push_back(i);
      r_fine_max = std::max(r_fine_max, r[i]);
    } else {
      coarse_members_.push_back(i);
      r_coarse_max = std::max(r_coarse_max, r[i]);
    }
  }
  PairTester test{x, r, box, skin, out};
  coarse_.build(x, coarse_members_, box, origin, c0);
  same_level_pairs(coarse_, x, r, r_coarse_max + skin, test);
  stats_.cells = coarse_.cell_count();
  if (!fine_members_.empty()) {
    fine_.build(x, fine_members_, box, origin, c1);
    same_level_pairs(fine_, x, r, r_fine_max + skin, test);
    stats_.subcells = fine_.cell_count();
    // Coarse–fine: each coarse particle visits the sub-cells its reach sphere touches.
    std::vector<std::pair<long, double>> cover[3];
    for (std::uint32_t i : coarse_members_) {
      const double reach = r[i] + r_fine_max + skin;
      for (int a = 0; a < 3; ++a) axis_cover(fine_, a, x[i][a], reach, cover[a]);
      for (const auto& [cz, gz] : cover[2])
        for (const auto& [cy, gy] : cover[1]) {
          const double gyz = gy * gy + gz * gz;
          if (gyz >= reach * reach) continue;
          for (const auto& [cx, gx] : cover[0]) {
            if (gx * gx + gyz >= reach * reach) continue;
            const long cell = fine_.find_wrapped(cx, cy, cz);
            if (cell < 0) continue;
            for (const std::uint32_t* b = fine_.begin(std::size_t(cell));
                 b != fine_.end(std::size_t(cell)); ++b)
              test(i, *b);
          }
        }
    }
  }
  stats_.distance_tests = test.tests;
  stats_.coarse_particles = coarse_members_.size();
  stats_.fine_particles = fine_members_.size();
  stats_.cell_m = coarse_.edge(0);
  stats_.subcell_m = fine_members_.empty() ? 0.0 : fine_.edge(0);
  stats_.subcells_per_axis = k;
}

std::vector<std::uint32_t> spatial_order(const std::vector<Vec3>& x, const PeriodicBox& box) {
  // Morton (Z-order) key of each particle's cell, cells of about one mean spacing: neighbours in
  // space are neighbours in memory along all three axes, not just the fastest one.
  Vec3 lo = box.min_m, hi = box.max_m;
  for (int a = 0; a < 3; ++a) {
    if (box.periodic[a]) continue;
    lo[a] = 1e300, hi[a] = -1e300;
    for (const Vec3& p : x) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  }
  double extent = 0.0;
  for (int a = 0; a < 3; ++a) extent = std::max(extent, hi[a] - lo[a]);
  const double edge =
      std::max(extent / double(1 << 20), std::cbrt(std::max(extent * extent * extent, 1e-300) /
                                                   double(std::max<std::size_t>(1, x.size()))));
  auto spread = [](std::uint64_t v) {  // 21 bits → every third bit
    v &= 0x1FFFFF;
    v = (v | v << 32) & 0x1F00000000FFFFULL;
    v = (v | v << 16) & 0x1F0000FF0000FFULL;
    v = (v | v << 8) & 0x100F00F00F00F00FULL;
    v = (v | v << 4) & 0x10C30C30C30C30C3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
  };
  std::vector<std::uint64_t> keys(x.size());
  std::vector<std::uint32_t> order(x.size());
  for (std::uint32_t i = 0; i < x.size(); ++i) {
    std::uint64_t key = 0;
    for (int a = 0; a < 3; ++a) {
      const double c = std::clamp((x[i][a] - lo[a]) / edge, 0.0, double((1 << 21) - 1));
      key |= spread(std::uint64_t(c)) << a;
    }
    keys[i] = key;
    order[i] = i;
  }
  radix_sort(keys, order);
  return order;
}

int choose_subcells_per_axis(const std::vector<double>& r, double skin, double volume) {
  if (r.size() < 2 || volume <= 0.0) return 1;
  double d_max = 0.0;
  for (double radius : r) d_max = std::max(d_max, 2.0 * radius);
  const double n_total = double(r.size()), density = n_total / volume;
  const double c0 = d_max + skin;
  double best_cost = 0.0;
  int best_k = 1;
  for (int k = 1; k <= 8; ++k) {
    const double c1 = c0 / k;
    // Fine particles: 2r + skin <= c1 (none at k = 1).
    double n_fine = 0.0, fine_d_max = 0.0, coarse_d_sum = 0.0;
    for (double radius : r) {
      const double d = 2.0 * radius;
      if (k > 1 && d + skin <= c1)
        n_fine += 1.0, fine_d_max = std::max(fine_d_max, d);
      else
        coarse_d_sum += d;
    }
    const double n_coarse = n_total - n_fine;
    const double d_coarse_mean = n_coarse > 0 ? coarse_d_sum / n_coarse : 0.0;
    const double fine_reach = n_fine > 0 ? fine_d_max + skin : 0.0;
    // Expected tests: each particle meets the others of its level in ~half of 27 cells (half
    // shell, own cell halved); each coarse particle scans the fines in its reach box and probes
    // the sub-cells there.
    const double coarse_coarse = n_coarse * 13.5 * c0 * c0 * c0 * density * (n_coarse / n_total);
    const double fine_fine = n_fine * 13.5 * c1 * c1 * c1 * density * (n_fine / n_total);
    const double box_edge = d_coarse_mean + fine_reach + c1;
    const double coarse_fine =
        n_coarse * box_edge * box_edge * box_edge * density * (n_fine / n_total);
    const double lookups = n_fine > 0 ? n_coarse * std::pow(box_edge / c1, 3.0) : 0.0;
    const double cost = coarse_coarse + fine_fine + coarse_fine + 2.0 * lookups;
    if (k == 1 || cost < best_cost) best_cost = cost, best_k = k;
  }
  return best_k;
}

}  // namespace millsim
