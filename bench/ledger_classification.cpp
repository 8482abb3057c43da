// The dust ledger's classification in a mill (issue 31): the scene's gas is spun up (or read
// from a spin-up cache), then frozen, and dust of every size from 0.25 to 16 µm is fed at a
// steady rate into the grinding zone (the fluid cells beyond 3/4 of the mill's radius, where
// the jets break the particles) and carried by the ledger alone, no particles. Over the last
// third of the window the grade efficiency of each size is what left through the outlet over
// what was fed then; its 50 % size is set against the force-balance cut at the outlet radius
// that the run's `mill` section reports (process/classification.h).
//
//   ledger_classification SCENE.json [--window-s 0.06] [--cache DIR]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dust/dust_ledger.h"
#include "gas/drag.h"
#include "process/classification.h"
#include "scene/scene_json.h"
#include "sim/gas_spin_up.h"
#include "sim/simulation.h"

using namespace millsim;

namespace {

struct Options {
  std::string scene;
  double window_s = 0.06;
  std::string cache;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--window-s") && i + 1 < argc) {
      o.window_s = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--cache") && i + 1 < argc) {
      o.cache = argv[++i];
    } else {
      o.scene = argv[i];
    }
  }
  if (o.scene.empty() || !(o.window_s > 0.0)) {
    std::fprintf(stderr, "usage: ledger_classification SCENE.json [--window-s S] [--cache DIR]\n");
    std::exit(2);
  }
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  SceneConfig scene = load_scene(options.scene);
  if (!scene.gas || !scene.mill) {
    std::fprintf(stderr, "%s: a scene with a gas and a mill is needed\n", options.scene.c_str());
    return 2;
  }
  double density = 0.0;
  for (const MaterialConfig& m : scene.materials)
    if (m.breakage) density = m.density_kg_per_m3;
  // The gas alone: no particles (the feeds stay, for the step they set, but never start).
  scene.sources.clear();
  for (FeedConfig& feed : scene.feeds) feed.start_s = 1e299;
  Simulation sim(scene, SimulationStart::AfterSpinUp);
  SpinUpOptions spin;
  spin.cache_dir = options.cache;
  std::ifstream file(options.scene);
  std::stringstream text;
  text << file.rdbuf();
  spin.scene_text = text.str();  // the cache key
  const SpinUpReport report = run_gas_spin_up(sim, spin);
  std::printf("gas spin-up: %s, %.1f s\n", report.source.c_str(), report.wall_s);

  const GasCoupling& coupling = *sim.gas();
  const GasView gas = coupling.view();
  const GasGrid& grid = gas.grid();
  const MillConfig& mill = *scene.mill;
  const GasConfig& config = *scene.gas;
  const double mean_free_path = dust_mean_free_path_m(config);
  std::vector<DustClass> classes;
  for (int k = 0; k <= 16; ++k) {
    const double d = 0.25e-6 * std::pow(2.0, 0.375 * k);  // 0.25 to 16 µm
    const double slip = mean_free_path > 0.0 ? cunningham_correction(d, mean_free_path) : 1.0;
    classes.push_back({d, density * d * d * slip / (18.0 * config.viscosity_pa_s)});
  }
  DustLedger dust(grid, classes, scene.gravity_m_per_s2);

  std::vector<Vec3> zone;  // the grinding zone's fluid cells
  for (int k = 1; k <= grid.n[2]; ++k)
    for (int j = 1; j <= grid.n[1]; ++j)
      for (int i = 1; i <= grid.n[0]; ++i) {
        const Vec3 x = grid.cell_center(i, j, k);
        const Vec3 r = x - mill.axis_point_m;
        if (grid.fluid[grid.index(i, j, k)] && std::hypot(r.x, r.y) >= 0.75 * mill.radius_m)
          zone.push_back(x);
      }
  const double rate_kg_per_s = 1e-6;  // per class; the ledger is linear in it
  const double dt = 1e-4;
  const int steps = int(std::lround(options.window_s / dt)), last_third = steps - steps / 3;
  std::vector<double> out_at_start(classes.size(), 0.0);
  for (int step = 0; step < steps; ++step) {
    if (step == last_third)
      for (std::size_t k = 0; k < classes.size(); ++k) out_at_start[k] = dust.outflow_kg(int(k));
    for (const Vec3& x : zone)
      for (int k = 0; k < int(classes.size()); ++k)
        dust.deposit(x, k, rate_kg_per_s * dt / double(zone.size()));
    dust.advance(gas, dt);
  }
  const double fed_last = rate_kg_per_s * dt * (steps - last_third);

  const double rho_g =
      gas.density_at(mill.axis_point_m +
                     Vec3{mill.outlet.radius_m, 0.0, 0.5 * (mill.height_m - mill.outlet.depth_m)});
  const VortexSample v =
      sample_vortex(gas, mill, mill.outlet.radius_m, 0.0, mill.height_m - mill.outlet.depth_m);
  const double cut = force_balance_cut_size_m(config.viscosity_pa_s, density, rho_g, v);
  std::printf("outlet radius %.1f mm: u_t %.1f m/s, u_r %.1f m/s, force-balance cut %.2f um\n",
              v.radius_m * 1e3, v.tangential_m_per_s, v.radial_m_per_s, cut * 1e6);
  std::printf("window %.0f ms (%d steps of %.0f us, %llu sub-steps), grinding zone %zu cells\n",
              options.window_s * 1e3, steps, dt * 1e6, (unsigned long long)dust.stats().substeps,
              zone.size());
  std::printf(
      "| d (um) | tau (us) | T over the last third | held / fed |\n| --- | --- | --- | --- |\n");
  std::vector<double> share(classes.size());
  for (std::size_t k = 0; k < classes.size(); ++k) {
    share[k] = (dust.outflow_kg(int(k)) - out_at_start[k]) / fed_last;
    std::printf("| %.2f | %.3g | %.3f | %.3f |\n", classes[k].diameter_m * 1e6,
                classes[k].relaxation_time_s * 1e6, share[k],
                dust.held_kg(int(k)) / (rate_kg_per_s * dt * steps));
  }
  for (std::size_t k = 1; k < classes.size(); ++k)
    if (share[k - 1] >= 0.5 && share[k] < 0.5) {
      const double f = (share[k - 1] - 0.5) / (share[k - 1] - share[k]);
      const double d50 = classes[k - 1].diameter_m *
                         std::pow(classes[k].diameter_m / classes[k - 1].diameter_m, f);
      std::printf("ledger's 50 %% size %.2f um, %.2f x the force-balance cut\n", d50 * 1e6,
                  d50 / cut);
    }
  return 0;
}
