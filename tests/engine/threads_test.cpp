// The engine's threads (parallel/thread_team.h): the team runs every block of a loop exactly once
// on any thread count, and a run's physics is the same bit for bit on 1, 2 and 3 threads: the
// spiral jet mill (gas, walls, multi-rate stepping) and its 4 barg variant (the compressible gas),
// the fluidized bed (dense contacts, gas) and the attrition target (breakage and fragment
// spawning), each compared column by column. The
// hashed grid's search, cut into one part per thread, returns the one-thread list in its order.
// The dust ledger and its grinding, which carry and sweep class by class on the threads, leave
// every class's mass in every cell the same bit for bit.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "dem/integrator.h"
#include "dust/dust_grinding.h"
#include "dust/dust_ledger.h"
#include "gas/compressible/compressible_solver.h"
#include "gas/gas_solver.h"
#include "parallel/slot_shares.h"
#include "parallel/thread_team.h"
#include "particles/materials.h"
#include "search/hashed_grid.h"
#include "sim/simulation.h"
#include "support/draining_vortex.h"
#include "support/ledger_state.h"
#include "support/run_compare.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

// Sets the team's size for one scope and puts the single thread back.
struct Threads {
  explicit Threads(int n) { set_thread_count(n); }
  ~Threads() { set_thread_count(1); }
};

// Blocks of 1/64 the size for one scope: the test scenes' few hundred to few thousand particles
// and candidates then make many blocks, so that every threaded loop runs on several threads.
struct SmallBlocks {
  SmallBlocks() { set_block_divisor(64); }
  ~SmallBlocks() { set_block_divisor(1); }
};

TEST(ThreadTeam, RunsEveryBlockOnceOnEveryThreadCount) {
  for (int threads : {1, 2, 3, 5}) {
    Threads team(threads);
    ASSERT_EQ(thread_count(), threads);
    for (std::size_t blocks : {std::size_t(1), std::size_t(2), std::size_t(7), std::size_t(1000)}) {
      std::vector<std::atomic<int>> runs(blocks);
      for (int repeat = 0; repeat < 20; ++repeat)
        parallel_blocks(blocks, [&](std::size_t b) { runs[b].fetch_add(1); });
      for (std::size_t b = 0; b < blocks; ++b) EXPECT_EQ(runs[b].load(), 20) << blocks << " " << b;
    }
  }
}

TEST(ThreadTeam, AThreadHeldUpInABlockLeavesTheRestOfItsShareToTheOthers) {
  // 2 threads, 8 blocks: the calling thread's share is blocks 0-3. Block 0 waits until blocks 1-3
  // have run, which only the other thread can do once its own share (4-7) is done.
  Threads team(2);
  std::vector<std::atomic<int>> done(8);
  std::vector<std::thread::id> ran_on(8);
  std::atomic<bool> timed_out{false};
  parallel_blocks(8, [&](std::size_t b) {
    ran_on[b] = std::this_thread::get_id();
    if (b == 0) {
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
      while (done[1].load() + done[2].load() + done[3].load() < 3)
        if (std::chrono::steady_clock::now() > give_up) {
          timed_out = true;
          break;
        }
    }
    done[b].store(1);
  });
  ASSERT_FALSE(timed_out.load()) << "blocks 1-3 waited for block 0's thread";
  for (std::size_t b = 1; b < 4; ++b) EXPECT_NE(ran_on[b], ran_on[0]) << b;
  for (int d = 0; d < 8; ++d) EXPECT_EQ(done[std::size_t(d)].load(), 1);
}

TEST(ThreadTeam, RangesCoverEveryItemOnce) {
  Threads team(3);
  SmallBlocks small_blocks;  // 10007 items: fewer than the threads' minimum otherwise
  const std::size_t n = 10007;
  std::vector<int> hits(n, 0);
  std::vector<std::size_t> block_of(n);
  parallel_ranges(n, 512, [&](std::size_t begin, std::size_t end, std::size_t block) {
    for (std::size_t i = begin; i < end; ++i) ++hits[i], block_of[i] = block;
  });
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(hits[i], 1) << i;
    ASSERT_EQ(block_of[i], i / 512) << i;
  }
}

