// NeighborList: candidate particle pairs and particle–wall pairs within a skin, rebuilt only when
// some particle has moved more than its share of it since the last build (skin/2, more for the
// fastest particles: skin by speed), measured in a frame turning with the particles where the
// walls allow (a mill's chamber; dem/motion_frame.h), or when particles were added or removed.
// Owns the tangential spring history of each candidate, aligned with the lists, and carries it
// across rebuilds by stable particle id. The contact set derived from it (overlap > 0) is exactly
// the all-pairs contact set: the rebuild rule guarantees no touching pair is missing.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "checkpoint/archive.h"
#include "contact/contact_law.h"
#include "contact/walls.h"
#include "dem/motion_frame.h"
#include "parallel/slot_shares.h"
#include "particles/particle_store.h"
#include "search/hashed_grid.h"
#include "search/nbs_grid.h"
#include "search/pair_search.h"

namespace millsim {

// Contact state of a candidate pair (pair_touching) at the last force pass.
inline constexpr std::uint8_t kPairApart = 0;
inline constexpr std::uint8_t kPairTouching = 1;
// Particles born overlapping (comminution/fragment_spawn.h): the pair's history holds the
// overlap memory δ₀ (x component), the overlap at birth, lowered whenever the overlap falls
// below it. Only δ − δ₀ > 0 pushes back (normal force, no friction), so the birth overlap stores
// no energy, yet the pair resists being pushed further together. Ends when the pair separates.
inline constexpr std::uint8_t kPairGhost = 2;

// A particle added mid-run. Its contacts at birth are not impacts. Its overlaps at birth become
// ghost pairs (with overlap memory) when the partner is a sibling (same nonzero family: one
// breakage event), when its parent was a ghost with the partner (fragments of a fragment still
// passing through the parent's siblings), or when they are deeper than the penetration limit.
struct Newborn {
  ParticleId id;
  std::uint64_t family;  // breakage event number; 0 = not a fragment (feed)
  ParticleId parent;     // the broken particle; 0 = none
};

// Tangential spring displacements (m), or a ghost pair's overlap memory, of the candidates that
// have one, kept in a pool that candidates index into: most candidates never touch, and cost 4
// bytes instead of 24. Slots freed when a contact ends are reused.
inline constexpr std::uint32_t kNoHistory = ~std::uint32_t(0);
class HistoryPool {
 public:
  std::uint32_t take(const Vec3& value) {
    if (free_.empty()) {
      values_.push_back(value);
      return std::uint32_t(values_.size() - 1);
    }
    const std::uint32_t slot = free_.back();
    free_.pop_back();
    values_[slot] = value;
    return slot;
  }
  void give_back(std::uint32_t slot) { free_.push_back(slot); }
  void clear() { values_.clear(), free_.clear(); }
  Vec3& operator[](std::uint32_t slot) { return values_[slot]; }
  const Vec3& operator[](std::uint32_t slot) const { return values_[slot]; }
  std::size_t in_use() const { return values_.size() - free_.size(); }
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, values_, free_);
  }

 private:
  std::vector<Vec3> values_;
  std::vector<std::uint32_t> free_;
};

struct NeighborStats {
  std::uint64_t rebuilds = 0;
  std::uint64_t distance_tests = 0;
  HashedGridStats last_search;
};

// How candidates are found at a rebuild (the list itself is the same either way).
enum class SearchMethod {
  Hashed,  // hashed NBS grid with the sub-grid levels (§2.1–2.2, search/hashed_grid.h)
  Nbs,     // the conventional dense NBS of Munjiza & Andrews (search/nbs_grid.h), a baseline
};

struct NeighborSettings {
  double skin_m = 0.0;
  bool automatic_skin = false;  // ¼ √(d_min d_max) when the population changes, then steered
  double max_skin_m = 1e300;    // never past this (the periodic minimum image)
  std::optional<double> cell_size_m;     // lower bound on the DEM-cell edge
  std::optional<int> subcells_per_axis;  // absent = automatic (with the levels)
  std::optional<int> grid_levels;        // absent = automatic, or 2 when k is given
  double step_s = 0.0;  // DEM time step, to predict a new population's list lifetime; 0 = unknown
  SearchMethod method = SearchMethod::Hashed;
  // Measure motion in a frame turning with the particles (dem/motion_frame.h) where the walls
  // allow it: a closed box, and every wall a surface of revolution about one axis or a plane
  // normal to it (a mill's chamber). Elsewhere, or when false, the lab frame.
  bool rotating_frame = true;
  // Give the fastest particles (relative to the frame) a larger share of the skin, in proportion
  // to their speed: the list then lives as long as the bulk allows, not its fastest few.
  bool skin_by_speed = true;
};

