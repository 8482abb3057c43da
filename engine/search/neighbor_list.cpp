#include "search/neighbor_list.h"

#include "parallel/thread_team.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dem/integrator.h"

namespace millsim {
namespace {

constexpr std::size_t kReorderMinParticles = 4096;
// Skin by speed: the largest share of the skin a particle may have, in units of the common one.
constexpr double kLargestShare = 4.0;

struct KeyedHistory {
  std::uint64_t a, b;  // stable ids (particle ids, or particle id and wall index)
  Vec3 history;        // a pair's tangential spring as seen from a (the lower id)
  std::uint8_t state;  // kPairApart / kPairTouching / kPairGhost
  bool operator<(const KeyedHistory& o) const { return a != o.a ? a < o.a : b < o.b; }
};

// A tangential spring is the first partner's displacement relative to the second, so it turns
// with the pair when a rebuild lists the pair the other way round; a ghost's overlap memory is a
// length and does not. `first_is_higher`: the pair is listed from its higher id.
Vec3 spring_from_lower_id(const Vec3& history, std::uint8_t state, bool first_is_higher) {
  return first_is_higher && state != kPairGhost ? -history : history;
}

const KeyedHistory* lookup(const std::vector<KeyedHistory>& table, std::uint64_t a,
                           std::uint64_t b) {
  auto it = std::lower_bound(table.begin(), table.end(), KeyedHistory{a, b, {}, 0});
  return it != table.end() && it->a == a && it->b == b ? &*it : nullptr;
}

const Newborn* find_newborn(const std::vector<Newborn>& newborn, ParticleId id) {
  auto it = std::lower_bound(newborn.begin(), newborn.end(), id,
                             [](const Newborn& n, ParticleId v) { return n.id < v; });
  return it != newborn.end() && it->id == id ? &*it : nullptr;
}

// ¼ √(d_min d_max): ¼ d for equal sizes, ≈ 1 d_min at 1:10, 2.5 d_min at 1:100 (the best of a
// scan on the shared scenes, bench/RESULTS.md).
double automatic_skin_m(const std::vector<double>& radius_m, double max_skin_m) {
  if (radius_m.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(radius_m.begin(), radius_m.end());
  return std::clamp(0.5 * std::sqrt(*lo * *hi), 0.0, max_skin_m);
}

// The smallest skin the steering may choose: a twentieth of the smallest diameter.
double skin_floor_m(const ParticleStore& p) {
  return 0.1 * *std::min_element(p.radius_m.begin(), p.radius_m.end());
}

// Volume the particles occupy for the sub-cell cost model: the periodic box, or the particles'
// bounding box on non-periodic axes.
double occupied_volume_m3(const std::vector<Vec3>& x, const PeriodicBox& box) {
  double volume = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (box.periodic[a]) {
      volume *= box.length(a);
      continue;
    }
    double lo = 1e300, hi = -1e300;
    for (const Vec3& p : x) lo = std::min(lo, p[a]), hi = std::max(hi, p[a]);
    volume *= std::max(hi - lo, 1e-12);
  }
  return volume;
}

// Whether the pair (a, b) descends from a ghost pair: (parent of a or a, parent of b or b) was
// a ghost at the last force pass.
bool parents_were_ghosts(const std::vector<KeyedHistory>& old_pairs, ParticleId a,
                         const Newborn* na, ParticleId b, const Newborn* nb) {
  const ParticleId pa = na && na->parent ? na->parent : a;
  const ParticleId pb = nb && nb->parent ? nb->parent : b;
  if (pa == a && pb == b) return false;
  const KeyedHistory* h = lookup(old_pairs, std::min(pa, pb), std::max(pa, pb));
  return h && h->state == kPairGhost;
}

}  // namespace

void NeighborList::mark_newborn(std::vector<Newborn> newborn, double penetration_limit) {
  newborn_ghost_ratio_ = penetration_limit;
  newborn_.insert(newborn_.end(), newborn.begin(), newborn.end());
  std::sort(newborn_.begin(), newborn_.end(),
            [](const Newborn& x, const Newborn& y) { return x.id < y.id; });
}

std::optional<MotionFrame> common_wall_axis(const std::vector<Wall>& walls) {
  std::optional<MotionFrame> axis;
  for (const Wall& w : walls)
    if (w.surface.kind != SurfaceKind::Plane && !axis)
      axis = MotionFrame{w.surface.point_m, w.surface.normal};
  if (!axis) return std::nullopt;
  // Exactly: a mill's surfaces share one axis point and direction (geometry/mill.cpp).
  auto parallel = [](const Vec3& u, const Vec3& v) { return norm2(cross(u, v)) == 0.0; };
  for (const Wall& w : walls) {
    const Surface& s = w.surface;
    if (!parallel(s.normal, axis->axis)) return std::nullopt;
    if (s.kind != SurfaceKind::Plane && !parallel(s.point_m - axis->center_m, axis->axis))
      return std::nullopt;
  }
  return axis;
}

MotionFrame NeighborList::choose_frame(const ParticleStore& p, const PeriodicBox& box,
                                       const std::vector<Wall>& walls) const {
  if (!settings_.rotating_frame || box.any_periodic() || p.size() == 0) return {};
  const std::optional<MotionFrame> axis = common_wall_axis(walls);
  if (!axis) return {};
  // Ω minimising Σ |v − Ω a × r|² over the particles (r their offsets from the axis), and the
  // largest |r|: the reference points keep their distance from the axis as the frame turns.
  MotionFrame f = *axis;
  double moment = 0.0, spread = 0.0, radius2 = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3 r = p.position_m[i] - f.center_m;
    const Vec3 r_perp = r - f.axis * dot(r, f.axis);
    moment += dot(f.axis, cross(r_perp, p.motion[i].velocity_m_per_s));
    spread += norm2(r_perp);
    radius2 = std::max(radius2, norm2(r_perp));
  }
  f.omega_rad_per_s = spread > 0.0 && std::isfinite(moment) ? moment / spread : 0.0;
  f.radius_bound_m = std::sqrt(radius2);
  return f;
}