TEST(ThreadTeam, AnExceptionInABlockReachesTheCallerAndTheTeamGoesOn) {
  Threads team(2);
  EXPECT_THROW(parallel_blocks(8,
                               [](std::size_t b) {
                                 if (b == 6) throw std::runtime_error("block 6");
                               }),
               std::runtime_error);
  // Two blocks throw: the lower block's exception is the one the caller gets.
  for (int repeat = 0; repeat < 20; ++repeat) {
    try {
      parallel_blocks(8, [](std::size_t b) {
        if (b == 1 || b == 5) throw std::runtime_error(b == 1 ? "block 1" : "block 5");
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "block 1");
    }
  }
  std::atomic<int> sum{0};
  parallel_blocks(8, [&](std::size_t b) { sum += int(b); });
  EXPECT_EQ(sum.load(), 28);
}

TEST(ThreadTeam, ALoopInsideALoopRunsOnItsCallingThread) {
  Threads team(2);
  std::vector<int> inner_threads_seen(4, 0);
  parallel_blocks(4, [&](std::size_t b) {
    const std::thread::id outer = std::this_thread::get_id();
    int elsewhere = 0;
    parallel_blocks(3, [&](std::size_t) { elsewhere += std::this_thread::get_id() != outer; });
    inner_threads_seen[b] = elsewhere;
  });
  for (int e : inner_threads_seen) EXPECT_EQ(e, 0);
}

TEST(ThreadTeam, EachThreadRunsItsOwnShareAndAThiefTakesFromTheBack) {
  // Every thread once, each on a thread of its own, thread 0 on the caller.
  for (int threads : {2, 3, 5}) {
    Threads team(threads);
    const std::size_t count = std::size_t(threads);
    std::vector<std::thread::id> ran_on(count);
    std::vector<std::atomic<int>> runs(count);
    for (int repeat = 0; repeat < 20; ++repeat)
      parallel_on_each_thread([&](std::size_t t) {
        ran_on[t] = std::this_thread::get_id();
        runs[t].fetch_add(1);
      });
    EXPECT_EQ(ran_on[0], std::this_thread::get_id());
    for (std::size_t t = 0; t < count; ++t) {
      EXPECT_EQ(runs[t].load(), 20) << t;
      for (std::size_t u = 0; u < t; ++u) EXPECT_NE(ran_on[t], ran_on[u]) << t << " " << u;
    }
  }
  // Uneven shares [0, 6) and [6, 8): block 0 (the caller's) waits until blocks 1-5 have run,
  // which only the other thread can do, after its own 6 and 7, taking 5, 4, ... from the back.
  Threads team(2);
  const std::size_t bounds[3] = {0, 6, 8};
  std::vector<std::atomic<int>> done(8);
  std::vector<std::thread::id> ran_on(8);
  std::vector<int> order(8, -1);
  std::atomic<int> next{0}, timed_out{0};
  parallel_blocks_in_shares(8, bounds, [&](std::size_t b) {
    ran_on[b] = std::this_thread::get_id();
    if (b == 0) {
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
      while (done[1] + done[2] + done[3] + done[4] + done[5] < 5)
        if (std::chrono::steady_clock::now() > give_up) {
          timed_out = 1;
          break;
        }
    } else {
      order[b] = next.fetch_add(1);
    }
    done[b].store(1);
  });
  ASSERT_FALSE(timed_out.load()) << "blocks 1-5 waited for block 0's thread";
  for (std::size_t b = 1; b < 8; ++b) EXPECT_NE(ran_on[b], ran_on[0]) << b;
  EXPECT_LT(order[6], order[7]);  // its own share from the front
  for (std::size_t b = 1; b < 5; ++b) EXPECT_GT(order[b], order[b + 1]) << b;  // then from the back
  EXPECT_GT(order[5], order[7]);
}

TEST(ThreadTeam, AScopeMovesTheMinimumForItsLoopsOnly) {
  Threads team(2);
  EXPECT_FALSE(worth_threads(kMinSlotsForOwnerPasses));
  {
    const MinItemsForThreadsScope scope(kMinSlotsForOwnerPasses);
    EXPECT_TRUE(worth_threads(kMinSlotsForOwnerPasses));
    EXPECT_FALSE(worth_threads(kMinSlotsForOwnerPasses - 1));
  }
  EXPECT_FALSE(worth_threads(kMinSlotsForOwnerPasses));
  EXPECT_TRUE(worth_threads(kMinItemsForThreads));
}

// A loop's pieces are halved from the nominal size until every thread has at least
// kPiecesPerThreadToBalance of them, never below the smallest size and never for a loop that
// already has that many.
TEST(ThreadTeam, APieceSizeLeavesEveryThreadAFewPieces) {
  auto pieces = [](std::size_t items, std::size_t size) { return (items + size - 1) / size; };
  for (int threads : {1, 2, 3, 8}) {
    SCOPED_TRACE(threads);
    Threads team(threads);
    const std::size_t wanted = kPiecesPerThreadToBalance * std::size_t(threads);
    for (std::size_t items : {1ul, 100ul, 3000ul, 20000ul, 50000ul, 1000000ul}) {
      SCOPED_TRACE(items);
      const std::size_t size = balanced_piece_items(items, 8192, 1024);
      EXPECT_LE(size, 8192u);
      EXPECT_GE(size, 1024u);
      EXPECT_EQ(8192 % size, 0u);  // a power-of-two part of the nominal size
      if (pieces(items, 8192) >= wanted) {
        EXPECT_EQ(size, 8192u);
      } else if (size > 1024) {
        EXPECT_GE(pieces(items, size), wanted);
        EXPECT_LT(pieces(items, 2 * size), wanted);  // halved no further than needed
      }
    }
  }
  Threads two(2);
  EXPECT_EQ(balanced_piece_items(20000, 8192, 1024), 2048u);  // 10 pieces, not 3
  EXPECT_EQ(balanced_piece_items(20000, 8192, 4096), 4096u);  // 5: the smallest allowed
}

TEST(SlotShares, EachShareBeginsWhereTheWeightBelowReachesItsPart) {
  // By hand: units of 4 slots weighing 1, 1, 6, 1, 1 over 18 slots (the last unit short), two
  // owners: the weight below reaches 5 of 10 at the end of unit 2 (slot 12), not before (2).
  SlotShares shares;
  split_by_weight({1, 1, 6, 1, 1}, 18, 4, 2, shares);
  EXPECT_EQ(shares.bound, (std::vector<std::size_t>{0, 12, 18}));
  split_by_weight({0, 0, 0, 0, 0}, 18, 4, 2, shares);  // no weight: equal shares of units
  EXPECT_EQ(shares.bound, (std::vector<std::size_t>{0, 8, 18}));
  EXPECT_TRUE(shares.fit(18, 2));
  EXPECT_FALSE(shares.fit(19, 2));
  EXPECT_FALSE(shares.fit(18, 3));
  // Random weights against the definition: each bound a multiple of the unit where the weight
  // below is at least t/T of the total and one unit lower it is not.
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const std::size_t unit = std::size_t(1) << (rng() % 5), units = 1 + rng() % 40;
    const std::size_t slots = (units - 1) * unit + 1 + rng() % unit, threads = 2 + rng() % 4;
    std::vector<double> w(units);
    for (double& x : w) x = rng() % 3 == 0 ? 0.0 : double(rng() % 1000);
    split_by_weight(w, slots, unit, threads, shares);
    ASSERT_EQ(shares.bound.size(), threads + 1);
    EXPECT_EQ(shares.bound.front(), 0u);
    EXPECT_EQ(shares.bound.back(), slots);
    double total = 0;
    for (double x : w) total += x;
    const auto below = [&](std::size_t slot) {
      double sum = 0;
      for (std::size_t u = 0; u * unit < slot; ++u) sum += w[u];
      return sum;
    };
    for (std::size_t t = 1; t < threads; ++t) {
      const std::size_t b = shares.bound[t];
      ASSERT_LE(shares.bound[t - 1], b);
      if (b < slots) {
        ASSERT_EQ(b % unit, 0u);
      }
      if (total == 0.0) continue;
      EXPECT_GE(below(b) * double(threads), total * double(t)) << trial << " " << t;
      if (b >= unit) {
        EXPECT_LT(below(b - unit) * double(threads), total * double(t)) << trial << " " << t;
      }
    }
  }
}

