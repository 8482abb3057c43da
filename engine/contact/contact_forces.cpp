#include "contact/contact_forces.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <memory>

#include "contact/contact_law.h"
#include "contact/curved_contact.h"
#include "geometry/surface.h"
#include "parallel/thread_team.h"

namespace millsim {
namespace {

// The overlap that pushes back in a contact born overlapping (kPairGhost): it remembers its
// birth overlap (`memory`, which follows the overlap down as the partners separate), and only the
// overlap beyond it counts (neighbor_list.h). ≤ 0 when nothing pushes.
inline double ghost_overlap_m(double overlap, double& memory) {
  memory = std::min(memory, overlap);
  return overlap - memory;
}

// Whether ghost candidate k pushes now: it still overlaps, deeper than its memory. When it
// overlaps no deeper, its memory follows the overlap down, with the arithmetic of visit_contact
// (the same bits), and the contact law has nothing to do. A pair that no longer overlaps counts
// as pushing: its end is visit_contact's.
template <bool kPeriodic>
inline bool ghost_pushes(const ParticleStore& p, NeighborList& nl, std::size_t k) {
  const std::uint32_t i = nl.pairs.first[k], j = nl.pairs.second[k];
  Vec3 d = p.position_m[i] - p.position_m[j];
  if constexpr (kPeriodic) d -= nl.pair_shift(k);
  const double dist2 = norm2(d), rsum = p.radius_m[i] + p.radius_m[j];
  if (dist2 >= rsum * rsum) return true;
  return ghost_overlap_m(rsum - std::sqrt(dist2), nl.history_pool[nl.pair_history[k]][0]) > 0.0;
}

// The wall's springs at the particle's contact point: R_e from the surface's curvature there.
inline PairSprings wall_springs_at(const ParticleStore& p, std::size_t i, const PairConstants& pc,
                                   double curvature_per_m) {
  return wall_springs(p, i, pc, equivalent_contact_radius_m(p.radius_m[i], curvature_per_m));
}
inline PairSprings wall_springs_at(const ParticleStore& p, std::size_t i, const Wall& wall,
                                   const PairConstants& pc) {
  return wall_springs_at(p, i, pc, surface_curvature_per_m(wall.surface, p.position_m[i]));
}

// Wall candidate k's springs, made once per curvature under it (NeighborList::wall_springs_memo):
// the same numbers as wall_springs_at, without its divisions and roots at every touching step.
inline const PairSprings& remembered_wall_springs(const ParticleStore& p, std::size_t i,
                                                  const Wall& wall, const PairConstants& pc,
                                                  NeighborList::WallSpringsMemo& memo) {
  // Only a tube's curvature depends on where the particle is (inside, outside, past a rim).
  const bool made = memo.curvature_per_m == memo.curvature_per_m;  // not NaN
  if (made && wall.surface.kind != SurfaceKind::Tube) return memo.springs;
  const double curvature = surface_curvature_per_m(wall.surface, p.position_m[i]);
  if (!made || curvature != memo.curvature_per_m)
    memo = {curvature, wall_springs_at(p, i, pc, curvature)};
  return memo.springs;
}

// The pair loop's memory pipeline, apart from the physics: a lean pass over a chunk of
// candidates keeps those that touch or touched at the last pass (a few percent). Second partners
// lie behind in memory, mostly still in cache; the few far ones are fetched some candidates
// ahead. Then the kept contacts born overlapping that do not push (they still overlap no deeper
// than their memory: most of a fragment cloud's pairs, two in three kept candidates in the
// shipped mill) have their memory lowered here, as visit_contact would, and are dropped. Then
// everything the rest read is fetched, and only they are visited. Visits candidates [begin, end)
// of one active range.
template <class Law, bool kPeriodic, class Visit>
void for_each_contact_candidate(const Law& law, const ParticleStore& p, NeighborList& nl,
                                std::size_t begin, std::size_t end, Visit&& visit) {
  const std::uint32_t* first = nl.pairs.first.data();
  const std::uint32_t* second = nl.pairs.second.data();
  const std::uint32_t* history = nl.pair_history.data();
  const std::uint8_t* touching_flag = nl.pair_touching.data();
  const Vec3* x = p.position_m.data();
  const double* r = p.radius_m.data();
  constexpr std::size_t kChunk = 256, kPrefetchAhead = 64;
  std::uint32_t kept[kChunk];
  for (std::size_t chunk = begin; chunk < end; chunk += kChunk) {
    const std::size_t chunk_end = std::min(end, chunk + kChunk);
    std::size_t n = 0;
    for (std::size_t k = chunk; k < chunk_end; ++k) {
      if (k + kPrefetchAhead < end) {
        __builtin_prefetch(&x[second[k + kPrefetchAhead]]);
        __builtin_prefetch(&r[second[k + kPrefetchAhead]]);
      }
      const std::uint32_t i = first[k], j = second[k];
      Vec3 d = x[i] - x[j];
      if constexpr (kPeriodic) d -= nl.pair_shift(k);
      const double rsum = r[i] + r[j];
      kept[n] = std::uint32_t(k - chunk);
      n += (norm2(d) < rsum * rsum) | (touching_flag[k] != kPairApart);
    }
    std::size_t pushing = 0;
    for (std::size_t h = 0; h < n; ++h) {
      const std::size_t k = chunk + kept[h];
      if (touching_flag[k] == kPairGhost && !ghost_pushes<kPeriodic>(p, nl, k)) continue;
      kept[pushing++] = kept[h];
    }
    n = pushing;
    for (std::size_t h = 0; h < n; ++h) {
      const std::size_t k = chunk + kept[h];
      for (const std::uint32_t a : {first[k], second[k]}) {
        // A 48-byte record may span two cache lines: fetch its first and last byte.
        const char* m = reinterpret_cast<const char*>(&p.motion[a]);
        const char* l = reinterpret_cast<const char*>(&p.load[a]);
        law.prefetch(a);
        __builtin_prefetch(m), __builtin_prefetch(m + sizeof(Motion) - 1);
        __builtin_prefetch(l), __builtin_prefetch(l + sizeof(Load) - 1);
        __builtin_prefetch(&p.material[a]);
      }
      if (history[k] != kNoHistory) __builtin_prefetch(&nl.history_pool[history[k]]);
    }
    for (std::size_t h = 0; h < n; ++h) visit(chunk + kept[h]);
  }
}

// The pair loop's arrays, taken out of their containers once per pass (read through plain
// pointers, the loop keeps them in registers).
struct PairArrays {
  const std::uint32_t* first;
  const std::uint32_t* second;
  std::uint32_t* history;
  std::uint8_t* touching;
  const Vec3* x;
  const Motion* motion;
  const double* r;
  const std::uint16_t* mat;
  const double* inv_mass;
  HistoryPool* pool;
  const NeighborList* nl;  // its periodic images
};

PairArrays pair_arrays(ParticleStore& p, NeighborList& nl) {
  return {nl.pairs.first.data(),
          nl.pairs.second.data(),
          nl.pair_history.data(),
          nl.pair_touching.data(),
          p.position_m.data(),
          p.motion.data(),
          p.radius_m.data(),
          p.material.data(),
          p.inv_mass_per_kg.data(),
          &nl.history_pool,
          &nl};
}

// A pass's statistics over a run of candidates: counts, the largest overlap ratio (its first
// candidate) and the lists of impacts and of contacts past the limit, in candidate order.
struct alignas(64) PairTally {  // (one cache line of its own: a thread's block counts into it)
  std::uint64_t touching = 0;
  double max_ratio = 0.0;
  std::size_t max_pair = 0;
  std::vector<Impact> impacts;
  std::vector<std::uint32_t> over_limit;
};

// What a contact does beyond its own candidate's state (the loads of both partners and the
// shared pool of tangential histories), as an `Apply`:
//  - DirectApply (one thread) does it at once, in candidate order.
//  - OwnerApply (the candidates listed at one owner's slots, on that owner's thread:
//    parallel/slot_shares.h) adds at once to the owner's own particles and records what goes to
//    a particle of a lower share and what the history pool must do; the records are applied in
//    candidate order (pair_loop_owned), so every load receives the same additions in the same
//    order as from DirectApply: the same bits on any thread count.
struct DirectApply {
  Load* load;
  HistoryPool& pool;
  std::uint32_t* history;