void NeighborList::choose_shares(const ParticleStore& p) {
  speed_scale2_.clear(), search_radius_m_.clear();
  const std::size_t n = p.size();
  if (!settings_.skin_by_speed || n < 2 || !(settings_.skin_m > 0.0)) return;
  // The speeds relative to the frame and their 99th percentile (counted, never timed); the
  // per-particle loops in blocks on the engine's threads, each writing its own places.
  const bool team = worth_threads(n);
  const std::size_t block = balanced_block_items(n);
  std::vector<double>& speed = speed_scratch_;
  speed.resize(n);
  parallel_ranges_if(team, n, block, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i)
      speed[i] = std::sqrt(frame_speed2(frame_, p.position_m[i], p.motion[i].velocity_m_per_s));
  });
  std::vector<double>& sorted = sorted_speed_scratch_;
  sorted = speed;
  const std::size_t q = n - 1 - n / 100;
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(q), sorted.end());
  const double reference = sorted[q];
  if (!(reference > 0.0)) return;
  // κ_i = u_i / u_99, at most 4, and no larger than keeps r_i + (κ_i − 1) skin/2 within the
  // largest radius (the grid's cells stay as they were).
  const double half_skin = 0.5 * settings_.skin_m;
  const double r_max = *std::max_element(p.radius_m.begin(), p.radius_m.end());
  std::vector<double>& share = speed;  // each speed becomes its share
  std::vector<std::uint8_t> block_any((n + block - 1) / block, 0);
  parallel_ranges_if(team, n, block, [&](std::size_t begin, std::size_t end, std::size_t b) {
    for (std::size_t i = begin; i < end; ++i) {
      if (speed[i] <= reference) {
        share[i] = 1.0;
        continue;
      }
      const double room = 1.0 + (r_max - p.radius_m[i]) / half_skin;
      share[i] = std::min({speed[i] / reference, kLargestShare, room});
      if (share[i] > 1.0) block_any[b] = 1;
    }
  });
  if (std::find(block_any.begin(), block_any.end(), 1) == block_any.end()) return;
  speed_scale2_.resize(n), search_radius_m_.resize(n);
  parallel_ranges_if(team, n, block, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i) {
      speed_scale2_[i] = 1.0 / (share[i] * share[i]);
      search_radius_m_[i] = p.radius_m[i] + (share[i] - 1.0) * half_skin;
    }
  });
}

double NeighborList::max_displacement_m(const ParticleStore& p, const PeriodicBox& box) const {
  // Per block of slots on the engine's threads, each block stopping once past skin/2. Below
  // skin/2 the figure is the exact largest displacement on any count; past it only the rebuild
  // it triggers is used. In a turning frame, from where the frame has carried each reference.
  const double limit2 = 0.25 * settings_.skin_m * settings_.skin_m;
  const FrameTurn turn(frame_, frame_elapsed_s_);
  const double* scale2 = speed_report(p).scale2;
  const std::size_t block =
      worth_threads(p.size()) ? balanced_block_items(p.size()) : std::max<std::size_t>(1, p.size());
  std::vector<double> block_max2((p.size() + block - 1) / block, 0.0);
  parallel_ranges(p.size(), block, [&](std::size_t begin, std::size_t end, std::size_t b) {
    double max2 = 0.0;
    for (std::size_t i = begin; i < end && max2 <= limit2; ++i)
      max2 = std::max(
          max2, norm2(box.minimum_image(p.position_m[i] - turn.carried(reference_position_m_[i]))) *
                    (scale2 ? scale2[i] : 1.0));
    block_max2[b] = max2;
  });
  double max2 = 0.0;
  for (double m : block_max2) max2 = std::max(max2, m);
  return std::sqrt(max2);
}

