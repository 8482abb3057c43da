// bench_step: the full DEM step (search + Hertz–Mindlin forces + integration) on a shared
// benchmark scene (shared/bench/FORMAT.md), one core, at the file's time step.
//
//   bench_step SCENE.txt [--steps N] [--json] [--skin-dmin F] [--subcells K] [--levels L]
//              [--checkpoint DIR]  (also times a checkpoint of the final state into DIR)
//              [--k-scan] [--threads N]  (the engine's threads, default 1)
//   bench_step --generate-mono N OUT.txt   writes a mono-like scene of N particles (d = 100 µm,
//                                          φ = 0.2, periodic, v ~ N(0, 2 m/s), Table 1, dt as
//                                          mono) in the shared format, for the scaling runs
//
// --skin-dmin F sets the Verlet skin to F × the smallest diameter, --subcells K fixes the
// sub-grid division and --levels L the number of grid levels (default: the engine's automatic
// choice; K alone means the paper's two levels); --k-scan runs K = 1..8 with two levels in turn
// and prints the time per step of each, normalised by the fastest (the paper's Fig. 3).
//
// Prints particle-steps per second, pair distance tests per true contact, neighbour-list
// rebuilds and their cost, resident memory per particle, the phase breakdown, and the physics
// sanity figures the peers report (kinetic-energy ratio final/initial, contacts at the end).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "checkpoint/checkpoint_file.h"
#include "core/errors.h"
#include "parallel/thread_team.h"
#include "particles/particle_sources.h"
#include "search/hashed_grid.h"
#include "sim/simulation.h"

namespace {

long resident_kib() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

}  // namespace

// Writes a mono-like scene of n particles in the shared benchmark format.
int generate_mono(std::int64_t n, const std::string& path) {
  using namespace millsim;
  const double d = 100e-6, phi = 0.2;
  const double L = std::cbrt(double(n) * M_PI / 6.0 * d * d * d / phi);
  SourceConfig source;
  source.kind = SourceKind::Random;
  source.count = n;
  source.region_max_m = {L, L, L};
  source.sizes = {SizeDistributionKind::Fixed, d};
  source.velocity_spread_m_per_s = 2.0;
  const PeriodicBox box{{0, 0, 0}, {L, L, L}, {true, true, true}};
  Rng rng(20261122);
  InputErrors errors;
  const std::vector<ParticleSpec> specs = random_packing(source, box, {}, rng, "generate", errors);
  if (!errors.empty()) {
    std::fprintf(stderr, "%s\n", format_input_errors("generate", errors).c_str());
    return 2;
  }
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) return 4;
  // The header keys shared/bench/peers/scene2data.py reads too, so LAMMPS can run the same file.
  std::fprintf(out, "# scene: mono_%lld\n# d_min_nominal: 1.000000e-04\n",
               static_cast<long long>(n));
  std::fprintf(out,
               "# N: %lld\n# boundary: periodic periodic periodic\n# box: 0 %.9e 0 %.9e 0 %.9e\n",
               static_cast<long long>(n), L, L, L);
  std::fprintf(out,
               "# youngs_modulus_E: 1e9\n# poisson_ratio_nu: 0.3\n# density_rho: 2000\n"
               "# restitution_e: 0.5\n# friction_mu: 0.3\n# gravity: 0 0 0\n# dt: 7.740358e-08\n"
               "# columns: id x y z d vx vy vz\n");
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const ParticleSpec& p = specs[i];
    std::fprintf(out, "%zu %.9e %.9e %.9e %.6e %.6e %.6e %.6e\n", i + 1, p.position_m.x,
                 p.position_m.y, p.position_m.z, p.diameter_m, p.velocity_m_per_s.x,
                 p.velocity_m_per_s.y, p.velocity_m_per_s.z);
  }
  return std::fclose(out) == 0 ? 0 : 4;
}

