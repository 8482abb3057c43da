#include "search/hashed_grid.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

#include "parallel/thread_team.h"

namespace millsim {
namespace {

constexpr int kAxisBits = 21;
constexpr long kAxisLimit = (1L << kAxisBits) - 1;

// A threaded search is cut into pieces of about this many particles (of a level, or of those
// visiting another level), run in waves of kPiecesPerThreadWave pieces per thread; a smaller
// search into smaller pieces, down to kSearchPieceMinParticles, so that every thread has a few
// (balanced_piece_items).
constexpr std::size_t kSearchPieceParticles = 8192;
constexpr std::size_t kSearchPieceMinParticles = 1024;
constexpr std::size_t kPiecesPerThreadWave = 8;

// LSD radix sort of (key, value) by key, 16 bits per pass, only as many passes as the keys need.
// With `on_team` each pass is cut into one chunk of the input per thread: every chunk counts its
// digits, the counts become where each chunk's keys of each digit go (digits in order, chunks in
// order within one), and every chunk scatters its keys there. A stable sort's output is unique,
// so the result is the one a single pass makes. The scratch arrays keep their capacity.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& values,
                SortScratch& scratch, bool on_team) {
  constexpr std::size_t kDigits = 65536;
  const std::size_t n = keys.size();
  const std::size_t chunks = on_team ? std::size_t(thread_count()) : 1;
  auto chunk_begin = [&](std::size_t c) { return n * c / chunks; };
  std::vector<std::uint64_t> chunk_or(chunks, 0);
  parallel_blocks_if(on_team, chunks, [&](std::size_t c) {
    std::uint64_t bits = 0;
    for (std::size_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i) bits |= keys[i];
    chunk_or[c] = bits;
  });
  std::uint64_t max_key = 0;
  for (const std::uint64_t bits : chunk_or) max_key |= bits;
  scratch.keys.resize(n);
  scratch.values.resize(n);
  for (int shift = 0; shift < 64 && (max_key >> shift) != 0; shift += 16) {
    scratch.count.assign(chunks * kDigits, 0);
    parallel_blocks_if(on_team, chunks, [&](std::size_t c) {
      std::uint32_t* count = scratch.count.data() + c * kDigits;
      for (std::size_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i)
        ++count[(keys[i] >> shift) & 0xFFFF];
    });
    std::uint32_t placed = 0;
    for (std::size_t d = 0; d < kDigits; ++d)
      for (std::size_t c = 0; c < chunks; ++c) {
        std::uint32_t& count = scratch.count[c * kDigits + d];
        const std::uint32_t here = count;
        count = placed;
        placed += here;
      }
    parallel_blocks_if(on_team, chunks, [&](std::size_t c) {
      std::uint32_t* at = scratch.count.data() + c * kDigits;
      for (std::size_t i = chunk_begin(c); i < chunk_begin(c + 1); ++i) {
        const std::uint32_t pos = at[(keys[i] >> shift) & 0xFFFF]++;
        scratch.keys[pos] = keys[i];
        scratch.values[pos] = values[i];
      }
    });
    keys.swap(scratch.keys);
    values.swap(scratch.values);
  }
}

inline std::uint64_t hash_key(std::uint64_t key) {
  return key * 0x9E3779B97F4A7C15ULL;
}

// Distance tests of one sphere against runs of a level's members; candidates are pushed as slot
// pairs (smaller slot first).
struct PairSink {
  const PeriodicBox& box;
  double skin;
  PairList& out;
  std::uint64_t tests = 0;
  std::uint64_t lookups = 0;  // cell probes through the hash or direct table

  // Members [first, last) of `level`, whose periodic image is displaced by `shift`.
  void run(const Sphere& a, std::uint32_t slot_a, const CellLevel& level, std::uint32_t first,
           std::uint32_t last, const Vec3& shift) {
    tests += last - first;
    const Sphere* sphere = level.spheres().data();
    const std::uint32_t* slot = level.slots().data();
    const double ax = a.x - shift[0], ay = a.y - shift[1], az = a.z - shift[2], ar = a.r + skin;
    for (std::uint32_t k = first; k < last; ++k) {
      const double dx = ax - sphere[k].x, dy = ay - sphere[k].y, dz = az - sphere[k].z;
      const double reach = ar + sphere[k].r;
      if (dx * dx + dy * dy + dz * dz < reach * reach)
        out.push(std::min(slot_a, slot[k]), std::max(slot_a, slot[k]));
    }
  }