TEST(ThreadTeam, UsableCoresFollowTheAffinityMask) {
  cpu_set_t set;
  CPU_ZERO(&set);
  ASSERT_EQ(sched_getaffinity(0, sizeof set, &set), 0);
  EXPECT_EQ(usable_core_count(), CPU_COUNT(&set));
}

// A cloud for the grid: radii log-uniform over `size_ratio`, in a few tight clusters of a box
// (periodic or not), so that the parts of a threaded search hold very different work.
struct GridCloud {
  std::vector<Vec3> x;
  std::vector<double> r;
  PeriodicBox box;
};

GridCloud clustered_cloud(std::size_t n, double size_ratio, bool periodic, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GridCloud c;
  const double length = 1.0, r_max = 0.02;
  c.box = {{0, 0, 0}, {length, length, length}, {periodic, periodic, periodic}};
  const Vec3 centres[3] = {{0.1, 0.5, 0.95}, {0.5, 0.5, 0.5}, {0.8, 0.05, 0.3}};
  for (std::size_t i = 0; i < n; ++i) {
    c.r.push_back(r_max * std::pow(size_ratio, -u(rng)));
    Vec3 p = centres[i % 3] + Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5} * 0.25;
    c.box.wrap(p);
    for (int a = 0; a < 3; ++a) p[a] = std::clamp(p[a], 0.0, length);
    c.x.push_back(p);
  }
  return c;
}