// One rebuild's search on the final state for every grid division, at the final skin: distance
// tests, candidates and the best of three times.
void print_search_scan(const millsim::Simulation& sim) {
  using namespace millsim;
  const ParticleStore& p = sim.particles();
  const double skin = sim.neighbors().skin_m();
  std::printf(
      "skin %.3e m\n| k | levels | distance tests | cell probes | candidates | seconds |\n"
      "| --- | --- | --- | --- | --- | --- |\n",
      skin);
  for (int k = 1; k <= 8; ++k)
    for (int levels = 2; levels <= (k == 1 ? 2 : kMaxGridLevels); ++levels) {
      HashedGrid grid;
      PairList pairs;
      double best = 1e300;
      for (int rep = 0; rep < 3; ++rep) {
        const auto t0 = std::chrono::steady_clock::now();
        grid.find_pairs(p.position_m, p.radius_m, sim.box(), {skin, k, levels, std::nullopt},
                        pairs);
        best = std::min(
            best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      std::printf("| %d | %d | %llu | %llu | %zu | %.4e |\n", k, k == 1 ? 1 : levels,
                  (unsigned long long)grid.stats().distance_tests,
                  (unsigned long long)grid.stats().cell_lookups, pairs.size(), best);
    }
}

int main(int argc, char** argv) {
  using namespace millsim;
  if (argc == 4 && std::string(argv[1]) == "--generate-mono")
    return generate_mono(std::stoll(argv[2]), argv[3]);
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_step SCENE.txt [--steps N] [--json]\n");
    return 2;
  }
  std::int64_t steps = 1000;
  bool as_json = false, k_scan = false, search_scan = false;
  std::string checkpoint_dir;
  std::optional<double> skin_dmin;
  std::optional<int> subcells;
  std::optional<int> levels;
  bool skin_by_speed = true;
  for (int k = 2; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--steps" && k + 1 < argc)
      steps = std::stoll(argv[++k]);
    else if (a == "--json")
      as_json = true;
    else if (a == "--skin-dmin" && k + 1 < argc)
      skin_dmin = std::stod(argv[++k]);
    else if (a == "--subcells" && k + 1 < argc)
      subcells = std::stoi(argv[++k]);
    else if (a == "--levels" && k + 1 < argc)
      levels = std::stoi(argv[++k]);
    else if (a == "--k-scan")
      k_scan = true;
    else if (a == "--search-scan")
      search_scan = true;
    else if (a == "--no-skin-by-speed")
      skin_by_speed = false;
    else if (a == "--checkpoint" && k + 1 < argc)
      checkpoint_dir = argv[++k];
    else if (a == "--threads" && k + 1 < argc)
      set_thread_count(std::max(1, std::stoi(argv[++k])));
    else {
      std::fprintf(stderr, "bench_step: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  try {
    SceneConfig scene = scene_from_particle_file(argv[1], steps);
    scene.search.skin_by_speed = skin_by_speed;
    if (skin_dmin) {
      double d_min = 1e300;
      for (const ParticleSpec& p : read_particle_file(argv[1]).particles)
        d_min = std::min(d_min, p.diameter_m);
      scene.search.skin_m = *skin_dmin * d_min;
    }
    if (k_scan) {
      std::vector<double> seconds;
      for (int k = 1; k <= 8; ++k) {
        scene.search.subcells_per_axis = k;
        Simulation sim(scene);
        const auto start = std::chrono::steady_clock::now();
        sim.advance(steps);
        seconds.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      }
      const double best = *std::min_element(seconds.begin(), seconds.end());
      std::printf("| k | seconds per step | normalised |\n| --- | --- | --- |\n");
      for (int k = 1; k <= 8; ++k)
        std::printf("| %d | %.4e | %.2f |\n", k, seconds[k - 1] / double(steps),
                    seconds[k - 1] / best);
      return 0;
    }
    scene.search.subcells_per_axis = subcells;
    scene.search.grid_levels = levels;
    const long rss_before = resident_kib();
    Simulation sim(scene);
    const double ke0 = sim.energy().kinetic_j;
    const auto neighbor_before = sim.neighbors().stats();
    const std::uint64_t team_loops_before = loops_run_on_team();
    const auto start = std::chrono::steady_clock::now();
    if (auto failure = sim.advance(steps)) {
      std::fprintf(stderr, "bench_step: %s\n", failure->detail.c_str());
      return 3;
    }
    const std::uint64_t contact_steps = sim.contact_steps();
    const double loop_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (search_scan) {
      print_search_scan(sim);
      return 0;
    }
    const long rss_after = resident_kib();
    const std::size_t n = sim.particles().size();
    const auto& ns = sim.neighbors().stats();
    nlohmann::ordered_json out;
    out["scene"] = scene.name;
    out["particles"] = n;
    out["steps"] = steps;
    out["time_step_s"] = sim.time_step().step_s;
    out["loop_seconds"] = loop_s;
    out["particle_steps_per_second"] = double(n) * double(steps) / loop_s;
    out["threads"] = thread_count();
    out["loops_on_team_per_step"] = double(loops_run_on_team() - team_loops_before) / double(steps);
    // The threaded force pass's seconds of work per owner (waits left out), over the whole run.
    out["force_pass_owner_work_s"] = sim.neighbors().owner_balance.total_work_s();
    out["neighbor_rebuilds"] = ns.rebuilds - neighbor_before.rebuilds;
    out["skin_m"] = sim.neighbors().skin_m();
    out["distance_tests_per_contact"] = double(ns.distance_tests - neighbor_before.distance_tests) /
                                        double(std::max<std::uint64_t>(1, contact_steps));
    out["candidate_pairs"] = sim.neighbors().pairs.size();
    out["subcells_per_axis"] = ns.last_search.subcells_per_axis;
    out["fine_particles"] = ns.last_search.fine_particles;
    out["grid_levels"] = ns.last_search.levels;
    out["level_particles"] = std::vector<std::uint64_t>(
        ns.last_search.level_particles, ns.last_search.level_particles + ns.last_search.levels);
    out["candidates_per_contact"] =
        double(sim.neighbors().pairs.size()) /
        double(std::max<std::uint64_t>(1, sim.contact_stats().touching_pairs));
    out["resident_bytes_per_particle"] = 1024.0 * double(rss_after - rss_before) / double(n);
    nlohmann::ordered_json phases;
    for (std::size_t k = 0; k < kPhaseNames.size(); ++k)
      phases[std::string(kPhaseNames[k])] = sim.profile().seconds[k];
    out["phase_seconds"] = phases;
    if (!checkpoint_dir.empty()) {
      // The cost of a checkpoint of this state: archive, write with fsync, read back, restore.
      using Clock = std::chrono::steady_clock;
      auto seconds_since = [](Clock::time_point t) {
        return std::chrono::duration<double>(Clock::now() - t).count();
      };
      auto t = Clock::now();
      ArchiveWriter w;
      sim.checkpoint_io(w);
      const double archive_s = seconds_since(t);
      t = Clock::now();
      const CheckpointHeader header{"bench",      "", checkpoint_layout(), 0, sim.step_index(),
                                    sim.time_s(), 0.0};
      const std::filesystem::path file = write_checkpoint(checkpoint_dir, header, w.data(), 1);
      const double write_s = seconds_since(t);
      t = Clock::now();
      Checkpoint back = read_checkpoint(file);
      ArchiveReader r(back.state.data(), back.state.size());
      sim.checkpoint_io(r);
      const double restore_s = seconds_since(t);
      const double gb = double(w.data().size()) / 1e9;
      out["checkpoint"] = {
          {"bytes", w.data().size()},
          {"bytes_per_particle", double(w.data().size()) / double(n)},
          {"archive_s", archive_s},
          {"write_fsync_s", write_s},
          {"read_restore_s", restore_s},
          {"save_s_per_gb", (archive_s + write_s) / gb},
          {"step_seconds_equivalent", (archive_s + write_s) / (loop_s / double(steps))}};
      remove_checkpoints(checkpoint_dir);
    }
    out["kinetic_energy_ratio"] = sim.energy().kinetic_j / ke0;
    out["contacts_final"] = sim.contact_stats().touching_pairs;
    if (as_json) {
      std::cout << out.dump(2) << "\n";
    } else {
      for (const auto& [key, value] : out.items()) std::cout << key << ": " << value.dump() << "\n";
    }
    return 0;
  } catch (const InputErrorList& e) {
    std::fprintf(stderr, "%s\n", format_input_errors(argv[1], e.errors()).c_str());
    return 2;
  } catch (const IoError& e) {
    std::fprintf(stderr, "bench_step: %s\n", e.what());
    return 4;
  }
}