class NeighborList {
 public:
  NeighborList() = default;
  explicit NeighborList(const NeighborSettings& settings) : settings_(settings) {}

  // Adds one step's largest displacement to the running bound: max_speed·dt, the speed relative to
  // motion_frame() (the kick-drift passes report it so), plus what the frame's turn adds
  // (dem/motion_frame.h). While the bound stays under skin/2 no particle can have moved that far,
  // and update() skips the O(N) exact check. Each block of kSpeedBlockSlots slots
  // (dem/integrator.h) keeps a bound of its own from its own largest speed, so that the gap bands
  // open block by block: a few fast particles then open them only around themselves.
  void note_motion(const std::vector<double>& block_max_speed_m_per_s, double max_speed_m_per_s,
                   double dt);

  // Rebuilds when needed (or when `force`); returns true if it did. A rebuild first wraps the
  // positions into the periodic box; between rebuilds they may drift out by up to skin/2, and
  // each pair keeps the periodic image it had at the rebuild (pair_shift()).
  bool update(ParticleStore& particles, const PeriodicBox& box, const std::vector<Wall>& walls,
              bool force);

  // Particles added since the last rebuild; consumed by the next (forced) rebuild, which must
  // come before any force pass.
  void mark_newborn(std::vector<Newborn> newborn, double penetration_limit);

  // Candidates in these ranges may touch now; the rest are still too far apart to have closed
  // their gap at the rebuild, so the force loop need not look at them. Candidates are sorted by
  // that gap, in bands of a quarter skin, and within a band by first slot, so each band is a run
  // of slot blocks; a band joins block by block as the motion bounds of the block and of the
  // blocks its partners lie in grow.
  struct PairRange {
    std::size_t begin, end;
  };
  const std::vector<PairRange>& active_ranges() const { return active_ranges_; }
  bool pair_active(std::size_t k) const;
  static constexpr int kGapBands = 4;
  // The active candidates of gap band `band`, as runs in candidate order; each band's candidates
  // are sorted by first slot.
  void active_runs_of_band(int band, std::vector<PairRange>& runs) const;
  // The active candidates listed at each unit of `unit` slots (of `slots`): the work of a force
  // pass on each part of the slots, for the owner shares (parallel/slot_shares.h).
  void count_active_candidates(std::size_t slots, std::size_t unit,
                               std::vector<std::uint64_t>& per_unit) const;

  // Separation of pair k's partners: x_i − x_j − pair_shift(k).
  const Vec3& pair_shift(std::size_t k) const { return image_shift_[pair_image[k]]; }

  // Whether the list was built for the population as it is (no particle added or removed since).
  bool current(const ParticleStore& particles) const {
    return particles.population_version == population_version_;
  }

  // True when the cheap motion bound says the next update() may rebuild anyway.
  bool rebuild_likely() const { return motion_bound_m_ > 0.5 * settings_.skin_m; }
  // True when, at the rate of the last step, the cheap bound will say so after one more step: the
  // next update() will measure motion and most likely rebuild. A population change applied now
  // takes the place of that rebuild instead of adding one (Simulation::process_population).
  bool rebuild_expected_next_step() const {
    return motion_bound_m_ + last_bound_increment_m_ > 0.5 * settings_.skin_m;
  }

  // The frame this list measures motion in, chosen at each rebuild: turning about the walls' common
  // axis at the particles' mean angular velocity about it (a least-squares fit), or the lab frame.
  // Speeds reported to note_motion() must be relative to it.
  const MotionFrame& motion_frame() const { return frame_; }
  // How speeds must be reported to note_motion(): relative to the frame, each particle's divided
  // by its share of the skin κ_i (skin by speed: at each rebuild, particles faster than the
  // population's 99th percentile of speed relative to the frame get κ_i = their speed over it, at
  // most 4, and every pair is listed within r_i + r_j + (κ_i + κ_j) skin/2). Until the next
  // rebuild after a population change, no scales (every speed counts whole: a wider bound).
  SpeedReport speed_report(const ParticleStore& particles) const {
    const bool scaled =
        !speed_scale2_.empty() && particles.size() == speed_scale2_.size() && current(particles);
    return {frame_, scaled ? speed_scale2_.data() : nullptr};
  }

  double skin_m() const { return settings_.skin_m; }
  const NeighborSettings& settings() const { return settings_; }
  const NeighborStats& stats() const { return stats_; }