  // The same under the minimum image, for periodic boxes too small for one image per cell;
  // with `after_slot`, only members of a larger slot (each pair once).
  void run_minimum_image(const Sphere& a, std::uint32_t slot_a, const CellLevel& level,
                         std::uint32_t first, std::uint32_t last, bool after_slot) {
    const Sphere* sphere = level.spheres().data();
    const std::uint32_t* slot = level.slots().data();
    for (std::uint32_t k = first; k < last; ++k) {
      if (after_slot && slot[k] <= slot_a) continue;
      ++tests;
      const Vec3 d =
          box.minimum_image_wrapped(Vec3{a.x - sphere[k].x, a.y - sphere[k].y, a.z - sphere[k].z});
      const double reach = a.r + sphere[k].r + skin;
      if (norm2(d) < reach * reach) out.push(std::min(slot_a, slot[k]), std::max(slot_a, slot[k]));
    }
  }
};

// A periodic axis with fewer than 3 cells: every distinct neighbour cell once, each pair once
// by slot order, under the minimum image.
void small_box_pairs(const CellLevel& level, PairSink& sink) {
  std::vector<long> neighbours;
  for (std::size_t cell = 0; cell < level.cell_count(); ++cell) {
    long c[3];
    level.coordinates(cell, c);
    neighbours.clear();
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const long nb = level.find(c[0] + dx, c[1] + dy, c[2] + dz);
          if (nb >= 0) neighbours.push_back(nb);
        }
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    for (std::uint32_t q = level.first(cell); q < level.last(cell); ++q)
      for (long nb : neighbours)
        sink.run_minimum_image(level.spheres()[q], level.slots()[q], level,
                               level.first(std::size_t(nb)), level.last(std::size_t(nb)), true);
  }
}

// The half shell in key order (x slowest, z fastest): of a cell's 26 neighbours, the 13 that come
// after it, in five rows along z: (x, y, z+1), (x, y+1, z−1..z+1), (x+1, y−1..y+1, z−1..z+1).
constexpr int kShellRow[5][2] = {{0, 0}, {0, 1}, {1, -1}, {1, 0}, {1, 1}};  // (dx, dy)

// A neighbour cell found for the half shell: where it is, its offset, the shift of its image.
struct ShellCell {
  long cell;
  int offset[3];
  Vec3 shift;
};

// The half-shell neighbours of `cell` (coordinates c). Rows that stay inside the box are read
// from the sorted cell list through one forward-only cursor per row (no hashing: successive
// cells' rows only move forward in key order); rows that wrap a periodic axis are looked up.
int half_shell_cells(const CellLevel& level, const PeriodicBox& box, const long c[3],
                     std::size_t cursor[5], ShellCell out[13], std::uint64_t& lookups) {
  int count = 0;
  for (int row = 0; row < 5; ++row) {
    const long dx = kShellRow[row][0], dy = kShellRow[row][1];
    const long z_lo = row == 0 ? c[2] + 1 : c[2] - 1, z_hi = c[2] + 1;
    const long xy[2] = {c[0] + dx, c[1] + dy};
    bool wraps = false, empty = false;
    for (int a = 0; a < 2; ++a) {
      const long n = level.periodic_cells(a);
      if (xy[a] < 0 || (n && xy[a] >= n)) (n ? wraps : empty) = true;
    }
    const long nz = level.periodic_cells(2);
    if (nz && (z_lo < 0 || z_hi >= nz)) wraps = true;
    if (empty) continue;
    if (wraps) {
      for (long z = z_lo; z <= z_hi; ++z) {
        long nb[3] = {xy[0], xy[1], z};
        Vec3 shift{0.0, 0.0, 0.0};
        for (int a = 0; a < 3; ++a) {
          const long n = level.periodic_cells(a);
          if (n && nb[a] < 0) nb[a] += n, shift[a] = -box.length(a);
          if (n && nb[a] >= n) nb[a] -= n, shift[a] = box.length(a);
        }
        ++lookups;
        const long found = level.find_wrapped(nb[0], nb[1], nb[2]);
        if (found >= 0) out[count++] = {found, {int(dx), int(dy), int(z - c[2])}, shift};
      }
      continue;
    }
    const std::uint64_t key_lo = CellLevel::pack(xy[0], xy[1], std::max(0L, z_lo));
    const std::uint64_t key_hi = CellLevel::pack(xy[0], xy[1], z_hi);
    std::size_t& q = cursor[row];
    while (q < level.cell_count() && level.key(q) < key_lo) ++q;
    for (std::size_t k = q; k < level.cell_count() && level.key(k) <= key_hi; ++k) {
      const long z = long(level.key(k) & std::uint64_t(kAxisLimit));
      out[count++] = {long(k), {int(dx), int(dy), int(z - c[2])}, Vec3{0.0, 0.0, 0.0}};
    }
  }
  return count;
}

