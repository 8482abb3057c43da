// Hashed NBS grid (§2.1) with a sub-grid for fines (§2.2), extended to a hierarchy of levels.
//
// Level 0 ("DEM cells") has cells at least 2 r_max + skin wide. With k > 1, level l has cells of
// edge C_l = C0/k^l (l < L, the number of levels; the paper's sub-grid is L = 2); a particle
// lives on the deepest level whose cells it fits, 2r + skin <= C_l, so any two particles of one
// level within reach lie in neighbouring cells of that level. Only occupied cells are stored and
// visited: particles are sorted by cell key (LSD radix sort), and a key is looked up in an
// open-addressing hash table (or, when the occupied box of cells is small, a direct table), so a
// dilute or clustered domain costs O(particles), not O(cells).
//
// Pairs are found once each:
//   same level:    own cell + the 13 half-shell cells, each swept only when the particle can
//                  reach it (the proximity check against the cell's bounds);
//   across levels: the particles of one level visit the cells of the other that their reach
//                  sphere touches; downwards (coarse visits fine cells) or upwards (fine visits
//                  coarse cells), whichever the level's counts say is cheaper.
// The result equals the all-pairs search (tests/engine/hashed_grid_test.cpp).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/vec3.h"
#include "dem/box.h"
#include "search/pair_search.h"

namespace millsim {

// Work arrays of a radix sort, kept between rebuilds so that no rebuild allocates.
struct SortScratch {
  std::vector<std::uint64_t> input_keys;  // the keys to sort, filled by the caller
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> values, count;
};

// A particle as the distance tests read it.
struct Sphere {
  double x, y, z, r;
};

// One level: occupied cells of one edge length.
class CellLevel {
 public:
  // Bins the particles `members` (slots into x) into cells of at least `cell_m` edge. On a
  // periodic axis the edge is stretched so a whole number of cells fills the box.
  void build(const std::vector<Vec3>& x, const std::vector<double>& r,
             const std::vector<std::uint32_t>& members, const PeriodicBox& box, const Vec3& origin,
             double cell_m, SortScratch& scratch);

  // Index of the occupied cell (ix, iy, iz) after periodic wrapping, or −1 when empty/outside.
  // Indices may lie at most one box length outside [0, n) on periodic axes.
  long find(long ix, long iy, long iz) const;
  // The same for indices already wrapped into [0, n) on periodic axes.
  long find_wrapped(long ix, long iy, long iz) const;

  std::size_t cell_count() const { return cell_key_.size(); }
  double edge(int axis) const { return edge_[axis]; }
  long periodic_cells(int axis) const { return periodic_cells_[axis]; }
  long index_of(double coordinate, int axis) const;
  // Cell coordinates of an occupied cell, and its members.
  void coordinates(std::size_t cell, long out[3]) const;
  // Key of an occupied cell; cells are numbered in increasing key order (x slowest, z fastest).
  std::uint64_t key(std::size_t cell) const { return cell_key_[cell]; }
  // The first occupied cell whose key is at least `key` (cell_count() when none).
  std::size_t first_cell_from(std::uint64_t key) const;
  // The first cell whose members start at or after position `member` (cell_count() when none).
  std::size_t first_cell_at_member(std::uint32_t member) const;
  static std::uint64_t pack(long ix, long iy, long iz);
  // Members of a cell as positions into the level's arrays: [first(cell), last(cell)).
  std::uint32_t first(std::size_t cell) const { return start_[cell]; }
  std::uint32_t last(std::size_t cell) const { return start_[cell + 1]; }
  // Slot of the member at a position, and its sphere (centre and radius, copied in cell order
  // so the distance tests stream through contiguous memory).
  const std::vector<std::uint32_t>& slots() const { return members_; }
  const std::vector<Sphere>& spheres() const { return sphere_; }
  double lower(long index, int axis) const { return origin_[axis] + double(index) * edge_[axis]; }