  // i gets +force and −torque_i, j gets −force and −torque_j.
  void contact(std::uint32_t i, std::uint32_t j, const Vec3& force, const Vec3& torque_i,
               const Vec3& torque_j) {
    Load &li = load[i], &lj = load[j];
    li.force_n += force;
    lj.force_n -= force;
    li.torque_n_m -= torque_i;
    lj.torque_n_m -= torque_j;
  }
  void separation(std::uint32_t i, std::uint32_t j, const Vec3& force) {
    load[i].force_n -= force;
    load[j].force_n += force;
  }
  // The tangential history of a contact that starts now (zero), to be updated by the law.
  Vec3* new_history(std::size_t k) {
    history[k] = pool.take({});
    return &pool[history[k]];
  }
  void forget_history(std::size_t k) {
    pool.give_back(history[k]);
    history[k] = kNoHistory;
  }
};

// What a contact adds to a particle of a lower share: force_n += force, and when with_torque,
// torque_n_m −= torque (a − b and a + (−b) are the same bits).
struct CrossLoad {
  std::uint32_t particle;
  bool with_torque;
  Vec3 force, torque;
};

struct HistoryEvent {
  std::uint32_t k;
  bool take;   // take a slot holding `value`; else give pair k's slot back
  Vec3 value;  // the history after this pass's law
};

struct alignas(64) OwnerSink {  // (cache lines of its own: one thread records into it)
  PairTally tally;
  std::vector<CrossLoad> cross;
  std::vector<HistoryEvent> history_events;
};

struct OwnerApply {
  Load* load;
  std::uint32_t own_begin;  // the owner's first slot; a first partner is never below it
  OwnerSink& sink;