// Whether a periodic axis has fewer than 3 cells (small_box_pairs then).
bool small_periodic_box(const CellLevel& level) {
  for (int a = 0; a < 3; ++a)
    if (level.periodic_cells(a) != 0 && level.periodic_cells(a) < 3) return true;
  return false;
}

// The pairs within one level that cells [cell_begin, cell_end) start: own cell + half shell with
// the proximity check.
void same_level_cells(const CellLevel& level, const PeriodicBox& box, double reach_extra,
                      std::size_t cell_begin, std::size_t cell_end, PairSink& sink) {
  if (cell_begin >= cell_end) return;
  const Vec3 no_shift{0.0, 0.0, 0.0};
  // Every half-shell row of a cell at or after cell_begin lies at or after the key (x, y, 0) of
  // cell_begin's (x, y): the rows' cursors start at the first cell from there.
  long c_begin[3];
  level.coordinates(cell_begin, c_begin);
  const std::size_t first_row_cell =
      level.first_cell_from(CellLevel::pack(c_begin[0], c_begin[1], 0));
  std::size_t cursor[5];
  for (std::size_t& c : cursor) c = first_row_cell;
  ShellCell shell[13];
  for (std::size_t cell = cell_begin; cell < cell_end; ++cell) {
    long c[3];
    level.coordinates(cell, c);
    const int shell_count = half_shell_cells(level, box, c, cursor, shell, sink.lookups);
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) lo[a] = level.lower(c[a], a), hi[a] = lo[a] + level.edge(a);
    const std::uint32_t last = level.last(cell);
    for (std::uint32_t q = level.first(cell); q < last; ++q) {
      const Sphere& p = level.spheres()[q];
      const std::uint32_t slot = level.slots()[q];
      sink.run(p, slot, level, q + 1, last, no_shift);
      // Proximity check (§2.1): sweep a neighbour only if the particle's reach crosses into it.
      const double reach = p.r + reach_extra;
      const double gap_lo[3] = {std::max(0.0, p.x - lo[0]), std::max(0.0, p.y - lo[1]),
                                std::max(0.0, p.z - lo[2])};
      const double gap_hi[3] = {std::max(0.0, hi[0] - p.x), std::max(0.0, hi[1] - p.y),
                                std::max(0.0, hi[2] - p.z)};
      for (int s = 0; s < shell_count; ++s) {
        double gap2 = 0.0;
        for (int ax = 0; ax < 3; ++ax) {
          const int o = shell[s].offset[ax];
          const double gap = o > 0 ? gap_hi[ax] : (o < 0 ? gap_lo[ax] : 0.0);
          gap2 += gap * gap;
        }
        if (gap2 >= reach * reach) continue;
        const std::size_t nb = std::size_t(shell[s].cell);
        sink.run(p, slot, level, level.first(nb), level.last(nb), shell[s].shift);
      }
    }
  }
}

// A cell index along one axis within reach of a coordinate: wrapped, with the smallest gap from
// the coordinate to the cell and the shift of the periodic image that gap belongs to.
struct CoverCell {
  long index;
  double gap, shift;
};