 private:
  void fill_spheres(const std::vector<Vec3>& x, const std::vector<double>& r);
  Vec3 origin_;
  double edge_[3] = {1, 1, 1};
  long periodic_cells_[3] = {0, 0, 0};  // 0 on non-periodic axes
  std::vector<std::uint64_t> cell_key_;
  std::vector<std::uint32_t> start_;    // cell_count + 1 offsets into members_
  std::vector<std::uint32_t> members_;  // slots grouped by cell
  std::vector<Sphere> sphere_;          // aligned with members_
  // Lookup key → cell: a direct table over the occupied bounding box of cells when that box is
  // small (at most 8 entries per particle), an open-addressing hash table otherwise.
  bool direct_ = false;
  long dims_[3] = {0, 0, 0};
  std::vector<std::int32_t> direct_cell_;
  std::vector<std::uint64_t> table_key_;
  std::vector<std::uint32_t> table_cell_;
  std::uint64_t table_mask_ = 0;
};

inline constexpr int kMaxGridLevels = 4;

struct HashedGridSettings {
  double skin_m = 0.0;
  int subcells_per_axis = 1;         // k; 1 = one level (no sub-grid)
  int levels = 2;                    // L with k > 1: cell edges C0, C0/k, …, C0/k^(L−1)
  std::optional<double> min_cell_m;  // lower bound on the level-0 edge
};

struct HashedGridStats {
  std::uint64_t distance_tests = 0;
  std::uint64_t cell_lookups = 0;    // hash or direct-table probes (sorted-row reads not counted)
  std::uint64_t fine_particles = 0;  // on levels >= 1
  std::uint64_t cells = 0, subcells = 0;  // occupied, level 0 and levels >= 1
  double cell_m = 0.0;                    // level-0 edge
  int subcells_per_axis = 1;
  int levels = 1;  // levels holding particles
  std::uint64_t level_particles[kMaxGridLevels] = {0, 0, 0, 0};
};

// One piece of a search run on the engine's threads: its candidates, in the order one thread
// finds them, and its counts. The pieces' lists are joined in piece order.
struct SearchPiece {
  PairList pairs;
  std::uint64_t tests = 0, lookups = 0;
};

class HashedGrid {
 public:
  void find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r, const PeriodicBox& box,
                  const HashedGridSettings& settings, PairList& out);
  const HashedGridStats& stats() const { return stats_; }
  // The grid's sort buffers, free between searches (the neighbour list reorders with them).
  SortScratch& scratch() { return scratch_; }

 private:
  CellLevel level_[kMaxGridLevels];
  std::vector<std::uint32_t> members_[kMaxGridLevels];
  SortScratch scratch_;
  std::vector<SearchPiece> pieces_;  // one wave's pieces while the search runs on several threads
  HashedGridStats stats_;
};

// A spatially coherent order of all particles (Morton order of cells of about one mean
// spacing), for ParticleStore::permute, written into `order`. With `behind` (one flag per
// particle), the particles flagged non-zero come after all the others, each part in Morton
// order: multi-rate stepping keeps the particles that take the contact step together in memory.
void spatial_order(const std::vector<Vec3>& x, const PeriodicBox& box,
                   std::vector<std::uint32_t>& order, SortScratch& scratch,
                   const std::uint8_t* behind = nullptr);

// One cell probe (hash or direct table) costs about as many distance tests as this in the
// search's cost model (bench_step --search-scan).
inline constexpr double kLookupCostTests = 8.0;

// The grid's division: k and the number of levels L (1 when k = 1).
struct GridDivision {
  int subcells_per_axis = 1;
  int levels = 1;
  bool operator==(const GridDivision&) const = default;
};

// Automatic division: the k in 1..8 and L in 2..kMaxGridLevels (or k = 1) that minimise an
// estimate of distance tests and cell lookups for the size distribution at uniform density in
// the particles' volume (docs/contact-search.md). A given k or L is kept and only the other
// chosen; a given k without L means the paper's two levels.
GridDivision choose_grid_division(const std::vector<double>& radius_m, double skin_m,
                                  double volume_m3, std::optional<int> subcells_per_axis = {},
                                  std::optional<int> levels = {});

}  // namespace millsim