// The grid's search on 2 and 3 threads, on the team, gives the list, tests and lookups of one
// thread's search (serial_grid, serial_list).
void expect_the_one_thread_list(const GridCloud& c, const HashedGridSettings& settings,
                                const HashedGrid& serial_grid, const PairList& serial_list) {
  for (int threads : {2, 3}) {
    SCOPED_TRACE(threads);
    Threads team(threads);
    PairList list;
    HashedGrid grid;
    const std::uint64_t loops_before = loops_run_on_team();
    grid.find_pairs(c.x, c.r, c.box, settings, list);
    EXPECT_GE(loops_run_on_team() - loops_before, 2u);
    EXPECT_EQ(list.first, serial_list.first);
    EXPECT_EQ(list.second, serial_list.second);
    EXPECT_EQ(grid.stats().distance_tests, serial_grid.stats().distance_tests);
    EXPECT_EQ(grid.stats().cell_lookups, serial_grid.stats().cell_lookups);
  }
}

TEST(Threads, GridSearchGivesTheOneThreadListInItsOrder) {
  SmallBlocks small_blocks;  // 3000 particles: past the threads' minimum
  for (const bool periodic : {false, true})
    for (const double size_ratio : {1.0, 30.0})
      for (const int k : {1, 3}) {
        SCOPED_TRACE(testing::Message()
                     << "periodic " << periodic << ", ratio " << size_ratio << ", k " << k);
        const GridCloud c = clustered_cloud(3000, size_ratio, periodic, 5u + unsigned(k));
        const HashedGridSettings settings{0.004, k, 3, std::nullopt};
        PairList serial_list;
        HashedGrid serial_grid;
        {
          Threads one(1);
          serial_grid.find_pairs(c.x, c.r, c.box, settings, serial_list);
        }
        ASSERT_GT(serial_list.size(), 1000u);
        if (k > 1 && size_ratio > 1.0) {
          ASSERT_GT(serial_grid.stats().levels, 1);  // the cross-level search is cut too
        }
        expect_the_one_thread_list(c, settings, serial_grid, serial_list);
      }
}

// A search of 12 000 particles at the shipped block sizes is cut into pieces of 1024 (at least
// four per thread, balanced_piece_items) instead of two of 8192: the list is still the one a
// single thread makes.
TEST(Threads, GridSearchInBalancedPiecesGivesTheOneThreadList) {
  const GridCloud c = clustered_cloud(12000, 30.0, true, 17u);
  const HashedGridSettings settings{0.002, 3, 3, std::nullopt};
  const MinItemsForThreadsScope scope(kMinSlotsForOwnerPasses);
  PairList serial_list;
  HashedGrid serial_grid;
  {
    Threads one(1);
    serial_grid.find_pairs(c.x, c.r, c.box, settings, serial_list);
  }
  ASSERT_GT(serial_list.size(), 12000u);
  expect_the_one_thread_list(c, settings, serial_grid, serial_list);
}

// A free vortex draining into a central outlet in the lid (the ledger's own test's flow), 24 × 24
// × 2 cells, dust of 12 classes from 0.1 to 10 µm put at random in every cell, and 400 salt
// particles of 60-200 µm moving at up to 150 m/s through it: 12 advances of the ledger, each
// followed by a grinding pass. Returns the ledger and the grinding as they end.
struct DustState {
  test::LedgerState ledger;
  std::vector<double> ground_kg;
};

DustState carry_and_grind_dust() {
  test::DrainingVortex vortex;
  vortex.cells = 24, vortex.layers = 2, vortex.side_m = 0.024, vortex.outlet_radius_m = 0.003;
  vortex.sink_m2_per_s = 0.03, vortex.circulation_m2_per_s = 0.15;
  const double L = vortex.side_m, lid = vortex.layers * vortex.cell_m();
  const GasSolver gas = test::draining_vortex_gas(vortex);
  const GasGrid& grid = gas.grid();
  const int n = vortex.cells;

  std::vector<double> edges;
  for (double d = 1e-7; d < 1.1e-5; d *= 1.5) edges.push_back(d);
  MaterialConfig salt = test::table1_material();
  salt.name = "salt", salt.density_kg_per_m3 = 2160, salt.youngs_modulus_pa = 1e9;
  MaterialBreakageConfig b;
  b.strength.model = StrengthModel::VogelPeukert;
  b.strength.f_mat_kg_per_j_m = 60.0;
  b.strength.x_w_min_j_m_per_kg = 0.003;
  b.fragments = test::power_law_fragments(1.0, 0.05, 0.7);
  salt.breakage = b;
  DustLedger ledger(grid, dust_classes(edges, 1e-5, 2160, 1.8e-5, 0.0), {0, 0, -9.81});
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int kz = 1; kz <= 2; ++kz)
    for (int j = 1; j <= n; ++j)
      for (int i = 1; i <= n; ++i)
        for (int k = 0; k < ledger.class_count(); ++k)
          ledger.deposit(grid.cell_center(i, j, kz), k, 1e-12 * unit(rng));

  const SceneConfig scene = test::empty_scene({0, 0, 0}, {L, L, lid}, salt);
  const MaterialTable table(scene);
  ParticleStore particles;
  for (int i = 0; i < 400; ++i) {
    const Vec3 x{L * unit(rng), L * unit(rng), lid * unit(rng)};
    const Vec3 v{300 * unit(rng) - 150, 300 * unit(rng) - 150, 20 * unit(rng) - 10};
    particles.add(table, 0, std::uint64_t(i + 1), x, v, {}, 6e-5 + 1.4e-4 * unit(rng));
  }
  DustGrinding grinding(ledger, edges, salt, 0, ImpactEquivalence::Energy);
  for (int step = 0; step < 12; ++step) {
    ledger.advance(gas, 2e-5);
    grinding.grind(ledger, particles, table, 2e-5);
  }
  return {test::ledger_state(ledger), grinding.stats().ground_kg};
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