void NeighborList::sort_pairs(const ParticleStore& p, const PeriodicBox& box) {
  // Each pair listed from its higher slot and ordered by that slot, stably (the pairs of one slot
  // keep the search's order): the force loop walks particles in memory order, and each second
  // partner lies behind, where that walk has just been (in cache). Then stably by gap band.
  // The work is cut into chunks of the list and buckets of slots (a bucket lies within one speed
  // block), each writing only its own places, on the engine's threads: the same list on any
  // count, and the one a single counting sort makes.
  for (int image = 0; image < 27; ++image) {
    const int n[3] = {image % 3 - 1, (image / 3) % 3 - 1, image / 9 - 1};
    for (int a = 0; a < 3; ++a)
      image_shift_[image][a] = box.periodic[a] ? n[a] * box.length(a) : 0.0;
  }
  const std::size_t count = pairs.size();
  const bool threaded = worth_threads(p.size());
  const std::size_t blocks = (p.size() + kSpeedBlockSlots - 1) / kSpeedBlockSlots;
  // A small population in smaller buckets and chunks, so that every thread has a few of each
  // (a bucket's slots divide a speed block's).
  const std::size_t bucket_slots =
      threaded ? balanced_piece_items(p.size(), block_items(kSpeedBlockSlots), block_items(512))
               : kSpeedBlockSlots;
  const std::size_t buckets = (p.size() + bucket_slots - 1) / bucket_slots;
  const std::size_t chunk_pairs =
      threaded ? balanced_block_items(count) : std::max<std::size_t>(1, count);
  const std::size_t chunks = (count + chunk_pairs - 1) / chunk_pairs;
  auto chunk_end = [&](std::size_t c) { return std::min(count, (c + 1) * chunk_pairs); };

  // 1. Each chunk counts its pairs per bucket of their higher slot; the counts become where each
  //    chunk's pairs of a bucket go (buckets in order, and within one the chunks in order).
  std::vector<std::uint32_t>& at = sort_positions_;  // [chunk][bucket]
  at.assign(chunks * buckets, 0);
  parallel_blocks_if(threaded, chunks, [&](std::size_t c) {
    std::uint32_t* own = at.data() + c * buckets;
    for (std::size_t k = c * chunk_pairs; k < chunk_end(c); ++k) {
      if (pairs.first[k] < pairs.second[k]) std::swap(pairs.first[k], pairs.second[k]);
      ++own[pairs.first[k] / bucket_slots];
    }
  });
  bucket_start_.assign(buckets + 1, 0);
  std::size_t placed = 0;
  for (std::size_t b = 0; b < buckets; ++b) {
    bucket_start_[b] = placed;
    for (std::size_t c = 0; c < chunks; ++c) {
      const std::uint32_t n = at[c * buckets + b];
      at[c * buckets + b] = std::uint32_t(placed);
      placed += n;
    }
  }
  bucket_start_[buckets] = placed;
  PairList& sorted = sorted_pairs_;
  sorted.first.resize(count);
  sorted.second.resize(count);
  parallel_blocks_if(threaded, chunks, [&](std::size_t c) {
    std::uint32_t* own = at.data() + c * buckets;
    for (std::size_t k = c * chunk_pairs; k < chunk_end(c); ++k) {
      const std::uint32_t to = own[pairs.first[k] / bucket_slots]++;
      sorted.first[to] = pairs.first[k];
      sorted.second[to] = pairs.second[k];
    }
  });

  // 2. Within each bucket, a counting sort on the slot, back into `pairs`; then each pair's
  //    periodic image, gap band and overlap, the bucket's count per band, and the speed blocks its
  //    second partners lie in (other than its own), in order of first appearance.
  const double band_width = 0.25 * settings_.skin_m;
  const bool shared = speed_scale2_.size() == p.size();
  image_scratch_.resize(count);
  band_scratch_.resize(count);
  bucket_band_pairs_.assign(buckets * kGapBands, 0);
  if (bucket_partner_blocks_.size() < buckets) bucket_partner_blocks_.resize(buckets);
  parallel_blocks_if(threaded, buckets, [&](std::size_t b) {
    const std::size_t begin = bucket_start_[b], end = bucket_start_[b + 1];
    const std::uint32_t first_slot = std::uint32_t(b * bucket_slots);
    std::uint32_t start[kSpeedBlockSlots + 1];
    std::fill(start, start + bucket_slots + 1, 0u);
    for (std::size_t k = begin; k < end; ++k) ++start[sorted.first[k] - first_slot + 1];
    for (std::size_t i = 0; i < bucket_slots; ++i) start[i + 1] += start[i];
    for (std::size_t k = begin; k < end; ++k) {
      const std::size_t to = begin + start[sorted.first[k] - first_slot]++;
      pairs.first[to] = sorted.first[k];
      pairs.second[to] = sorted.second[k];
    }
    std::size_t* band_pairs = &bucket_band_pairs_[b * kGapBands];
    std::vector<std::uint32_t>& partner_blocks = bucket_partner_blocks_[b];
    partner_blocks.clear();
    const std::uint32_t own_block = first_slot / kSpeedBlockSlots;
    for (std::size_t k = begin; k < end; ++k) {
      const std::uint32_t i = pairs.first[k], j = pairs.second[k];
      const Vec3 d = p.position_m[i] - p.position_m[j];
      int image = 0, stride = 1;
      for (int a = 0; a < 3; ++a, stride *= 3) image += (box.image_of(d[a], a) + 1) * stride;
      image_scratch_[k] = std::uint8_t(image);
      const double dist2 = norm2(d - image_shift_[image]), reach = p.radius_m[i] + p.radius_m[j];
      const double gap = std::sqrt(dist2) - p.radius_m[i] - p.radius_m[j];
      // A pair with a partner of more than the common share of the skin closes faster than the
      // blocks' bounds (in shares) say: it is looked at from the start, in the closest band.
      const bool faster = shared && (speed_scale2_[i] < 1.0 || speed_scale2_[j] < 1.0);
      const int band =
          band_width > 0.0 && !faster ? std::clamp(int(gap / band_width), 0, kGapBands - 1) : 0;
      band_scratch_[k] = std::uint8_t(band | (dist2 < reach * reach ? kOverlappingBit : 0));
      ++band_pairs[band];
      const std::uint32_t block_j = std::uint32_t(j / kSpeedBlockSlots);
      if (block_j != own_block &&
          std::find(partner_blocks.begin(), partner_blocks.end(), block_j) == partner_blocks.end())
        partner_blocks.push_back(block_j);
    }
  });

  // 3. Per speed block, the blocks its candidates' second partners lie in (itself first), and
  //    where each band's run of it begins; then where each bucket's pairs of each band go.
  partner_block_start_.assign(blocks + 1, 0);
  partner_blocks_.clear();
  std::vector<std::uint32_t>& seen = block_seen_;  // seen[b] == a: block b listed for block a
  seen.assign(blocks, ~std::uint32_t(0));
  const std::size_t buckets_per_block = kSpeedBlockSlots / bucket_slots;
  for (std::uint32_t a = 0; a < blocks; ++a) {
    partner_block_start_[a] = std::uint32_t(partner_blocks_.size());
    partner_blocks_.push_back(a);
    seen[a] = a;
    for (std::size_t b = a * buckets_per_block; b < std::min(buckets, (a + 1) * buckets_per_block);
         ++b)
      for (const std::uint32_t partner : bucket_partner_blocks_[b])
        if (seen[partner] != a) seen[partner] = a, partner_blocks_.push_back(partner);
  }
  partner_block_start_[blocks] = std::uint32_t(partner_blocks_.size());
  std::size_t band_start = 0;
  for (int band = 0; band < kGapBands; ++band) {
    band_block_start_[band].assign(blocks + 1, 0);
    std::size_t position = band_start;
    for (std::size_t b = 0; b < buckets; ++b) {
      const std::size_t block = b / buckets_per_block;
      if (b % buckets_per_block == 0) band_block_start_[band][block] = position;
      std::size_t& bucket_pairs = bucket_band_pairs_[b * kGapBands + std::size_t(band)];
      const std::size_t pairs_here = bucket_pairs;
      bucket_pairs = position;  // from here on: where the bucket's next pair of the band goes
      position += pairs_here;
    }
    band_block_start_[band][blocks] = position;
    band_end_[band] = position;
    band_start = position;
  }

  // 4. Each bucket's pairs to their band's run, the overlapping ones noted.
  pair_image.resize(count);
  if (bucket_overlapping_.size() < buckets) bucket_overlapping_.resize(buckets);
  parallel_blocks_if(threaded, buckets, [&](std::size_t b) {
    std::size_t* band_at = &bucket_band_pairs_[b * kGapBands];
    std::vector<std::uint32_t>& overlapping = bucket_overlapping_[b];
    overlapping.clear();
    for (std::size_t k = bucket_start_[b]; k < bucket_start_[b + 1]; ++k) {
      const std::size_t to = band_at[band_scratch_[k] & ~kOverlappingBit]++;
      sorted.first[to] = pairs.first[k];
      sorted.second[to] = pairs.second[k];
      pair_image[to] = image_scratch_[k];
      if (band_scratch_[k] & kOverlappingBit) overlapping.push_back(std::uint32_t(to));
    }
  });
  pairs.first.swap(sorted.first);
  pairs.second.swap(sorted.second);
  overlapping_.clear();
  for (std::size_t b = 0; b < buckets; ++b)
    overlapping_.insert(overlapping_.end(), bucket_overlapping_[b].begin(),
                        bucket_overlapping_[b].end());
  std::sort(overlapping_.begin(), overlapping_.end());
}