// Cells along one axis covering [x − reach, x + reach]. Returns false when two images of one
// cell fall within reach (a periodic box narrower than the reach): the cells are then listed
// once each and the caller must use the minimum image.
bool axis_cover(const CellLevel& level, const PeriodicBox& box, int axis, double x, double reach,
                std::vector<CoverCell>& out) {
  out.clear();
  const long lo = level.index_of(x - reach, axis), hi = level.index_of(x + reach, axis);
  const long n = level.periodic_cells(axis);
  const bool unique_images = n == 0 || hi - lo + 1 <= n;
  for (long index = lo; index <= hi; ++index) {
    const double cell_lo = level.lower(index, axis), cell_hi = cell_lo + level.edge(axis);
    const double gap = x < cell_lo ? cell_lo - x : (x > cell_hi ? x - cell_hi : 0.0);
    const long wrapped = n > 0 ? ((index % n) + n) % n : index;
    const double shift = n > 0 ? double((index - wrapped) / n) * box.length(axis) : 0.0;
    if (unique_images) {
      out.push_back({wrapped, gap, shift});
      continue;
    }
    auto it = std::find_if(out.begin(), out.end(),
                           [&](const CoverCell& e) { return e.index == wrapped; });
    if (it == out.end())
      out.push_back({wrapped, gap, 0.0});
    else
      it->gap = std::min(it->gap, gap);
  }
  return unique_images;
}

// Every particle of `from` in members [member_begin, member_end) visits the cells of `to` that its
// reach sphere (r_i + reach_extra) touches. `to` holds the other level, so no pair is met twice.
void cross_level_pairs(const CellLevel& from, const CellLevel& to, const PeriodicBox& box,
                       double reach_extra, std::uint32_t member_begin, std::uint32_t member_end,
                       PairSink& sink) {
  std::vector<CoverCell> cover[3];
  for (std::uint32_t q = member_begin; q < member_end; ++q) {
    const Sphere& p = from.spheres()[q];
    const std::uint32_t slot = from.slots()[q];
    const double reach = p.r + reach_extra, reach2 = reach * reach;
    const double centre[3] = {p.x, p.y, p.z};
    bool images = true;
    for (int a = 0; a < 3; ++a) images &= axis_cover(to, box, a, centre[a], reach, cover[a]);
    for (const CoverCell& z : cover[2])
      for (const CoverCell& y : cover[1]) {
        const double gyz = y.gap * y.gap + z.gap * z.gap;
        if (gyz >= reach2) continue;
        for (const CoverCell& x : cover[0]) {
          if (x.gap * x.gap + gyz >= reach2) continue;
          ++sink.lookups;
          const long cell = to.find_wrapped(x.index, y.index, z.index);
          if (cell < 0) continue;
          if (images)
            sink.run(p, slot, to, to.first(std::size_t(cell)), to.last(std::size_t(cell)),
                     Vec3{x.shift, y.shift, z.shift});
          else
            sink.run_minimum_image(p, slot, to, to.first(std::size_t(cell)),
                                   to.last(std::size_t(cell)), false);
        }
      }
  }
}

// Runs search(piece, sink) for pieces 0 .. pieces−1 and appends their candidates to `sink` in
// piece order: the list one thread makes searching the pieces one after the other. One piece runs
// straight into `sink`; more run on the engine's threads in waves of kPiecesPerThreadWave pieces
// per thread, each piece into a list of its own, each wave joined before the next starts, so the
// lists hold a bounded share of the candidates at any particle count.
template <class Search>
void search_in_pieces(std::size_t pieces, std::vector<SearchPiece>& scratch, PairSink& sink,
                      const Search& search) {
  if (pieces == 1) return search(0, sink);
  const std::size_t wave = kPiecesPerThreadWave * std::size_t(thread_count());
  if (scratch.size() < wave) scratch.resize(wave);
  for (std::size_t first = 0; first < pieces; first += wave) {
    const std::size_t count = std::min(wave, pieces - first);
    parallel_blocks(count, [&](std::size_t q) {
      SearchPiece& own = scratch[q];
      own.pairs.clear();
      PairSink piece_sink{sink.box, sink.skin, own.pairs};
      search(first + q, piece_sink);
      own.tests = piece_sink.tests, own.lookups = piece_sink.lookups;
    });
    for (std::size_t q = 0; q < count; ++q) {
      const PairList& own = scratch[q].pairs;
      sink.out.first.insert(sink.out.first.end(), own.first.begin(), own.first.end());
      sink.out.second.insert(sink.out.second.end(), own.second.begin(), own.second.end());
      sink.tests += scratch[q].tests, sink.lookups += scratch[q].lookups;
    }
  }
}

// What the counts of one level say about it, for choosing how to search across levels.
struct LevelSummary {
  double count = 0.0;
  double density_per_m3 = 0.0;  // particles per unit volume of the level's occupied cells
  double edge_m = 1.0;
  double r_mean_m = 0.0, r_max_m = 0.0;
};

constexpr double kLookupCost = kLookupCostTests;

