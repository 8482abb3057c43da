// Hashed NBS grid (§2.1) with a sub-grid for fines (§2.2).
//
// Level 0 ("DEM cells") has cells at least 2 r_max + skin wide. With k > 1, level 1 divides
// each cell into k³ sub-cells of edge C1 = C0/k; a particle is *fine* when 2r + skin <= C1, so
// any two fine particles within reach lie in neighbouring sub-cells. Only occupied cells are
// stored and visited: particles are sorted by cell key (LSD radix sort), and a key is looked up
// in an open-addressing hash table (or, when the occupied box of cells is small, a direct
// table), so a dilute or clustered domain costs O(particles), not O(cells).
//
// Pairs are found once each:
//   coarse–coarse: own cell + the 13 half-shell cells of level 0, each swept only when the
//                  particle can reach it (the proximity check against the cell's bounds);
//   fine–fine:     the same on level 1;
//   coarse–fine:   each coarse particle visits the level-1 sub-cells its reach sphere touches.
// The result equals the all-pairs search (tests/engine/hashed_grid_test.cpp).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/vec3.h"
#include "dem/box.h"
#include "search/pair_search.h"

namespace millsim {

// One level: occupied cells of one edge length.
class CellLevel {
 public:
  // Bins the particles `members` (slots into x) into cells of at least `cell_m` edge. On a
  // periodic axis the edge is stretched so a whole number of cells fills the box.
  void build(const std::vector<Vec3>& x, const std::vector<std::uint32_t>& members,
             const PeriodicBox& box, const Vec3& origin, double cell_m);

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
  const std::uint32_t* begin(std::size_t cell) const { return members_.data() + start_[cell]; }
  const std::uint32_t* end(std::size_t cell) const { return members_.data() + start_[cell + 1]; }
  double lower(long index, int axis) const { return origin_[axis] + double(index) * edge_[axis]; }

 private:
  static std::uint64_t pack(long ix, long iy, long iz);
  Vec3 origin_;
  double edge_[3] = {1, 1, 1};
  long periodic_cells_[3] = {0, 0, 0};  // 0 on non-periodic axes
  std::vector<std::uint64_t> cell_key_;
  std::vector<std::uint32_t> start_;    // cell_count + 1 offsets into members_
  std::vector<std::uint32_t> members_;  // slots grouped by cell
  // Lookup key → cell: a direct table over the occupied bounding box of cells when that box is
  // small (at most 8 entries per particle), an open-addressing hash table otherwise.
  bool direct_ = false;
  long dims_[3] = {0, 0, 0};
  std::vector<std::int32_t> direct_cell_;
  std::vector<std::uint64_t> table_key_;
  std::vector<std::uint32_t> table_cell_;
  std::uint64_t table_mask_ = 0;
};

struct HashedGridSettings {
  double skin_m = 0.0;
  int subcells_per_axis = 1;         // k; 1 = no sub-grid
  std::optional<double> min_cell_m;  // lower bound on the level-0 edge
};

struct HashedGridStats {
  std::uint64_t distance_tests = 0;
  std::uint64_t coarse_particles = 0, fine_particles = 0;
  std::uint64_t cells = 0, subcells = 0;  // occupied
  double cell_m = 0.0, subcell_m = 0.0;
  int subcells_per_axis = 1;
};

class HashedGrid {
 public:
  void find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r, const PeriodicBox& box,
                  const HashedGridSettings& settings, PairList& out);
  const HashedGridStats& stats() const { return stats_; }

 private:
  CellLevel coarse_, fine_;
  std::vector<std::uint32_t> coarse_members_, fine_members_;
  HashedGridStats stats_;
};

// A spatially coherent order of all particles (cell by cell, cells of about 2 mean spacings),
// for ParticleStore::permute.
std::vector<std::uint32_t> spatial_order(const std::vector<Vec3>& x, const PeriodicBox& box);

// Automatic sub-cell division: the k in 1..8 that minimises a distance-test estimate for the
// size distribution at uniform density in the particles' volume (docs/contact-search.md).
int choose_subcells_per_axis(const std::vector<double>& radius_m, double skin_m, double volume_m3);

}  // namespace millsim