void NeighborList::note_motion(const std::vector<double>& block_max_speed_m_per_s,
                               double max_speed_m_per_s, double dt) {
  // The frame's turn carries each displacement round (|Ω| dt of it) and cuts the arc (the chord):
  // both zero in the lab frame.
  const double turn = std::abs(frame_.omega_rad_per_s) * dt;
  const double chord_m = 0.5 * turn * turn * frame_.radius_bound_m;
  frame_elapsed_s_ += dt;
  last_bound_increment_m_ = max_speed_m_per_s * dt + turn * motion_bound_m_ + chord_m;
  motion_bound_m_ += last_bound_increment_m_;
  if (block_max_speed_m_per_s.size() != block_bound_m_.size()) {
    block_bounds_valid_ = false;  // the population changed: the next update() rebuilds
    return;
  }
  for (std::size_t a = 0; a < block_bound_m_.size(); ++a)
    block_bound_m_[a] += block_max_speed_m_per_s[a] * dt + turn * block_bound_m_[a] + chord_m;
}

void NeighborList::widen_active_bands() {
  // Band b's gaps at the rebuild exceed b·skin/4, and two partners close at most the sum of their
  // motion bounds: until then none of its pairs can touch. Bands only ever join (the exact
  // displacement check may lower the bound, but a pair looked at once keeps being looked at, so
  // its contact state stays current). The global bound holds for every block, and is the
  // tighter one after an exact check.
  const double quarter = 0.25 * settings_.skin_m;
  const int before = active_bands_;
  if (!block_bounds_valid_) {
    while (active_bands_ < kGapBands && double(active_bands_) * quarter <= 2.0 * motion_bound_m_)
      ++active_bands_;
    if (active_bands_ != before) list_active_ranges();
    return;
  }
  bool joined = false;
  for (std::size_t a = 0; active_bands_ < kGapBands && a < block_bound_m_.size(); ++a) {
    double partner = 0.0;
    for (std::uint32_t s = partner_block_start_[a]; s < partner_block_start_[a + 1]; ++s)
      partner = std::max(partner, block_bound_m_[partner_blocks_[s]]);
    const double closing =
        std::min(block_bound_m_[a], motion_bound_m_) + std::min(partner, motion_bound_m_);
    for (int b = active_bands_; b < kGapBands && double(b) * quarter <= closing; ++b)
      if (!block_active_[b][a]) block_active_[b][a] = 1, ++blocks_joined_[b], joined = true;
  }
  // A band every block has joined is active whole.
  while (active_bands_ < kGapBands && blocks_joined_[active_bands_] == block_bound_m_.size())
    ++active_bands_;
  if (joined) list_active_ranges();
}