// Estimated tests and lookups when each particle of `from` visits the cells of `to` within its
// reach: the reach box, padded by one cell, in cells and in particles of `to`.
double visit_cost(const LevelSummary& from, const LevelSummary& to, double skin) {
  const double span = 2.0 * (from.r_mean_m + to.r_max_m + skin) + to.edge_m;
  const double lookups = std::pow(span / to.edge_m, 3.0);
  return from.count * (kLookupCost * lookups + span * span * span * to.density_per_m3);
}

}  // namespace

std::uint64_t CellLevel::pack(long ix, long iy, long iz) {
  return (std::uint64_t(ix) << (2 * kAxisBits)) | (std::uint64_t(iy) << kAxisBits) |
         std::uint64_t(iz);
}

long CellLevel::index_of(double coordinate, int axis) const {
  return long(std::floor((coordinate - origin_[axis]) / edge_[axis]));
}

void CellLevel::build(const std::vector<Vec3>& x, const std::vector<double>& r,
                      const std::vector<std::uint32_t>& members, const PeriodicBox& box,
                      const Vec3& origin, double cell_m, SortScratch& scratch) {
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
  // Cell coordinates of every member, and the box of cells they occupy (per block of members on
  // the engine's threads; the largest index of each axis over the blocks).
  std::vector<std::uint64_t>& keys = scratch.input_keys;
  keys.resize(members.size());
  const std::size_t block = balanced_block_items(members.size());
  std::vector<std::array<long, 3>> block_max_index((members.size() + block - 1) / block);
  parallel_ranges(members.size(), block, [&](std::size_t begin, std::size_t end, std::size_t b) {
    long max_index[3] = {0, 0, 0};
    for (std::size_t k = begin; k < end; ++k) {
      long c[3];
      for (int a = 0; a < 3; ++a) {
        c[a] = index_of(x[members[k]][a], a);
        if (periodic_cells_[a]) c[a] = std::clamp(c[a], 0L, periodic_cells_[a] - 1);
        c[a] = std::clamp(c[a], 0L, kAxisLimit);
        max_index[a] = std::max(max_index[a], c[a]);
      }
      keys[k] = pack(c[0], c[1], c[2]);
    }
    block_max_index[b] = {max_index[0], max_index[1], max_index[2]};
  });
  long max_index[3] = {0, 0, 0};
  for (const std::array<long, 3>& m : block_max_index)
    for (int a = 0; a < 3; ++a) max_index[a] = std::max(max_index[a], m[std::size_t(a)]);
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
      return std::size_t((ix * dims_[1] + iy) * dims_[2] + iz);  // key order
    };
    direct_cell_.assign(std::size_t(box_cells), -1);
    std::vector<std::uint32_t>& count = scratch.count;
    count.assign(std::size_t(box_cells) + 1, 0);
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
    fill_spheres(x, r);
    return;
  }
  members_.assign(members.begin(), members.end());
  radix_sort(keys, members_, scratch, worth_threads(keys.size()));
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
  fill_spheres(x, r);
}

void CellLevel::fill_spheres(const std::vector<Vec3>& x, const std::vector<double>& r) {
  sphere_.resize(members_.size());
  parallel_ranges(members_.size(), balanced_block_items(members_.size()),
                  [&](std::size_t begin, std::size_t end, std::size_t) {
                    for (std::size_t k = begin; k < end; ++k) {
                      const Vec3& p = x[members_[k]];
                      sphere_[k] = {p[0], p[1], p[2], r[members_[k]]};
                    }
                  });
}

std::size_t CellLevel::first_cell_from(std::uint64_t key) const {
  return std::size_t(std::lower_bound(cell_key_.begin(), cell_key_.end(), key) - cell_key_.begin());
}