TEST(Threads, DustLedgerAndItsGrindingAreBitIdenticalOnOneTwoAndThreeThreads) {
  SmallBlocks small_blocks;  // 12 classes × 1 152 cells, 400 particles: past the minimum then
  DustState serial;
  {
    Threads one(1);
    serial = carry_and_grind_dust();
  }
  // The case must exercise what it is here for: dust left, classes sub-stepped, dust ground.
  double out = 0.0, ground = 0.0;
  for (double kg : serial.ledger.outflow_kg) out += kg;
  for (double kg : serial.ground_kg) ground += kg;
  EXPECT_GT(out, 0.0);
  EXPECT_GT(ground, 0.0);
  EXPECT_GT(serial.ledger.substeps, 12u * serial.ledger.mass.size());
  for (int threads : {2, 3}) {
    SCOPED_TRACE(threads);
    Threads team(threads);
    const std::uint64_t loops_before = loops_run_on_team();
    const DustState threaded = carry_and_grind_dust();
    EXPECT_GE(loops_run_on_team() - loops_before, 24u) << "each advance and pass on the team";
    ASSERT_EQ(threaded.ledger.mass.size(), serial.ledger.mass.size());
    for (std::size_t k = 0; k < serial.ledger.mass.size(); ++k)
      EXPECT_TRUE(same_bits(threaded.ledger.mass[k], serial.ledger.mass[k])) << "class " << k;
    EXPECT_TRUE(same_bits(threaded.ledger.outflow_kg, serial.ledger.outflow_kg));
    EXPECT_TRUE(same_bits(threaded.ground_kg, serial.ground_kg));
    EXPECT_TRUE(same_bits(threaded.ledger.max_slip, serial.ledger.max_slip));
    EXPECT_EQ(threaded.ledger.speed_bounded_cells, serial.ledger.speed_bounded_cells);
    EXPECT_EQ(threaded.ledger.substeps, serial.ledger.substeps);
  }
}

// The state after 40 steps of a viscous periodic box of compressible gas with a flow pattern and
// uneven dust on it (gas/compressible/compressible_solver.h, "dust"), on `threads` threads with
// blocks small enough that every cell pass runs on all of them.
std::vector<double> dusty_box_state(int threads) {
  Threads team(threads);
  SmallBlocks small;
  const MinItemsForThreadsScope every_loop(1);
  GasConfig config;
  config.model = GasModel::Compressible;
  config.cells = {10, 10, 10};
  config.viscosity_pa_s = 1.8e-5;
  CompressibleSolver solver(
      config, build_gas_grid(config, {0, 0, 0}, {1e-2, 1e-2, 1e-2}, {true, true, true}),
      {0, 0, -9.81});
  const GasGrid& g = solver.grid();
  solver.dust_density().assign(g.padded_size, 0.0);
  for (std::size_t c = 0; c < g.padded_size; ++c) {
    if (!g.fluid[c]) continue;
    const std::array<int, 3> ijk = g.coords(c);
    const double s = std::sin(1.3 * ijk[0] + 0.7 * ijk[1] + 2.1 * ijk[2]);
    solver.set_state(c, 1.2 * (1 + 0.05 * s), Vec3{20 * s, 5 * std::cos(ijk[0]), 0},
                     101325.0 * (1 + 0.03 * s));
    solver.dust_density()[c] = 3.0 * (1 + s);
  }
  for (int step = 0; step < 40; ++step) EXPECT_FALSE(solver.advance(solver.stable_step_s(0.4)));
  std::vector<double> state;
  for (std::size_t c = 0; c < g.padded_size; ++c)
    if (g.fluid[c]) {
      const Vec3 u = solver.velocity_m_per_s(c);
      state.insert(state.end(),
                   {solver.density_kg_per_m3(c), u.x, u.y, u.z, solver.pressure_pa(c)});
    }
  const Vec3 impulse = solver.dust_impulse_n_s();
  state.insert(state.end(), {impulse.x, impulse.y, impulse.z, solver.dust_work_j()});
  return state;
}