void NeighborList::list_active_ranges() {
  active_ranges_.clear();
  auto add = [this](std::size_t begin, std::size_t end) {
    if (begin == end) return;
    if (!active_ranges_.empty() && active_ranges_.back().end == begin)
      active_ranges_.back().end = end;
    else
      active_ranges_.push_back({begin, end});
  };
  for (int b = 0; b < kGapBands; ++b) {
    if (b < active_bands_) {
      add(b ? band_end_[b - 1] : 0, band_end_[b]);
      continue;
    }
    const std::vector<std::size_t>& start = band_block_start_[b];
    for (std::size_t a = 0; a < block_active_[b].size(); ++a)
      if (block_active_[b][a]) add(start[a], start[a + 1]);
  }
}

void NeighborList::active_runs_of_band(int band, std::vector<PairRange>& runs) const {
  runs.clear();
  const std::size_t lo = band ? band_end_[band - 1] : 0, hi = band_end_[band];
  for (const PairRange& r : active_ranges_) {
    const std::size_t begin = std::max(r.begin, lo), end = std::min(r.end, hi);
    if (begin < end) runs.push_back({begin, end});
  }
}

void NeighborList::count_active_candidates(std::size_t slots, std::size_t unit,
                                           std::vector<std::uint64_t>& per_unit) const {
  static thread_local std::vector<PairRange> runs;
  per_unit.assign((slots + unit - 1) / unit, 0);
  const std::uint32_t* first = pairs.first.data();
  for (int band = 0; band < kGapBands; ++band) {
    active_runs_of_band(band, runs);
    for (const PairRange& r : runs) {
      // Within a band the candidates are sorted by first slot: each unit's are one run, found by
      // binary search from the run's first unit on.
      std::size_t k = r.begin;
      while (k < r.end) {
        const std::size_t u = first[k] / unit;
        const std::uint32_t next_unit_slot = std::uint32_t((u + 1) * unit);
        const std::size_t stop =
            std::size_t(std::lower_bound(first + k, first + r.end, next_unit_slot) - first);
        per_unit[u] += stop - k;
        k = stop;
      }
    }
  }
}

void NeighborList::reset_motion_bounds() {
  motion_bound_m_ = 0.0;
  active_bands_ = 1;
  const std::size_t blocks = partner_block_start_.empty() ? 0 : partner_block_start_.size() - 1;
  block_bound_m_.assign(blocks, 0.0);
  block_bounds_valid_ = true;
  for (int b = 0; b < kGapBands; ++b) block_active_[b].assign(blocks, 0), blocks_joined_[b] = 0;
  list_active_ranges();
}

bool NeighborList::pair_active(std::size_t k) const {
  auto it = std::upper_bound(active_ranges_.begin(), active_ranges_.end(), k,
                             [](std::size_t v, const PairRange& r) { return v < r.end; });
  return it != active_ranges_.end() && it->begin <= k;
}