  void contact(std::uint32_t i, std::uint32_t j, const Vec3& force, const Vec3& torque_i,
               const Vec3& torque_j) {
    Load& li = load[i];
    li.force_n += force;
    li.torque_n_m -= torque_i;
    if (j < own_begin) {
      sink.cross.push_back({j, true, -force, torque_j});
      return;
    }
    Load& lj = load[j];
    lj.force_n -= force;
    lj.torque_n_m -= torque_j;
  }
  void separation(std::uint32_t i, std::uint32_t j, const Vec3& force) {
    load[i].force_n -= force;
    if (j < own_begin)
      sink.cross.push_back({j, false, force, {}});
    else
      load[j].force_n += force;
  }
  Vec3* new_history(std::size_t k) {
    sink.history_events.push_back({std::uint32_t(k), true, {}});
    return &sink.history_events.back().value;  // written by the law before the next record
  }
  void forget_history(std::size_t k) {
    sink.history_events.push_back({std::uint32_t(k), false, {}});
  }
};

// The contact law on candidate k, which touches now or touched at the last pass. What it does
// beyond candidate k's own state goes through `apply`; its statistics into the counters and
// lists (the caller's locals: kept in registers).
template <class Law, bool kPeriodic, class Apply>
inline void visit_contact(const Law& law, const MaterialTable& materials, double dt, double limit,
                          const PairArrays& a, bool record_impacts, std::size_t k, Apply& apply,
                          std::uint64_t& touching, double& max_ratio, std::size_t& max_pair,
                          std::vector<Impact>& impacts, std::vector<std::uint32_t>& over_limit) {
  const std::uint32_t i = a.first[k], j = a.second[k];
  const double* r = a.r;
  Vec3 d = a.x[i] - a.x[j];
  if constexpr (kPeriodic) d -= a.nl->pair_shift(k);
  const double dist2 = norm2(d), rsum = r[i] + r[j];
  const std::uint32_t history = a.history[k];
  if (dist2 >= rsum * rsum) {
    if (a.touching[k]) {  // the contact ended: it forgets its history
      if (a.touching[k] == kPairTouching) {
        // A contact of restitution below 0.05 ends keeping only that share of its normal
        // separation speed (particles/restitution.h): equal and opposite impulses along n, as a
        // force over the step; a frozen partner (no inverse mass) takes none of it.
        const double scale = materials.pair(a.mat[i], a.mat[j]).separation_scale;
        const double inv_sum = a.inv_mass[i] + a.inv_mass[j];
        if (scale < 1.0 && inv_sum > 0.0) {
          const Vec3 n = d * (1.0 / std::sqrt(dist2));
          const double vn = dot(a.motion[i].velocity_m_per_s - a.motion[j].velocity_m_per_s, n);
          if (vn > 0.0) apply.separation(i, j, n * separation_force_n(scale, vn, inv_sum, dt));
        }
      }
      a.touching[k] = kPairApart;
      if (history != kNoHistory) apply.forget_history(k);
    }
    return;
  }
  const std::uint8_t before = a.touching[k];
  const bool ghost = before == kPairGhost;
  const double dist = std::sqrt(dist2);
  Vec3* spring = nullptr;  // the tangential history; none for a ghost
  if (!ghost) {
    a.touching[k] = kPairTouching;
    spring = history == kNoHistory ? apply.new_history(k) : &(*a.pool)[history];
  }
  double overlap = rsum - dist;
  if (ghost) overlap = ghost_overlap_m(overlap, (*a.pool)[history][0]);
  if (overlap <= 0.0) return;
  ++touching;
  const Vec3 n = d * (1.0 / dist);
  const PairConstants& pc = materials.pair(a.mat[i], a.mat[j]);
  // Velocity of the contact point of i relative to j; contact point at −r_i n from i, +r_j n
  // from j.
  const Motion &mi = a.motion[i], &mj = a.motion[j];
  const Vec3 v_rel =
      mi.velocity_m_per_s - mj.velocity_m_per_s -
      cross(mi.angular_velocity_rad_per_s * r[i] + mj.angular_velocity_rad_per_s * r[j], n);
  if (before == kPairApart && record_impacts) {
    const double vn = dot(v_rel, n);
    if (vn < 0.0) impacts.push_back({i, j, false, -vn, norm(v_rel - n * vn)});
  }
  const ContactResponse c =
      contact_response(law(i, j, pc), pc, overlap, n, v_rel,
                       mi.angular_velocity_rad_per_s - mj.angular_velocity_rad_per_s,
                       r[i] * r[j] / rsum, dt, spring);
  const Vec3 n_cross_ft = cross(n, c.tangential_force_n);
  apply.contact(i, j, n * c.normal_force_n + c.tangential_force_n,
                n_cross_ft * (r[i] - 0.5 * overlap) + c.rolling_torque_n_m,
                n_cross_ft * (r[j] - 0.5 * overlap) - c.rolling_torque_n_m);
  const double ratio = overlap / (2.0 * std::min(r[i], r[j]));
  if (ratio > limit) over_limit.push_back(std::uint32_t(k));
  if (ratio > max_ratio) max_ratio = ratio, max_pair = k;
}

// A later run of candidates' tally after `total`'s: counts added, lists appended, the largest
// ratio kept at its first candidate.
void add_tally(PairTally& total, const PairTally& t) {
  total.touching += t.touching;
  if (t.max_ratio > total.max_ratio) total.max_ratio = t.max_ratio, total.max_pair = t.max_pair;
  total.impacts.insert(total.impacts.end(), t.impacts.begin(), t.impacts.end());
  total.over_limit.insert(total.over_limit.end(), t.over_limit.begin(), t.over_limit.end());
}

// The step's statistics from the tallies, in candidate order.
void finish_pair_stats(const PairTally& t, const ParticleStore& p, const NeighborList& nl,
                       ContactStepStats& stats) {
  stats.touching_pairs = t.touching;
  if (t.max_ratio > stats.max_overlap_ratio) {
    stats.max_overlap_ratio = t.max_ratio;
    const std::uint32_t i = nl.pairs.first[t.max_pair], j = nl.pairs.second[t.max_pair];
    const bool i_smaller = p.radius_m[i] <= p.radius_m[j];
    stats.max_overlap_particle = p.id[i_smaller ? i : j];
    stats.max_overlap_partner = p.id[i_smaller ? j : i];
    stats.max_overlap_wall = -1;
  }
}

// One thread's history records into the pool, in candidate order: its takes and give-backs
// exactly as DirectApply makes them.
void apply_history_events(const OwnerSink& sink, NeighborList& nl) {
  for (const HistoryEvent& e : sink.history_events) {
    if (e.take) {
      nl.pair_history[e.k] = nl.history_pool.take(e.value);
    } else {
      nl.history_pool.give_back(nl.pair_history[e.k]);
      nl.pair_history[e.k] = kNoHistory;
    }
  }
}

// What owner `from` recorded for thread t's particles (in candidate order).
void apply_cross_loads(const OwnerSink& from, const SlotShares& shares, std::size_t t, Load* load) {
  const std::uint32_t lo = std::uint32_t(shares.bound[t]), hi = std::uint32_t(shares.bound[t + 1]);
  for (const CrossLoad& c : from.cross) {
    if (c.particle < lo || c.particle >= hi) continue;
    load[c.particle].force_n += c.force;
    if (c.with_torque) load[c.particle].torque_n_m -= c.torque;
  }
}

// How many of the pass's active bands an owner has run (its records then complete).
struct alignas(64) OwnerProgress {
  std::atomic<std::uint32_t> bands_done{0};
};

// Scratch of the threaded pair loop, kept between steps: per gap band, each owner's records and
// the band's active runs; each owner's progress and seconds of work.
struct OwnerLoopScratch {
  std::vector<OwnerSink> sinks[NeighborList::kGapBands];
  std::vector<NeighborList::PairRange> runs[NeighborList::kGapBands];
  std::unique_ptr<OwnerProgress[]> progress;
  std::size_t progress_size = 0;
  std::vector<std::uint64_t> unit_candidates;
  std::vector<double> work_s;
};

// One thread: each contact applied at once, in candidate order. Its own function (as is the
// threaded one), so that each gets g++'s whole inlining budget: in one function together the
// contact law went out of line and the mill's pair loop took 17 % longer.
template <class Law, bool kPeriodic>
[[gnu::noinline]] void pair_loop_direct(const Law& law, const MaterialTable& materials, double dt,
                                        double limit, ParticleStore& p, NeighborList& nl,
                                        bool impacts, PairTally& total) {
  const PairArrays a = pair_arrays(p, nl);
  DirectApply apply{p.load.data(), nl.history_pool, nl.pair_history.data()};
  std::uint64_t touching = 0;
  double max_ratio = 0.0;
  std::size_t max_pair = 0;
  for (const NeighborList::PairRange& range : nl.active_ranges())
    for_each_contact_candidate<Law, kPeriodic>(
        law, p, nl, range.begin, range.end, [&](std::size_t k) {
          visit_contact<Law, kPeriodic>(law, materials, dt, limit, a, impacts, k, apply, touching,
                                        max_ratio, max_pair, total.impacts, total.over_limit);
        });
  total.touching = touching, total.max_ratio = max_ratio, total.max_pair = max_pair;
}

// Several threads, each on the candidates listed at its own slots (nl.owner_shares), band by
// band, in one team call. A particle's additions come, in candidate order, from its own owner's
// candidates of a band (added at once), then from the higher owners' (their records): so after
// each band, an owner waits until each higher owner has run that band and adds its records for
// the owner's particles, in owner order, before its next band. DirectApply's order, so its bits.
// The highest owner never waits, and no owner waits for a lower one. The pool's takes and
// give-backs and the statistics are applied after, band by band in owner order, which is
// candidate order. The shares follow the work: each owner's seconds of work (its waits left
// out) teach the balancer what its candidates cost (parallel/slot_shares.h).
template <class Law, bool kPeriodic>
[[gnu::noinline]] void pair_loop_owned(const Law& law, const MaterialTable& materials, double dt,
                                       double limit, ParticleStore& p, NeighborList& nl,
                                       bool impacts, PairTally& total) {
  const PairArrays a = pair_arrays(p, nl);
  const std::size_t threads = std::size_t(thread_count());
  // (Named here, on the calling thread: inside the loop a thread_local would be the worker's.)
  static thread_local OwnerLoopScratch calling_thread_scratch;
  OwnerLoopScratch& scratch = calling_thread_scratch;
  const std::size_t unit = block_items(kOwnerUnitSlots);
  nl.count_active_candidates(p.size(), unit, scratch.unit_candidates);
  nl.owner_balance.split(scratch.unit_candidates, p.size(), unit, threads, nl.owner_shares);
  const SlotShares& shares = nl.owner_shares;
  int bands[NeighborList::kGapBands];
  std::uint32_t band_count = 0;
  for (int band = 0; band < NeighborList::kGapBands; ++band) {
    nl.active_runs_of_band(band, scratch.runs[band]);
    if (scratch.runs[band].empty()) continue;
    bands[band_count++] = band;
    if (scratch.sinks[band].size() != threads) scratch.sinks[band].resize(threads);
  }
  if (scratch.progress_size != threads) {
    scratch.progress = std::make_unique<OwnerProgress[]>(threads);
    scratch.progress_size = threads;
  }
  for (std::size_t t = 0; t < threads; ++t)
    scratch.progress[t].bands_done.store(0, std::memory_order_relaxed);
  scratch.work_s.assign(threads, 0.0);
  const std::uint32_t* first = nl.pairs.first.data();
  Load* load = p.load.data();
  parallel_on_each_thread([&](std::size_t t) {
    OwnerProgress& mine = scratch.progress[t];
    const std::uint32_t lo = std::uint32_t(shares.bound[t]);
    const std::uint32_t hi = std::uint32_t(shares.bound[t + 1]);
    const auto start = std::chrono::steady_clock::now();
    std::chrono::steady_clock::duration waited{};
    try {
      for (std::uint32_t i = 0; i < band_count; ++i) {
        const int band = bands[i];
        OwnerSink& sink = scratch.sinks[band][t];
        sink.cross.clear(), sink.history_events.clear();
        sink.tally.impacts.clear(), sink.tally.over_limit.clear();
        OwnerApply apply{load, lo, sink};
        std::uint64_t touching = 0;
        double max_ratio = 0.0;
        std::size_t max_pair = 0;
        for (const NeighborList::PairRange& run : scratch.runs[band]) {
          // The run's candidates listed at slots [lo, hi): sorted by first slot within the band.
          const std::size_t begin =
              std::size_t(std::lower_bound(first + run.begin, first + run.end, lo) - first);
          const std::size_t end =
              std::size_t(std::lower_bound(first + begin, first + run.end, hi) - first);
          for_each_contact_candidate<Law, kPeriodic>(law, p, nl, begin, end, [&](std::size_t k) {
            visit_contact<Law, kPeriodic>(law, materials, dt, limit, a, impacts, k, apply, touching,
                                          max_ratio, max_pair, sink.tally.impacts,
                                          sink.tally.over_limit);
          });
        }
        sink.tally.touching = touching, sink.tally.max_ratio = max_ratio;
        sink.tally.max_pair = max_pair;
        mine.bands_done.store(i + 1, std::memory_order_release);
        for (std::size_t from = t + 1; from < threads; ++from) {
          const auto wait_start = std::chrono::steady_clock::now();
          wait_until_at_least(scratch.progress[from].bands_done, i + 1);
          waited += std::chrono::steady_clock::now() - wait_start;
          apply_cross_loads(scratch.sinks[band][from], shares, t, load);
        }
      }
    } catch (...) {
      mine.bands_done.store(band_count, std::memory_order_release);  // no owner waits on it
      throw;
    }
    scratch.work_s[t] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start - waited).count();
  });
  nl.owner_balance.learn(shares, scratch.unit_candidates, scratch.work_s);