TEST(Threads, TheDustyCompressibleGasIsBitIdenticalOnOneTwoAndThreeThreads) {
  const std::uint64_t loops_before = loops_run_on_team();
  const std::vector<double> one = dusty_box_state(1);
  const std::vector<double> two = dusty_box_state(2), three = dusty_box_state(3);
  EXPECT_GT(loops_run_on_team(), loops_before) << "the cell passes ran on the team";
  ASSERT_EQ(one.size(), two.size());
  ASSERT_EQ(one.size(), three.size());
  for (std::size_t k = 0; k < one.size(); ++k) {
    ASSERT_EQ(one[k], two[k]) << k;
    ASSERT_EQ(one[k], three[k]) << k;
  }
  EXPECT_NE(one.back(), 0.0) << "the dust took work from the gas";
}

TEST(Threads, TheListCountsTheActiveCandidatesOfEachUnitOfSlots) {
  // The fluidized bed after some steps: gap bands partly active, block by block. The list's
  // count (binary searches within each band) against a walk over every candidate.
  SceneConfig scene = test::shipped_case("fluidized_bed.json", 2e-3);
  if (scene.gas) scene.gas->spin_up_s = 0.0;
  Simulation sim(scene);
  ASSERT_FALSE(sim.advance(sim.total_steps()));
  const NeighborList& nl = sim.neighbors();
  const std::size_t n = sim.particles().size();
  for (std::size_t unit : {1, 16, 1024}) {
    std::vector<std::uint64_t> brute((n + unit - 1) / unit, 0), from_list;
    std::size_t active = 0;
    for (std::size_t k = 0; k < nl.pairs.size(); ++k)
      if (nl.pair_active(k)) ++brute[nl.pairs.first[k] / unit], ++active;
    ASSERT_GT(active, 0u);
    ASSERT_LT(active, nl.pairs.size());  // some candidates outside the active bands
    nl.count_active_candidates(n, unit, from_list);
    EXPECT_EQ(from_list, brute) << unit;
  }
}