double NeighborList::steer_skin(const ParticleStore& p, double steps_per_skin) const {
  // Per step, a looked-at candidate costs one evaluation in the force loop and a rebuild costs
  // about kRebuildPerParticle evaluations per particle (bench/RESULTS.md: 300–740 ns per particle
  // against 5–8 ns per candidate). A candidate in gap band b (of 4) is looked at for about
  // 1 − b/4 of a list's life, the motion bound growing about linearly to skin/2. Candidates for
  // s' <= s are counted from this list's gaps, beyond s extrapolated linearly (at the weight of
  // the outer bands); the rebuild interval scales with the skin.
  constexpr double kRebuildPerParticle = 60.0;
  constexpr int kBins = 32;
  const double s = settings_.skin_m;
  if (s <= 0.0 || pairs.size() == 0) return s;
  // A regular sample of at most ~32 000 candidates, each standing for `stride` of them, binned
  // per piece of the sample on the engine's threads (whole counts: exact in any order).
  const std::size_t stride = std::max<std::size_t>(1, pairs.size() / 32768);
  const std::size_t samples = (pairs.size() + stride - 1) / stride, piece = block_items(8192);
  const std::size_t pieces = (samples + piece - 1) / piece;
  std::vector<double> piece_below(pieces * (kBins + 1), 0.0);
  parallel_blocks_if(worth_threads(p.size()), pieces, [&](std::size_t q) {
    double* bins = &piece_below[q * (kBins + 1)];
    for (std::size_t sample = q * piece; sample < std::min(samples, (q + 1) * piece); ++sample) {
      const std::size_t k = sample * stride;
      const std::uint32_t i = pairs.first[k], j = pairs.second[k];
      const double gap =
          norm(p.position_m[i] - p.position_m[j] - pair_shift(k)) - p.radius_m[i] - p.radius_m[j];
      bins[std::clamp(int(std::ceil(gap / s * kBins)), 0, kBins)] += double(stride);
    }
  });
  std::vector<double> below(kBins + 1, 0.0);  // below[b]: candidates with gap < s·b/kBins
  for (std::size_t q = 0; q < pieces; ++q)
    for (int b = 0; b <= kBins; ++b)
      below[std::size_t(b)] += piece_below[q * (kBins + 1) + std::size_t(b)];
  const std::vector<double> in_bin = below;
  for (int b = 0; b < kBins; ++b) below[std::size_t(b + 1)] += below[std::size_t(b)];
  const double slope = (below[kBins] - below[kBins / 2]) / (0.5 * s);
  auto evaluations = [&](double skin) {  // per step, over the list's life
    double sum = 0.0;
    for (int b = 0; b <= kBins; ++b) {
      const double gap = std::max(0.0, (double(b) - 0.5) * s / kBins);
      if (gap >= skin) break;
      const int band = std::min(kGapBands - 1, int(gap / (0.25 * skin)));
      sum += in_bin[std::size_t(b)] * (1.0 - 0.25 * band);
    }
    return sum + std::max(0.0, skin - s) * slope * 0.375;
  };
  auto cost = [&](double skin) {
    return evaluations(skin) +
           kRebuildPerParticle * double(p.size()) / std::max(1.0, steps_per_skin * skin);
  };
  double best = s, best_cost = cost(s);
  for (double f : {0.25, 0.32, 0.4, 0.5, 0.63, 0.79, 1.26, 1.59, 2.0}) {
    const double skin = std::clamp(s * f, skin_floor_m(p), settings_.max_skin_m);
    if (cost(skin) < best_cost) best = skin, best_cost = cost(skin);
  }
  return best;
}

GridDivision NeighborList::division(const ParticleStore& p, const PeriodicBox& box,
                                    bool population_changed) {
  const double skin = settings_.skin_m;
  const bool skin_moved = skin > 1.25 * division_skin_m_ || skin < 0.8 * division_skin_m_;
  if (population_changed || division_skin_m_ < 0.0 || skin_moved) {
    division_ = choose_grid_division(p.radius_m, skin, occupied_volume_m3(p.position_m, box),
                                     settings_.subcells_per_axis, settings_.grid_levels);
    division_skin_m_ = skin;
  }
  return division_;
}