  for (std::uint32_t i = 0; i < band_count; ++i)
    for (const OwnerSink& sink : scratch.sinks[bands[i]]) {
      apply_history_events(sink, nl);
      add_tally(total, sink.tally);
    }
}

template <class Law, bool kPeriodic>
void pair_loop(const Law& law, const MaterialTable& materials, double dt, double limit,
               ParticleStore& p, NeighborList& nl, ContactStepStats& stats) {
  PairTally total;
  total.impacts = std::move(stats.impacts);
  total.over_limit = std::move(stats.pairs_over_limit);
  // By particles, not candidates: what the threads add to, the next kick-drift reads (a loop
  // on two cores below the minimum moves the loads from cache to cache). A single-rate run's
  // kick-drift runs on the owner shares this pass makes, which keeps each thread's particles in
  // its core's caches: its caller lowers the minimum (MinItemsForThreadsScope).
  if (!worth_threads(p.size())) {
    nl.owner_shares.clear();
    pair_loop_direct<Law, kPeriodic>(law, materials, dt, limit, p, nl, stats.record_impacts, total);
  } else {
    pair_loop_owned<Law, kPeriodic>(law, materials, dt, limit, p, nl, stats.record_impacts, total);
  }
  stats.impacts = std::move(total.impacts);
  stats.pairs_over_limit = std::move(total.over_limit);
  finish_pair_stats(total, p, nl, stats);
}

template <class Law>
void pair_loop_any_box(const Law& law, const MaterialTable& materials, const PeriodicBox& box,
                       double dt, double limit, ParticleStore& p, NeighborList& nl,
                       ContactStepStats& stats) {
  if (box.any_periodic())
    pair_loop<Law, true>(law, materials, dt, limit, p, nl, stats);
  else
    pair_loop<Law, false>(law, materials, dt, limit, p, nl, stats);
}

}  // namespace