TEST(SlotShares, AListIsCutWhereTheOwnersUnitsBeginAndItsMaximaAreTheOnePassOnes) {
  // A multi-rate step's listed passes (dem/integrator.h, listed_pieces) on the owner shares: 10 000
  // slots in units of 64 shared by 3 owners, a list of about a third of them with whole units
  // missing. Each piece must be exactly the listed entries of one unit, every entry run once, and
  // the speed maxima per block those of one pass in order.
  Threads team(3);
  // The scope a multi-rate step's stepping passes run in (Simulation::min_items_for_threads).
  const MinItemsForThreadsScope minimum(kMinSlotsForOwnerPasses);
  constexpr std::size_t kPopulation = 10000, kUnit = 64;
  const std::size_t units = (kPopulation + kUnit - 1) / kUnit;
  SlotShares shares;
  shares.slots = kPopulation, shares.unit = kUnit,
  shares.bound = {0, 40 * kUnit, 100 * kUnit, kPopulation};
  std::mt19937_64 rng(5);
  std::vector<std::uint32_t> slots;
  for (std::uint32_t i = 0; i < kPopulation; ++i)
    if ((i < 3000 || i >= 4100) && rng() % 3 == 0) slots.push_back(i);
  std::vector<std::atomic<int>> runs(units);
  std::vector<std::pair<std::size_t, std::size_t>> range(units);
  const std::size_t pieces = listed_pieces(
      slots, kPopulation, &shares, [&](std::size_t begin, std::size_t end, std::size_t piece) {
        runs[piece].fetch_add(1);
        range[piece] = {begin, end};
      });
  EXPECT_EQ(pieces, units);
  std::size_t covered = 0;
  for (std::size_t u = 0; u < units; ++u) {
    // By definition: the entries whose slot lies in [u·64, (u+1)·64).
    std::size_t first = slots.size(), last = 0;
    for (std::size_t k = 0; k < slots.size(); ++k)
      if (slots[k] / kUnit == u) first = std::min(first, k), last = k + 1;
    if (first == slots.size()) {
      EXPECT_EQ(runs[u].load(), 0) << "unit " << u << " lists nothing";
      continue;
    }
    ASSERT_EQ(runs[u].load(), 1) << "unit " << u;
    EXPECT_EQ(range[u], std::make_pair(first, last)) << "unit " << u;
    covered += last - first;
  }
  EXPECT_EQ(covered, slots.size());
  EXPECT_EQ(runs[3000 / kUnit + 1].load(), 0);  // a unit with nothing listed

  // The speeds' maxima on the shares against one pass in list order, and the cut the listed
  // passes take when the shares do not fit the population (pieces of the list's entries).
  std::vector<double> speed2(kPopulation);
  for (double& v : speed2) v = double(rng() % 100000);
  const std::size_t blocks = (kPopulation + kSpeedBlockSlots - 1) / kSpeedBlockSlots;
  std::vector<double> expected_block(blocks, 0.0);
  double expected_max = 0.0;
  for (const std::uint32_t i : slots) {
    expected_block[i / kSpeedBlockSlots] =
        std::max(expected_block[i / kSpeedBlockSlots], speed2[i]);
    expected_max = std::max(expected_max, speed2[i]);
  }
  for (const std::size_t population : {kPopulation, kPopulation + 1}) {
    SmallBlocks small_blocks;
    std::vector<double> block(blocks, 0.0);
    const double max2 = for_listed_speeds(
        slots, block, [&](std::uint32_t i) { return speed2[i]; }, population, &shares);
    EXPECT_EQ(max2, expected_max);
    EXPECT_EQ(block, expected_block);
  }
  const std::size_t entry_pieces =
      (slots.size() + block_items(kListPieceEntries) - 1) / block_items(kListPieceEntries);
  const auto nothing = [](std::size_t, std::size_t, std::size_t) {};
  EXPECT_EQ(listed_pieces(slots, kPopulation + 1, &shares, nothing), entry_pieces);
  // Nor where the caller's scope finds the population not worth threads (a catch-up of a few
  // waiting particles, outside the stepping passes' scope).
  const MinItemsForThreadsScope outside(kMinItemsForThreads);
  EXPECT_EQ(listed_pieces(slots, kPopulation, &shares, nothing), entry_pieces);
}

TEST(SlotShares, TheBalancerLearnsWhereCandidatesCostMore) {
  // 64 units of 1024 slots, 100 candidates each; the last 16 units' candidates cost 3 times the
  // others' (the periodic images' pairs of a Morton order's corner, say). Two owners. A pass's
  // seconds per owner are its units' true costs; the balancer sees only those sums.
  const std::size_t unit = 1024, units = 64, slots = units * unit;
  const std::vector<std::uint64_t> candidates(units, 100);
  const auto true_cost = [](std::size_t u) { return u >= 48 ? 3e-9 : 1e-9; };
  const auto work = [&](const SlotShares& shares) {
    std::vector<double> w(shares.threads(), 0.0);
    for (std::size_t t = 0; t < shares.threads(); ++t)
      for (std::size_t u = shares.bound[t] / unit; u * unit < shares.bound[t + 1]; ++u)
        w[t] += double(candidates[u]) * true_cost(u);
    return w;
  };
  const auto imbalance = [](const std::vector<double>& w) {
    return std::max(w[0], w[1]) / (0.5 * (w[0] + w[1])) - 1.0;
  };
  ShareBalancer balancer;
  SlotShares shares;
  balancer.split(candidates, slots, unit, 2, shares);
  EXPECT_EQ(shares.bound[1], slots / 2);    // by count alone: half the units each
  EXPECT_GT(imbalance(work(shares)), 0.3);  // thread 1 holds 16 + 16·3 of 96 cost units
  for (int pass = 0; pass < 30; ++pass) {
    balancer.learn(shares, candidates, work(shares));
    balancer.split(candidates, slots, unit, 2, shares);
  }
  // Balanced within the kept imbalance and a unit's cost: the even cut lies at 48 of 96 cost
  // units, i.e. at unit 48, and 5 % of 48 is 2.4 units.
  EXPECT_LT(imbalance(work(shares)), ShareBalancer::kKeepImbalance + 0.03);
  EXPECT_NEAR(double(shares.bound[1]) / double(unit), 48.0, 3.0);
}

struct ThreadCase {
  const char* file;
  double end_s;
  bool multi_rate;
  bool wall_riders = false;
};