std::size_t CellLevel::first_cell_at_member(std::uint32_t member) const {
  return std::size_t(std::lower_bound(start_.begin(), start_.end() - 1, member) - start_.begin());
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
    return direct_cell_[std::size_t((ix * dims_[1] + iy) * dims_[2] + iz)];
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
  const int levels = k == 1 ? 1 : std::clamp(settings.levels, 1, kMaxGridLevels);
  double edge[kMaxGridLevels];
  for (int l = 0; l < levels; ++l) edge[l] = c0 / std::pow(double(k), l);

  // Each particle on the deepest level whose cells it fits.
  LevelSummary summary[kMaxGridLevels];
  for (int l = 0; l < kMaxGridLevels; ++l) members_[l].clear();
  for (std::uint32_t i = 0; i < n; ++i) {
    const double reach = 2.0 * r[i] + skin;
    int l = levels - 1;
    while (l > 0 && reach > edge[l]) --l;
    members_[l].push_back(i);
    summary[l].r_mean_m += r[i];
    summary[l].r_max_m = std::max(summary[l].r_max_m, r[i]);
  }
  PairSink sink{box, skin, out};
  // On the engine's threads, pieces of a level's own pairs are runs of cells holding about
  // kSearchPieceParticles of its particles, pieces across levels runs of as many visiting
  // particles; on one thread, one piece. The list is the same for any cut.
  const bool on_team = worth_threads(n);
  auto piece_count = [&](std::size_t particles) {
    const std::size_t size = balanced_piece_items(particles, block_items(kSearchPieceParticles),
                                                  block_items(kSearchPieceMinParticles));
    return on_team ? std::max<std::size_t>(1, (particles + size - 1) / size) : 1;
  };
  auto share = [](std::size_t count, std::size_t piece, std::size_t pieces) {
    return std::uint32_t(count * piece / pieces);
  };
  int used[kMaxGridLevels], used_count = 0;
  for (int l = 0; l < levels; ++l) {
    if (members_[l].empty() && l > 0) continue;
    const CellLevel& level = level_[l];
    level_[l].build(x, r, members_[l], box, origin, edge[l], scratch_);
    const double reach_extra = summary[l].r_max_m + skin;
    if (small_periodic_box(level)) {
      small_box_pairs(level, sink);
    } else {
      const std::size_t members = level.slots().size(), pieces = piece_count(members);
      search_in_pieces(pieces, pieces_, sink, [&](std::size_t q, PairSink& piece_sink) {
        same_level_cells(level, box, reach_extra,
                         level.first_cell_at_member(share(members, q, pieces)),
                         level.first_cell_at_member(share(members, q + 1, pieces)), piece_sink);
      });
    }
    LevelSummary& s = summary[l];
    s.count = double(members_[l].size());
    s.r_mean_m /= std::max(1.0, s.count);
    s.edge_m = level_[l].edge(0);
    const double cell_volume = level_[l].edge(0) * level_[l].edge(1) * level_[l].edge(2);
    s.density_per_m3 = s.count / std::max(1e-300, double(level_[l].cell_count()) * cell_volume);
    used[used_count++] = l;
    stats_.level_particles[l] = members_[l].size();
    if (l == 0)
      stats_.cells = level_[l].cell_count();
    else
      stats_.subcells += level_[l].cell_count(), stats_.fine_particles += members_[l].size();
  }
  // Across levels: from whichever side the estimate says is cheaper.
  for (int a = 0; a < used_count; ++a)
    for (int b = a + 1; b < used_count; ++b) {
      const int coarse = used[a], fine = used[b];
      if (members_[coarse].empty()) continue;
      const bool upwards = visit_cost(summary[fine], summary[coarse], skin) <
                           visit_cost(summary[coarse], summary[fine], skin);
      const int from = upwards ? fine : coarse, to = upwards ? coarse : fine;
      const std::size_t visitors = level_[from].slots().size(), pieces = piece_count(visitors);
      search_in_pieces(pieces, pieces_, sink, [&](std::size_t q, PairSink& piece_sink) {
        cross_level_pairs(level_[from], level_[to], box, summary[to].r_max_m + skin,
                          share(visitors, q, pieces), share(visitors, q + 1, pieces), piece_sink);
      });
    }
  stats_.distance_tests = sink.tests;
  stats_.cell_lookups = sink.lookups;
  stats_.cell_m = level_[0].edge(0);
  stats_.subcells_per_axis = k;
  stats_.levels = used_count;
}

void spatial_order(const std::vector<Vec3>& x, const PeriodicBox& box,
                   std::vector<std::uint32_t>& order, SortScratch& scratch,
                   const std::uint8_t* behind) {
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
  std::vector<std::uint64_t>& keys = scratch.input_keys;
  keys.resize(x.size());
  order.resize(x.size());
  const std::size_t block = balanced_block_items(x.size());
  parallel_ranges(x.size(), block, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i) {
      std::uint64_t key = 0;
      for (int a = 0; a < 3; ++a) {
        const double c = std::clamp((x[i][a] - lo[a]) / edge, 0.0, double((1 << 21) - 1));
        key |= spread(std::uint64_t(c)) << a;
      }
      // (The Morton key takes bits 0–62.)
      if (behind && behind[i] != 0) key |= std::uint64_t(1) << 63;
      keys[i] = key;
      order[i] = std::uint32_t(i);
    }
  });
  radix_sort(keys, order, scratch, worth_threads(keys.size()));
}