bool NeighborList::update(ParticleStore& p, const PeriodicBox& box, const std::vector<Wall>& walls,
                          bool force) {
  ++steps_since_rebuild_;
  const bool population_changed = p.population_version != population_version_;
  if (!force && !population_changed) {
    widen_active_bands();
    if (motion_bound_m_ <= 0.5 * settings_.skin_m) return false;
    // The cheap bound says maybe: measure, and keep the exact figure as the new bound.
    motion_bound_m_ = max_displacement_m(p, box);
    if (motion_bound_m_ <= 0.5 * settings_.skin_m) return false;
  }
  if (box.any_periodic())
    for (Vec3& x : p.position_m) box.wrap(x);
  // Keep neighbours in space neighbours in memory; history follows by id. Reordered when the
  // population changed or particles may have moved half a mean spacing since the last reorder.
  // Small sets fit in cache anyway and keep their slot order (tests rely on it). Under multi-rate
  // stepping the particles that took the contact step since the last rebuild (and any new ones)
  // come first: the listed passes over them then walk memory in long runs, not one slot in two.
  if (p.size() >= kReorderMinParticles && (population_changed || reorder_due())) {
    spatial_order(p.position_m, box, order_, grid_.scratch(),
                  p.has_multi_rate_state ? p.free_flight.data() : nullptr);
    p.permute(order_, reference_position_m_);  // free until rebuild() sets it again
    reorder_spacing_m_ = std::cbrt(occupied_volume_m3(p.position_m, box) / double(p.size()));
    motion_since_reorder_m_ = 0.0;
  }
  const bool first_build = stats_.rebuilds == 0;
  rebuild(p, box, walls, population_changed);
  // The first list's skin is the size rule's guess; when the steering already knows better (from
  // the speeds), build again at once rather than carry a far too thick list for its lifetime.
  if (first_build && next_skin_m_ && *next_skin_m_ < 0.67 * settings_.skin_m) {
    steps_since_rebuild_ = 0;  // nothing observed yet: the next skin is predicted again
    rebuild(p, box, walls, false);
  }
  motion_since_reorder_m_ += 0.5 * settings_.skin_m;  // what the new list lets anyone move
  reset_motion_bounds();
  steps_since_rebuild_ = 0;
  population_version_ = p.population_version;  // after any permute above
  return true;
}