  // Empties wall_springs_memo (one entry per wall candidate, none made yet).
  void forget_wall_springs();

  // The slots each thread owned in the last threaded force pass (contact/contact_forces.h),
  // balanced by its active candidates; the next kick-drift runs on them. Derived: made by every
  // threaded pass, empty after a one-thread one, never checkpointed.
  SlotShares owner_shares;
  ShareBalancer owner_balance;  // what a candidate costs where (derived, never checkpointed)

  // Particle–particle candidates, each listed from its higher slot (first > second), and their
  // tangential spring displacement (m).
  PairList pairs;
  std::vector<std::uint8_t> pair_image;     // index into the 27 periodic shifts
  std::vector<std::uint32_t> pair_history;  // slot in history_pool, or kNoHistory
  HistoryPool history_pool;
  // Pair k's tangential spring displacement (m), or overlap memory for a ghost; zero when none.
  Vec3 pair_history_m(std::size_t k) const {
    return pair_history[k] == kNoHistory ? Vec3{} : history_pool[pair_history[k]];
  }
  // kPairApart/kPairTouching/kPairGhost at the last force pass; carried across rebuilds by id,
  // so a contact's onset (an impact) is seen exactly once.
  std::vector<std::uint8_t> pair_touching;
  // Particle–wall candidates.
  std::vector<std::uint32_t> wall_particle;
  std::vector<std::uint32_t> wall_index;
  std::vector<Vec3> wall_history_m;
  std::vector<std::uint8_t> wall_touching;
  // Per wall candidate, for the force pass: the springs of its last touching step and the wall's
  // curvature they were made for (NaN: none yet). A candidate's particle and wall are fixed
  // until the next rebuild, so its springs change only with the curvature under it (a tube's
  // inside, outside or rim). Derived: emptied at every rebuild and load, never checkpointed.
  struct WallSpringsMemo {
    double curvature_per_m;
    PairSprings springs;
  };
  std::vector<WallSpringsMemo> wall_springs_memo;