TEST(Threads, PhysicsIsBitIdenticalOnOneTwoAndThreeThreads) {
  // Under the sanitizers (ThreadSanitizer's run is the one that checks the loops' memory
  // accesses; 5-15x slower) 1 against 3 threads, and half the bed's window.
#if defined(MILLSIM_SANITIZED)
  const std::vector<int> thread_counts{3};
  constexpr double kBedEnd = 0.005;
#else
  const std::vector<int> thread_counts{2, 3};
  constexpr double kBedEnd = 0.01;
#endif
  for (const ThreadCase& c : {ThreadCase{"attrition_target.json", 4e-4, false},
                              ThreadCase{"fluidized_bed.json", kBedEnd, false},
                              ThreadCase{"fluidized_bed.json", kBedEnd, true},
                              ThreadCase{"spiral_jet_mill.json", 1.5e-5, true},
                              ThreadCase{"attrition_target.json", 4e-4, true, true},
                              ThreadCase{"spiral_jet_mill_4barg.json", 4e-6, true}}) {
    SCOPED_TRACE(std::string(c.file) + (c.multi_rate ? ", multi-rate" : "") +
                 (c.wall_riders ? ", wall riders" : ""));
    SmallBlocks small_blocks;
    // The mill's feed has brought in only a few particles this early: 600 more near its mantle.
    SceneConfig scene = test::shipped_case(
        c.file, test::bit_for_bit_window_s(c.file, c.end_s), [&](nlohmann::json& doc) {
          if (std::string(c.file).rfind("spiral_jet_mill", 0) != 0) return;
          doc["sources"] = nlohmann::json::array(
              {{{"type", "random"},
                {"material", "salt"},
                {"count", 600},
                {"region", {{"min_m", {0.015, 0.033, 0.001}}, {"max_m", {0.025, 0.037, 0.005}}}},
                {"sizes", {{"distribution", "uniform"}, {"min_m", 6e-5}, {"max_m", 1.2e-4}}}}});
        });
    scene.time.multi_rate = c.multi_rate;
    scene.time.wall_riders = c.wall_riders;
    if (scene.gas) scene.gas->spin_up_s = 0.0;  // the particles meet a gas that changes fast
    Threads one(1);
    Simulation serial(scene);
    ASSERT_FALSE(serial.advance(serial.total_steps()));
    for (int threads : thread_counts) {
      SCOPED_TRACE(threads);
      Threads team(threads);
      Simulation threaded(scene);
      const std::uint64_t loops_before = loops_run_on_team();
      ASSERT_FALSE(threaded.advance(threaded.total_steps()));
      // The steps ran their loops on the team (under multi-rate stepping most steps move a short
      // list of particles, below the threads' minimum: fewer there).
      EXPECT_GT(loops_run_on_team() - loops_before,
                std::uint64_t(threaded.step_index()) / (c.multi_rate ? 20 : 2));
      test::expect_identical(serial, threaded);
      // The force pass ran on owner shares of the slots (the one-thread one did not), and the
      // kick-drift on them (a multi-rate step's listed passes cut at their units).
      EXPECT_TRUE(
          threaded.neighbors().owner_shares.fit(threaded.particles().size(), std::size_t(threads)));
      EXPECT_TRUE(serial.neighbors().owner_shares.bound.empty());
      EXPECT_EQ(serial.contact_steps(), threaded.contact_steps());
      EXPECT_EQ(serial.contact_stats().touching_walls, threaded.contact_stats().touching_walls);
      if (serial.breakage()) {
        EXPECT_EQ(serial.breakage()->stats().impacts, threaded.breakage()->stats().impacts);
        EXPECT_EQ(serial.breakage()->stats().fragments, threaded.breakage()->stats().fragments);
      }
      if (serial.gas()) {
        const CouplingStats &a = serial.gas()->stats(), &b = threaded.gas()->stats();
        EXPECT_EQ(a.drag_evaluations, b.drag_evaluations);
        EXPECT_EQ(0, std::memcmp(&a.particle_impulse_n_s, &b.particle_impulse_n_s, sizeof(Vec3)));
      }
    }
    // The cases must exercise what they are here for.
    if (serial.gas()) {
      EXPECT_GT(serial.gas()->stats().drag_evaluations, 0u);
      if (serial.gas()->compressible()) {  // its own passes ran, on the team too
        EXPECT_GT(serial.gas()->stats().cfd_steps, 2u);
      }
    }
    if (std::string(c.file).rfind("spiral_jet_mill", 0) != 0) {  // too early for the mills
      EXPECT_GT(serial.contact_steps(), 0u);
    }
    if (std::string(c.file) == "attrition_target.json") {
      EXPECT_GT(serial.breakage()->stats().events, 0u);
    }
    if (c.multi_rate) {
      EXPECT_GT(serial.multi_rate()->stats.waiting_particle_steps, 0.0);
    }
    if (c.wall_riders) {
      EXPECT_GT(serial.multi_rate()->stats.rider_steps, 0.0);
    }
  }
}

}  // namespace
}  // namespace millsim