void compute_pair_forces(ContactModel model, const MaterialTable& materials, const PeriodicBox& box,
                         double dt, double limit, ParticleStore& p, NeighborList& nl,
                         ContactStepStats& stats) {
  switch (model) {
    case ContactModel::SeriesSprings:
      return pair_loop_any_box(SeriesSprings(p), materials, box, dt, limit, p, nl, stats);
    case ContactModel::PaperSprings:
      return pair_loop_any_box(PaperSprings(p), materials, box, dt, limit, p, nl, stats);
    case ContactModel::EquivalentProperties:
      return pair_loop_any_box(EquivalentProperties(p), materials, box, dt, limit, p, nl, stats);
  }
}

namespace {

// The wall contacts of candidates [begin, end): the contact law on each, its force and torque
// added to its particle, its statistics into `tally`.
void wall_contacts(const MaterialTable& materials, const std::vector<Wall>& walls, double dt,
                   double limit, bool record_impacts, ParticleStore& p, NeighborList& nl,
                   std::size_t begin, std::size_t end, PairTally& tally) {
  std::uint64_t touching = 0;
  double max_ratio = 0.0;
  std::size_t max_pair = 0;
  for (std::size_t k = begin; k < end; ++k) {
    const std::uint32_t i = nl.wall_particle[k];
    const Wall& wall = walls[nl.wall_index[k]];
    const double r = p.radius_m[i];
    // Apart and staying apart (the branch below would change nothing): skip the exact gap.
    if (nl.wall_touching[k] == kPairApart &&
        surface_certainly_beyond(wall.surface, p.position_m[i], r))
      continue;
    Vec3 n;
    double overlap = r - wall_gap_m(wall, p.position_m[i], n);
    const PairConstants& pc = materials.wall_pair(wall.pair_table, p.material[i]);
    if (overlap <= 0.0) {
      // Restitution below 0.05: the particle leaves with that share of its normal speed.
      const double vn = dot(p.motion[i].velocity_m_per_s, n);
      if (nl.wall_touching[k] == kPairTouching && pc.separation_scale < 1.0 && vn > 0.0 &&
          p.inv_mass_per_kg[i] > 0.0)
        p.load[i].force_n -=
            n * separation_force_n(pc.separation_scale, vn, p.inv_mass_per_kg[i], dt);
      nl.wall_history_m[k] = {};
      nl.wall_touching[k] = kPairApart;
      continue;
    }
    const bool onset = nl.wall_touching[k] == kPairApart;
    const bool ghost = nl.wall_touching[k] == kPairGhost;
    if (ghost) {  // born deep in the wall: overlap memory, as for particle pairs
      overlap = ghost_overlap_m(overlap, nl.wall_history_m[k][0]);
      if (overlap <= 0.0) continue;
    } else {
      nl.wall_touching[k] = kPairTouching;
    }
    ++touching;
    const Motion& m = p.motion[i];
    const Vec3 v_rel = m.velocity_m_per_s - cross(m.angular_velocity_rad_per_s * r, n);
    if (onset && record_impacts) {
      const double vn = dot(v_rel, n);
      if (vn < 0.0) tally.impacts.push_back({i, nl.wall_index[k], true, -vn, norm(v_rel - n * vn)});
    }
    const ContactResponse c = contact_response(
        remembered_wall_springs(p, i, wall, pc, nl.wall_springs_memo[k]), pc, overlap, n, v_rel,
        m.angular_velocity_rad_per_s, r, dt, ghost ? nullptr : &nl.wall_history_m[k]);
    p.load[i].force_n += n * c.normal_force_n + c.tangential_force_n;
    p.load[i].torque_n_m -=
        cross(n, c.tangential_force_n) * (r - 0.5 * overlap) + c.rolling_torque_n_m;
    const double ratio = overlap / (2.0 * r);
    if (ratio > limit) tally.over_limit.push_back(std::uint32_t(k));
    if (ratio > max_ratio) max_ratio = ratio, max_pair = k;
  }
  tally.touching += touching;
  if (max_ratio > tally.max_ratio) tally.max_ratio = max_ratio, tally.max_pair = max_pair;
}

// The wall pass's statistics from its pieces' tallies, in candidate order, as one thread
// gathers them.
void finish_wall_stats(const std::vector<PairTally>& tallies, std::size_t pieces,
                       const ParticleStore& p, const NeighborList& nl, ContactStepStats& stats) {
  PairTally total;
  total.impacts = std::move(stats.impacts);
  total.over_limit = std::move(stats.walls_over_limit);
  for (std::size_t q = 0; q < pieces; ++q) add_tally(total, tallies[q]);
  stats.impacts = std::move(total.impacts);
  stats.walls_over_limit = std::move(total.over_limit);
  stats.touching_walls = total.touching;
  if (total.max_ratio > stats.max_overlap_ratio) {
    const std::uint32_t i = nl.wall_particle[total.max_pair];
    stats.max_overlap_ratio = total.max_ratio;
    stats.max_overlap_particle = p.id[i];
    stats.max_overlap_partner = 0;
    stats.max_overlap_wall = int(nl.wall_index[total.max_pair]);
  }
}

// Wall candidates per piece, about: a piece ends where a particle's run of candidates ends, so
// that one thread adds all of a particle's wall forces, in candidate order.
constexpr std::size_t kWallPieceCandidates = 2048;

}  // namespace