  // Checkpoints: the lists, their history and every bound and choice the next steps read. The
  // grids are not kept: a rebuild fills them from the positions alone.
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, pairs, pair_image, pair_history, history_pool, pair_touching, wall_particle,
           wall_index, wall_history_m, wall_touching);
    if constexpr (std::is_same_v<A, ArchiveReader>) forget_wall_springs();
    io_all(a, settings_, division_, division_skin_m_, image_shift_, motion_bound_m_,
           steps_since_rebuild_, previous_skin_m_, next_skin_m_, population_version_);
    io_all(a, reference_position_m_, reference_id_, newborn_, overlapping_, band_end_,
           active_bands_, block_bound_m_, block_bounds_valid_, partner_block_start_,
           partner_blocks_, band_block_start_, block_active_, blocks_joined_, active_ranges_);
    io_all(a, reorder_spacing_m_, motion_since_reorder_m_, newborn_ghost_ratio_, stats_);
    io_all(a, frame_, frame_elapsed_s_, speed_scale2_, last_bound_increment_m_);
  }

 private:
  // The frame for the list about to be built from the particles as they are now.
  MotionFrame choose_frame(const ParticleStore& particles, const PeriodicBox& box,
                           const std::vector<Wall>& walls) const;
  // The shares of the skin for the list about to be built (speed_scale2_), and the search radii
  // r_i + (κ_i − 1) skin/2 (search_radius_m_) when any share exceeds 1.
  void choose_shares(const ParticleStore& particles);
  // Largest displacement since the last build, in the list's frame; stops early once past skin/2.
  double max_displacement_m(const ParticleStore& particles, const PeriodicBox& box) const;
  void rebuild(const ParticleStore& particles, const PeriodicBox& box,
               const std::vector<Wall>& walls, bool population_changed);
  // The skin for the next list, from this list's candidate gaps and the last rebuild interval.
  // `steps_per_skin`: steps a list lasts per metre of skin (observed, or predicted from speeds).
  double steer_skin(const ParticleStore& particles, double steps_per_skin) const;
  // Sorts the candidates by gap band (gap at the rebuild in quarters of the skin), each band by
  // first slot, sets their periodic images, and lists those that overlap now (overlapping_).
  void sort_pairs(const ParticleStore& particles, const PeriodicBox& box);
  // Lets in the bands, whole or block by block, whose pairs the motion since the rebuild may have
  // closed, and lists the active ranges.
  void widen_active_bands();
  void list_active_ranges();
  // After a rebuild: no motion yet, the closest band active alone.
  void reset_motion_bounds();
  // Whether particles may have strayed far enough from the last spatial reorder (half a mean
  // spacing) for memory order to lose its locality.
  bool reorder_due() const { return motion_since_reorder_m_ >= 0.5 * reorder_spacing_m_; }

  // The grid division for this rebuild: re-chosen when the population changed or the skin moved
  // by more than a quarter since the last choice.
  GridDivision division(const ParticleStore& particles, const PeriodicBox& box,
                        bool population_changed);

  NeighborSettings settings_;
  HashedGrid grid_;
  NbsGrid nbs_;  // only with SearchMethod::Nbs
  GridDivision division_;
  double division_skin_m_ = -1.0;
  Vec3 image_shift_[27];
  double motion_bound_m_ = 0.0;
  double last_bound_increment_m_ = 0.0;  // what the last note_motion() added to it
  std::uint64_t steps_since_rebuild_ = 0;
  double previous_skin_m_ = 0.0;       // skin of the list whose interval just ended
  std::optional<double> next_skin_m_;  // steered skin, applied at the next rebuild
  std::uint64_t population_version_ = ~std::uint64_t(0);
  std::vector<Vec3> reference_position_m_;
  std::vector<ParticleId> reference_id_;
  std::vector<Newborn> newborn_;  // sorted by id
  // Work arrays kept between rebuilds, so that a rebuild does not allocate.
  std::vector<std::uint32_t> order_;
  PairList sorted_pairs_;
  std::vector<std::uint8_t> image_scratch_, band_scratch_;
  std::vector<std::vector<std::uint32_t>> wall_block_scratch_;  // per slot block, while listing
  static constexpr std::uint8_t kOverlappingBit = 0x80;         // in band_scratch_
  std::vector<std::uint32_t> overlapping_;  // candidates overlapping at the rebuild
  std::size_t band_end_[kGapBands] = {0, 0, 0, 0};
  int active_bands_ = kGapBands;  // bands [0, active_bands_) are active in every block
  // Per slot block: the motion bound of its particles (false: unknown, use the global one), the
  // blocks its candidates' second partners lie in (CSR, itself included), where each band's run
  // of it begins (band_block_start_[b][block], one past the last block = the band's end), and
  // which of the partly active bands it has joined.
  std::vector<double> block_bound_m_;
  bool block_bounds_valid_ = false;
  std::vector<std::uint32_t> partner_block_start_, partner_blocks_;
  // Work arrays of sort_pairs: per chunk of the list and bucket of slots, where its pairs go;
  // per bucket, where its pairs start, its pairs per band (then where they go), the speed blocks
  // its second partners lie in, and its overlapping candidates; per speed block, which blocks
  // are listed for it.
  std::vector<std::uint32_t> sort_positions_;
  std::vector<std::size_t> bucket_start_, bucket_band_pairs_;
  std::vector<std::vector<std::uint32_t>> bucket_partner_blocks_, bucket_overlapping_;
  std::vector<std::uint32_t> block_seen_;
  std::vector<std::size_t> band_block_start_[kGapBands];
  std::vector<std::uint8_t> block_active_[kGapBands];
  std::size_t blocks_joined_[kGapBands] = {0, 0, 0, 0};
  std::vector<PairRange> active_ranges_;
  double reorder_spacing_m_ = 0.0;       // mean particle spacing at the last reorder
  double motion_since_reorder_m_ = 0.0;  // bound on any particle's motion since then
  double newborn_ghost_ratio_ =
      0.15;  // overlap / smaller diameter past which a birth contact is a ghost
  NeighborStats stats_;
  MotionFrame frame_;             // lab frame until the first rebuild
  double frame_elapsed_s_ = 0.0;  // time since the last rebuild, over which the frame has turned
  // Skin by speed: per slot 1/κ_i² (empty: κ = 1 for all). The motion bounds are in units of the
  // common share skin/2; a pair with a partner of κ > 1 lies in the closest gap band, looked at
  // from the start (the bands open by the blocks' bounds, which are in shares).
  std::vector<double> speed_scale2_;
  std::vector<double> search_radius_m_;  // of choose_shares, for the rebuild's search
  std::vector<double> speed_scratch_, sorted_speed_scratch_;
};

// The axis every wall is a surface of revolution about (or, for a plane, normal to), as a frame
// turning at 0: none when there is no curved wall, or when the walls share no axis exactly.
std::optional<MotionFrame> common_wall_axis(const std::vector<Wall>& walls);

}  // namespace millsim