void NeighborList::rebuild(const ParticleStore& p, const PeriodicBox& box,
                           const std::vector<Wall>& walls, bool population_changed) {
  // Keep the state of pairs that have any (touching ones), keyed by stable ids.
  std::vector<KeyedHistory> old_pairs, old_walls;
  for (std::size_t k = 0; k < pairs.size(); ++k)
    if (pair_touching[k] != kPairApart || norm2(pair_history_m(k)) > 0.0) {
      std::uint64_t a = reference_id_[pairs.first[k]], b = reference_id_[pairs.second[k]];
      old_pairs.push_back({std::min(a, b), std::max(a, b),
                           spring_from_lower_id(pair_history_m(k), pair_touching[k], a > b),
                           pair_touching[k]});
    }
  for (std::size_t k = 0; k < wall_particle.size(); ++k)
    if (wall_touching[k] != kPairApart || norm2(wall_history_m[k]) > 0.0)
      old_walls.push_back(
          {reference_id_[wall_particle[k]], wall_index[k], wall_history_m[k], wall_touching[k]});
  std::sort(old_pairs.begin(), old_pairs.end());
  std::sort(old_walls.begin(), old_walls.end());

  // The skin, cell size and sub-cell division follow the size distribution as it changes
  // (feed, breakage, outlet).
  previous_skin_m_ = settings_.skin_m;
  if (settings_.automatic_skin)
    settings_.skin_m = population_changed || !next_skin_m_
                           ? automatic_skin_m(p.radius_m, settings_.max_skin_m)
                           : *next_skin_m_;
  frame_ = choose_frame(p, box, walls);
  frame_elapsed_s_ = 0.0;
  choose_shares(p);
  const std::vector<double>& search_radius =
      search_radius_m_.empty() ? p.radius_m : search_radius_m_;
  if (settings_.method == SearchMethod::Nbs) {
    nbs_.find_pairs(p.position_m, search_radius, box, settings_.skin_m, pairs);
    stats_.last_search = {};
    stats_.last_search.distance_tests = nbs_.stats().distance_tests;
    stats_.last_search.cells = nbs_.stats().cells;
    stats_.last_search.cell_m = nbs_.stats().cell_m;
    stats_.last_search.level_particles[0] = p.size();
  } else {
    const GridDivision split = division(p, box, population_changed);
    grid_.find_pairs(
        p.position_m, search_radius, box,
        {settings_.skin_m, split.subcells_per_axis, split.levels, settings_.cell_size_m}, pairs);
    stats_.last_search = grid_.stats();
  }
  stats_.distance_tests += stats_.last_search.distance_tests;
  sort_pairs(p, box);
  // A pair absent from the old list was apart at the last force pass (the rebuild rule keeps
  // every touching pair listed), except for newborn particles.
  pair_history.assign(pairs.size(), kNoHistory);
  history_pool.clear();
  pair_touching.assign(pairs.size(), kPairApart);
  if (!old_pairs.empty() || !newborn_.empty())
    for (const std::uint32_t k : overlapping_) {
      // A pair apart now is apart at the next force pass whatever it was (its history is then
      // cleared): only overlapping pairs need their state.
      const std::uint32_t i = pairs.first[k], j = pairs.second[k];
      const double reach = p.radius_m[i] + p.radius_m[j];
      const Vec3 d = p.position_m[i] - p.position_m[j] - image_shift_[pair_image[k]];
      const std::uint64_t a = p.id[i], b = p.id[j];
      if (const KeyedHistory* h = lookup(old_pairs, std::min(a, b), std::max(a, b))) {
        if (norm2(h->history) > 0.0 || h->state == kPairGhost)
          pair_history[k] = history_pool.take(spring_from_lower_id(h->history, h->state, a > b));
        pair_touching[k] = h->state;
        continue;
      }
      if (newborn_.empty()) continue;
      const Newborn* ni = find_newborn(newborn_, a);
      const Newborn* nj = find_newborn(newborn_, b);
      if (!ni && !nj) continue;
      const double dist = norm(d);
      const bool siblings = ni && nj && ni->family != 0 && ni->family == nj->family;
      const bool deep =
          reach - dist > newborn_ghost_ratio_ * 2.0 * std::min(p.radius_m[i], p.radius_m[j]);
      if (siblings || deep || parents_were_ghosts(old_pairs, a, ni, b, nj)) {
        pair_touching[k] = kPairGhost;
        pair_history[k] = history_pool.take({reach - dist, 0.0, 0.0});  // the overlap memory
      } else {
        pair_touching[k] = kPairTouching;
      }
    }

  // Wall candidates by slot, then wall: blocks of slots on the engine's threads, joined in
  // block order (the list one thread makes).
  const std::size_t wall_block_slots = block_items(4096);
  const std::size_t wall_blocks = (p.size() + wall_block_slots - 1) / wall_block_slots;
  if (wall_block_scratch_.size() < wall_blocks) wall_block_scratch_.resize(wall_blocks);
  parallel_ranges(
      p.size(), wall_block_slots, [&](std::size_t begin, std::size_t end, std::size_t b) {
        std::vector<std::uint32_t>& found = wall_block_scratch_[b];  // slot, wall, slot, wall, ...
        found.clear();
        if (walls.empty()) return;
        for (std::size_t i = begin; i < end; ++i)
          for (std::size_t w = 0; w < walls.size(); ++w)
            if (wall_gap_m(walls[w], p.position_m[i]) < search_radius[i] + settings_.skin_m)
              found.push_back(std::uint32_t(i)), found.push_back(std::uint32_t(w));
      });
  wall_particle.clear(), wall_index.clear();
  for (std::size_t b = 0; b < wall_blocks; ++b)
    for (std::size_t e = 0; e < wall_block_scratch_[b].size(); e += 2)
      wall_particle.push_back(wall_block_scratch_[b][e]),
          wall_index.push_back(wall_block_scratch_[b][e + 1]);
  wall_history_m.assign(wall_particle.size(), Vec3{});
  wall_touching.assign(wall_particle.size(), kPairApart);
  forget_wall_springs();
  if (!old_walls.empty() || !newborn_.empty())
    for (std::size_t k = 0; k < wall_particle.size(); ++k) {
      const std::uint32_t i = wall_particle[k];
      if (const KeyedHistory* h = lookup(old_walls, p.id[i], wall_index[k])) {
        wall_history_m[k] = h->history;
        wall_touching[k] = h->state;
      } else if (find_newborn(newborn_, p.id[i])) {
        const double overlap = p.radius_m[i] - wall_gap_m(walls[wall_index[k]], p.position_m[i]);
        if (overlap > newborn_ghost_ratio_ * 2.0 * p.radius_m[i]) {
          wall_touching[k] = kPairGhost;  // born deep in the wall: overlap memory
          wall_history_m[k] = {overlap, 0.0, 0.0};
        } else if (overlap > 0.0) {
          wall_touching[k] = kPairTouching;
        }
      }
    }
  newborn_.clear();

  next_skin_m_.reset();
  if (settings_.automatic_skin && !population_changed && steps_since_rebuild_ > 0) {
    next_skin_m_ = steer_skin(p, double(steps_since_rebuild_) / std::max(previous_skin_m_, 1e-300));
  } else if (settings_.automatic_skin && settings_.step_s > 0.0) {
    // No interval observed for this population: predict it, skin/2 at the largest speed.
    double max_speed2 = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i)
      max_speed2 =
          std::max(max_speed2, frame_speed2(frame_, p.position_m[i], p.motion[i].velocity_m_per_s));
    if (max_speed2 > 0.0)
      next_skin_m_ = steer_skin(p, 1.0 / (2.0 * std::sqrt(max_speed2) * settings_.step_s));
  }
  // The positions and ids of this build, copied in blocks on the engine's threads.
  reference_position_m_.resize(p.size());
  reference_id_.resize(p.size());
  parallel_ranges(p.size(), balanced_block_items(p.size()),
                  [&](std::size_t begin, std::size_t end, std::size_t) {
                    std::copy(p.position_m.begin() + std::ptrdiff_t(begin),
                              p.position_m.begin() + std::ptrdiff_t(end),
                              reference_position_m_.begin() + std::ptrdiff_t(begin));
                    std::copy(p.id.begin() + std::ptrdiff_t(begin),
                              p.id.begin() + std::ptrdiff_t(end),
                              reference_id_.begin() + std::ptrdiff_t(begin));
                  });
  ++stats_.rebuilds;
}

void NeighborList::forget_wall_springs() {
  wall_springs_memo.assign(wall_particle.size(),
                           {std::numeric_limits<double>::quiet_NaN(), PairSprings{}});
}

}  // namespace millsim