void compute_wall_forces(const MaterialTable& materials, const std::vector<Wall>& walls, double dt,
                         double limit, ParticleStore& p, NeighborList& nl, ContactStepStats& stats,
                         const std::vector<NeighborList::PairRange>* ranges) {
  const std::size_t n = nl.wall_particle.size();
  if (nl.wall_springs_memo.size() != n) nl.forget_wall_springs();
  const bool impacts = stats.record_impacts;
  static thread_local std::vector<PairTally> calling_thread_tallies;
  std::vector<PairTally>& tallies = calling_thread_tallies;
  const std::size_t threads = std::size_t(thread_count());
  // With `ranges` (a multi-rate step with wall riders) only where the caller's scope finds the
  // population worth threads: the stepping particles' pass, not a rider level's catch-up.
  if (n > 0 && nl.owner_shares.fit(p.size(), threads) && (!ranges || worth_threads(p.size()))) {
    // On the pair pass's owner shares: each thread on the candidates of its own particles (the
    // rebuild lists them by slot, so `ranges`, ascending, hold them by slot too), adding to its
    // own loads. Owner by owner, their candidates come in the one-thread order.
    if (tallies.size() < threads) tallies.resize(threads);
    const std::uint32_t* particle = nl.wall_particle.data();
    parallel_on_each_thread([&](std::size_t t) {
      PairTally& tally = tallies[t];
      tally.impacts.clear(), tally.over_limit.clear();
      tally.touching = 0, tally.max_ratio = 0.0, tally.max_pair = 0;
      const std::uint32_t first_slot = std::uint32_t(nl.owner_shares.bound[t]);
      const std::uint32_t end_slot = std::uint32_t(nl.owner_shares.bound[t + 1]);
      // The candidates of [begin, end) whose particle is one of t's.
      const auto run_own = [&](std::size_t begin, std::size_t end) {
        const std::uint32_t* from = std::lower_bound(particle + begin, particle + end, first_slot);
        const std::uint32_t* to = std::lower_bound(from, particle + end, end_slot);
        if (from < to)
          wall_contacts(materials, walls, dt, limit, impacts, p, nl, std::size_t(from - particle),
                        std::size_t(to - particle), tally);
      };
      if (!ranges) return run_own(0, n);
      // The first range holding a candidate of t's (its last one at or past t's first slot).
      auto r = std::lower_bound(ranges->begin(), ranges->end(), first_slot,
                                [&](const NeighborList::PairRange& range, std::uint32_t slot) {
                                  return particle[range.end - 1] < slot;
                                });
      for (; r != ranges->end() && particle[r->begin] < end_slot; ++r) run_own(r->begin, r->end);
    });
    finish_wall_stats(tallies, threads, p, nl, stats);
    return;
  }
  // The pieces: runs of candidates cut where a particle's candidates end (the rebuild lists them
  // together, by slot, then wall), about kWallPieceCandidates to a piece, or one piece of all
  // of them unless the population is worth threads.
  const std::size_t piece_size = worth_threads(p.size()) ? block_items(kWallPieceCandidates)
                                                         : std::numeric_limits<std::size_t>::max();
  static thread_local std::vector<NeighborList::PairRange> calling_thread_runs;
  static thread_local std::vector<std::size_t> calling_thread_piece_runs;
  std::vector<NeighborList::PairRange>& runs = calling_thread_runs;
  std::vector<std::size_t>& piece_runs = calling_thread_piece_runs;  // each piece's first run
  runs.clear(), piece_runs.assign(1, 0);
  std::size_t in_piece = 0;
  const auto add_runs = [&](std::size_t begin, std::size_t end) {
    while (begin < end) {
      std::size_t stop = end;
      if (end - begin > piece_size - in_piece) {
        stop = begin + std::max<std::size_t>(piece_size - in_piece, 1);
        while (stop < end && nl.wall_particle[stop] == nl.wall_particle[stop - 1]) ++stop;
      }
      runs.push_back({begin, stop});
      in_piece += stop - begin;
      if (in_piece >= piece_size) piece_runs.push_back(runs.size()), in_piece = 0;
      begin = stop;
    }
  };
  if (ranges)
    for (const NeighborList::PairRange& r : *ranges) add_runs(r.begin, r.end);
  else
    add_runs(0, n);
  if (piece_runs.back() != runs.size()) piece_runs.push_back(runs.size());
  const std::size_t pieces = piece_runs.size() - 1;
  if (tallies.size() < pieces) tallies.resize(pieces);
  parallel_blocks(pieces, [&](std::size_t q) {
    PairTally& t = tallies[q];
    t.impacts.clear(), t.over_limit.clear();
    t.touching = 0, t.max_ratio = 0.0, t.max_pair = 0;
    for (std::size_t run = piece_runs[q]; run < piece_runs[q + 1]; ++run)
      wall_contacts(materials, walls, dt, limit, impacts, p, nl, runs[run].begin, runs[run].end, t);
  });
  finish_wall_stats(tallies, pieces, p, nl, stats);
}