namespace {

// Diameters in logarithmic bins: the cost model evaluates every division on bins, not particles.
struct DiameterBin {
  double count = 0.0, d_sum = 0.0, d_max = 0.0;
};

// Estimated distance tests plus weighted lookups per rebuild for one division, at uniform
// number density (docs/contact-search.md).
double division_cost(const std::vector<DiameterBin>& bins, double skin, double volume, double c0,
                     int k, int levels) {
  double edge[kMaxGridLevels];
  for (int l = 0; l < levels; ++l) edge[l] = c0 / std::pow(double(k), l);
  LevelSummary level[kMaxGridLevels];
  for (const DiameterBin& bin : bins) {
    if (bin.count == 0.0) continue;
    int l = levels - 1;
    while (l > 0 && bin.d_max + skin > edge[l]) --l;
    level[l].count += bin.count;
    level[l].r_mean_m += 0.5 * bin.d_sum;
    level[l].r_max_m = std::max(level[l].r_max_m, 0.5 * bin.d_max);
  }
  double cost = 0.0;
  for (int l = 0; l < levels; ++l) {
    LevelSummary& s = level[l];
    s.edge_m = edge[l];
    s.density_per_m3 = s.count / volume;
    s.r_mean_m /= std::max(1.0, s.count);
    if (s.count == 0.0) continue;
    // Half shell and own cell: 13.5 cells of tests, 13 lookups per occupied cell.
    const double cell_volume = edge[l] * edge[l] * edge[l];
    const double cells = std::min(s.count, volume / cell_volume);
    cost += s.count * 13.5 * cell_volume * s.density_per_m3 + kLookupCost * 13.0 * cells;
    for (int c = 0; c < l; ++c)
      if (level[c].count > 0.0)
        cost += std::min(visit_cost(level[c], s, skin), visit_cost(s, level[c], skin));
  }
  return cost;
}

}  // namespace

GridDivision choose_grid_division(const std::vector<double>& r, double skin, double volume,
                                  std::optional<int> fixed_k, std::optional<int> fixed_levels) {
  auto normalised = [](int k, int levels) {
    return k <= 1 ? GridDivision{1, 1} : GridDivision{k, std::clamp(levels, 2, kMaxGridLevels)};
  };
  if (fixed_levels && *fixed_levels <= 1) return {1, 1};
  if (fixed_k) return normalised(*fixed_k, fixed_levels.value_or(2));
  if (r.size() < 2 || volume <= 0.0) return {};
  const auto [lo, hi] = std::minmax_element(r.begin(), r.end());
  const double d_min = 2.0 * *lo, d_max = 2.0 * *hi;
  const double c0 = d_max + skin;
  constexpr int kBins = 256;
  std::vector<DiameterBin> bins(kBins);
  const double log_span = std::log(std::max(1.0 + 1e-12, d_max / d_min));
  for (double radius : r) {
    const double d = 2.0 * radius;
    const int b = std::clamp(int(std::log(d / d_min) / log_span * kBins), 0, kBins - 1);
    bins[std::size_t(b)].count += 1.0;
    bins[std::size_t(b)].d_sum += d;
    bins[std::size_t(b)].d_max = std::max(bins[std::size_t(b)].d_max, d);
  }
  GridDivision best{1, 1};
  double best_cost = division_cost(bins, skin, volume, c0, 1, 1);
  for (int k = 2; k <= 8; ++k)
    for (int levels = 2; levels <= kMaxGridLevels; ++levels) {
      if (fixed_levels && levels != std::clamp(*fixed_levels, 2, kMaxGridLevels)) continue;
      // A level finer than the smallest particle holds nobody: no deeper division helps.
      if (c0 / std::pow(double(k), levels - 1) < d_min + skin && levels > 2) continue;
      const double cost = division_cost(bins, skin, volume, c0, k, levels);
      if (cost < best_cost) best_cost = cost, best = {k, levels};
    }
  return best;
}

}  // namespace millsim