double contact_elastic_energy_j(ContactModel model, const MaterialTable& materials,
                                const PeriodicBox& box, const std::vector<Wall>& walls,
                                const ParticleStore& p, const NeighborList& nl) {
  const SeriesSprings series_law(p);
  const PaperSprings paper_law(p);
  const EquivalentProperties equivalent_law(p);
  double energy = 0.0;
  for (std::size_t k = 0; k < nl.pairs.size(); ++k) {
    const std::uint32_t i = nl.pairs.first[k], j = nl.pairs.second[k];
    const double dist = norm(box.minimum_image(p.position_m[i] - p.position_m[j]));
    const bool ghost = nl.pair_touching[k] == kPairGhost;
    const Vec3 history = nl.pair_history_m(k);
    const double overlap = p.radius_m[i] + p.radius_m[j] - dist - (ghost ? history[0] : 0.0);
    if (overlap <= 0.0) continue;
    const PairConstants& pc = materials.pair(p.material[i], p.material[j]);
    const PairSprings s = model == ContactModel::SeriesSprings  ? series_law(i, j, pc)
                          : model == ContactModel::PaperSprings ? paper_law(i, j, pc)
                                                                : equivalent_law(i, j, pc);
    energy += contact_elastic_energy_j(s, overlap, ghost ? nullptr : &history);
  }
  for (std::size_t k = 0; k < nl.wall_particle.size(); ++k) {
    const std::uint32_t i = nl.wall_particle[k];
    const Wall& wall = walls[nl.wall_index[k]];
    const bool ghost = nl.wall_touching[k] == kPairGhost;
    const double overlap =
        p.radius_m[i] - wall_gap_m(wall, p.position_m[i]) - (ghost ? nl.wall_history_m[k][0] : 0.0);
    if (overlap <= 0.0) continue;
    const PairConstants& pc = materials.wall_pair(wall.pair_table, p.material[i]);
    energy += contact_elastic_energy_j(wall_springs_at(p, i, wall, pc), overlap,
                                       ghost ? nullptr : &nl.wall_history_m[k]);
  }
  return energy;
}

}  // namespace millsim
