#include "sim/run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>

#include "checkpoint/checkpoint_file.h"
#include "core/build_info.h"
#include "gas/pressure_probe.h"
#include "geometry/surface_mesh.h"
#include "io/h5_writer.h"
#include "io/json_text.h"
#include "io/text_file.h"
#include "parallel/thread_team.h"
#include "process/classification.h"
#include "process/dust_exit_load.h"
#include "process/feed.h"
#include "process/holdup_fill.h"
#include "process/holdup_history.h"
#include "process/impact_spectrum_plot.h"
#include "process/mass_flows.h"
#include "process/steady_projection.h"
#include "sim/run_eta.h"

namespace millsim {
namespace {

// The share of class k's (fluid cell, advance) slips the dust speed bound shortened.
double speed_bounded_share(const DustLedger& dust, int k) {
  const double seen = double(dust.stats().advances) * double(dust.fluid_cell_count());
  return seen > 0.0 ? double(dust.stats().speed_bounded_cells[std::size_t(k)]) / seen : 0.0;
}

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The run's product columns exist only when the scene has outlets, feeds or breakage.
bool has_product(const Simulation& sim) {
  return sim.breakage() || !sim.feeders().empty() || !sim.outlet_mass_by_outlet_kg().empty();
}

struct TimeSeries {
  std::vector<std::string> names = {
      "time_s",         "kinetic_j", "rotational_j",  "potential_j",   "elastic_j",
      "total_energy_j", "particles", "contact_pairs", "wall_contacts", "max_overlap_ratio"};
  bool product = false;
  std::vector<std::vector<double>> columns;

  std::vector<PressureDropConfig> drops;  // one column each, after the product's
  // With a dust ledger: its first column (held, out, then held and out per class), else 0.
  std::size_t dust_column = 0;

  TimeSeries(bool with_product, const Simulation& sim) : product(with_product) {
    if (product)
      for (const char* name : {"fed_mass_kg", "outlet_mass_kg", "dust_mass_kg", "breakage_events"})
        names.push_back(name);
    if (const DustLedger* dust = sim.dust_ledger()) {
      dust_column = names.size();
      names.push_back("dust_held_kg");
      names.push_back("dust_outflow_kg");
      for (int k = 0; k < dust->class_count(); ++k) {
        names.push_back(concat("dust_held_c", k < 10 ? "0" : "", k, "_kg"));
        names.push_back(concat("dust_outflow_c", k < 10 ? "0" : "", k, "_kg"));
      }
    }
    if (sim.gas()) drops = sim.gas()->config().pressure_drops;
    // The gas is solved every CFD step: a drop is that of the last solve, at gas_time_s.
    if (!drops.empty()) names.push_back("gas_time_s");
    for (const PressureDropConfig& d : drops) names.push_back(pressure_drop_column(d));
    columns.resize(names.size());
  }

  static std::string pressure_drop_column(const PressureDropConfig& d) {
    return "pressure_drop_" + d.name + "_pa";
  }

  void record(const Simulation& sim) {
    const EnergyReport e = sim.energy();
    const ContactStepStats& c = sim.contact_stats();
    std::vector<double> row = {sim.time_s(),
                               e.kinetic_j,
                               e.rotational_j,
                               e.potential_j,
                               e.elastic_j,
                               e.total_j(),
                               double(sim.particles().size()),
                               double(c.touching_pairs),
                               double(c.touching_walls),
                               c.max_overlap_ratio};
    if (product) {
      const MassBalance m = sim.mass_balance();
      row.insert(row.end(), {m.fed_kg, m.outlet_kg, m.dust_kg,
                             sim.breakage() ? double(sim.breakage()->stats().events) : 0.0});
    }
    if (const DustLedger* dust = sim.dust_ledger()) {
      row.insert(row.end(), {dust->held_kg(), dust->outflow_kg()});
      for (int k = 0; k < dust->class_count(); ++k)
        row.insert(row.end(), {dust->held_kg(k), dust->outflow_kg(k)});
    }
    if (!drops.empty()) row.push_back(sim.gas()->view().time_s());
    for (const PressureDropConfig& d : drops) row.push_back(pressure_drop_pa(sim.gas()->gas(), d));
    for (std::size_t k = 0; k < names.size(); ++k) columns[k].push_back(row[k]);
  }
};

// The window the steady state is judged over: the product window, or the run's last third.
std::array<double, 2> steady_window_s(const Simulation& sim, const SceneConfig& scene) {
  if (const auto& window = sim.product_window_s()) return *window;
  return {scene.time.end_s * (2.0 / 3.0), scene.time.end_s};
}

// The hold-up and what left, now (process/holdup_history.h).
HoldupRow holdup_row(const Simulation& sim) {
  const MassBalance m = sim.mass_balance();
  HoldupRow r;
  r.time_s = sim.time_s();
  r.fed_kg = m.initial_kg + m.fed_kg + m.filled_kg;  // a fill lies before the steady window
  r.particles_kg = m.particles_kg;
  r.outlet_kg = m.outlet_kg;
  r.dust_made_kg = m.dust_kg;
  if (const DustLedger* dust = sim.dust_ledger()) {
    r.dust_out_kg = dust->outflow_kg();
    r.dust_held_kg = dust->held_kg();
  }
  if (const Breakage* b = sim.breakage()) r.events_by_generation = b->stats().events_by_generation;
  // Under, classes, over: every kilogram in one list.
  auto by_class = [](const PsdTally& t) {
    std::vector<double> v{t.under_mass_kg};
    v.insert(v.end(), t.mass_kg.begin(), t.mass_kg.end());
    v.push_back(t.over_mass_kg);
    return v;
  };
  PsdTally held(sim.outlet_tally().edges_m);
  const ParticleStore& p = sim.particles();
  for (std::size_t i = 0; i < p.size(); ++i) held.add(2.0 * p.radius_m[i], p.mass_kg[i]);
  r.holdup_by_class_kg = by_class(held);
  if (const Breakage* b = sim.breakage()) r.dust_made_by_class_kg = by_class(b->dust());
  return r;
}

// Whether the run ended steady, over the product window or else its last third.
nlohmann::ordered_json steady_state_json(const Simulation& sim, const SceneConfig& scene,
                                         const std::vector<HoldupRow>& rows) {
  const std::array<double, 2> window = steady_window_s(sim, scene);
  const std::optional<SteadyWindow> w = steady_window(
      rows, window[0], window[1], sim.dust_ledger() != nullptr, sim.time_step().step_s);
  if (!w) return nullptr;
  nlohmann::ordered_json j = steady_window_json(*w);
  j["window_from"] = sim.product_window_s() ? "product_window_s" : "last third";
  return j;
}

// The gas's mass in the domain (the incompressible gas: its density over the fluid cells).
double gas_mass_kg(const GasCoupling& gas) {
  if (const CompressibleSolver* compressible = gas.compressible())
    return compressible->total_mass_kg();
  const GasGrid& grid = gas.grid();
  return gas.gas().density_kg_per_m3() * double(grid.fluid_cells) * grid.cell_volume_m3();
}

// The product (outlet particles + dust table) and where the mass went, for result.json.
void add_product_summary(const Simulation& sim, nlohmann::ordered_json& s) {
  const MassBalance m = sim.mass_balance();
  s["mass_balance"] = {{"initial_kg", m.initial_kg}, {"fed_kg", m.fed_kg}};
  if (m.filled_kg > 0.0) s["mass_balance"]["filled_kg"] = m.filled_kg;
  s["mass_balance"]["particles_kg"] = m.particles_kg;
  s["mass_balance"]["outlet_kg"] = m.outlet_kg;
  s["mass_balance"]["dust_kg"] = m.dust_kg;
  s["mass_balance"]["relative_error"] = m.relative_error();
  if (const Breakage* b = sim.breakage()) {
    const BreakageStats& st = b->stats();
    s["breakage"] = {{"dust_threshold_diameter_m", b->dust_threshold_m()},
                     {"impacts", st.impacts},
                     {"fatigue_impacts", st.fatigue_impacts},
                     {"events", st.events},
                     {"crush_events", st.crush_events},
                     {"events_by_generation", st.events_by_generation},
                     {"max_generation", st.max_generation},
                     {"fragments", st.fragments},
                     {"dust_fragments", st.dust_fragments},
                     {"broken_mass_kg", st.broken_mass_kg},
                     {"completed_impacts", st.completed_impacts},
                     {"dust_count", b->dust().total_count()},
                     {"dust_mass_kg", b->dust().total_mass_kg()}};
  }
  nlohmann::ordered_json feeds = nlohmann::ordered_json::array();
  for (const Feeder& f : sim.feeders())
    feeds.push_back({{"name", f.config().name},
                     {"inserted", f.stats().inserted},
                     {"inserted_mass_kg", f.stats().inserted_mass_kg},
                     {"blocked_steps", f.stats().blocked_steps}});
  if (!feeds.empty()) s["feeds"] = feeds;
  s["outlet_particles"] = {{"count", sim.outlet_tally().total_count()},
                           {"mass_kg", sim.outlet_tally().total_mass_kg()},
                           {"mass_by_outlet_kg", sim.outlet_mass_by_outlet_kg()}};
  if (const DustLedger* dust = sim.dust_ledger()) {
    nlohmann::ordered_json classes = nlohmann::ordered_json::array();
    for (int k = 0; k < dust->class_count(); ++k) {
      const DustClass& c = dust->classes()[std::size_t(k)];
      classes.push_back({{"diameter_m", c.diameter_m},
                         {"relaxation_time_s", c.relaxation_time_s},
                         {"held_kg", dust->held_kg(k)},
                         {"outflow_kg", dust->outflow_kg(k)},
                         {"max_slip_m_per_s", dust->stats().max_slip_m_per_s[std::size_t(k)]},
                         {"speed_bounded_share", speed_bounded_share(*dust, k)}});
    }
    // In: the dust made, and what a hold-up fill added.
    const double made = sim.breakage()->dust().total_mass_kg(), in = made + dust->filled_kg();
    s["dust_ledger"] = {
        {"made_kg", made},
        {"held_kg", dust->held_kg()},
        {"outflow_kg", dust->outflow_kg()},
        {"relative_error", in > 0.0 ? (dust->held_kg() + dust->outflow_kg() - in) / in : 0.0},
        {"deposits", dust->stats().deposits},
        {"displaced_deposits", dust->stats().displaced_deposits},
        {"advances", dust->stats().advances},
        {"substeps", dust->stats().substeps},
        {"carry_courant", sim.dust_carry_courant()},
        {"gas_coupling", sim.dust_two_way() ? "two_way" : "one_way"},
        {"max_cell_mass_loading", sim.dust_max_cell_loading()},
        {"mass_loading", dust->held_kg() / gas_mass_kg(*sim.gas())},
        {"classes", classes}};
    if (dust->filled_kg() > 0.0) s["dust_ledger"]["filled_kg"] = dust->filled_kg();
    if (const DustGrinding* grinding = sim.dust_grinding()) {
      double ground = 0.0;
      for (double kg : grinding->stats().ground_kg) ground += kg;
      s["dust_ledger"]["grinding"] = {{"model", "sweep"},
                                      {"passes", grinding->stats().passes},
                                      {"ground_kg", ground},
                                      {"ground_by_class_kg", grinding->stats().ground_kg}};
    }
  }
  if (const auto& window = sim.product_window_s()) s["product_window_s"] = *window;
  s["outlet_psd"] = psd_json(summarize(sim.product_tally()));
  // Everything made so far: the product plus the hold-up still in the domain. Runs that end
  // before the hold-up has left compare fairly on this one.
  PsdTally all = sim.product_tally();
  const ParticleStore& p = sim.particles();
  for (std::size_t i = 0; i < p.size(); ++i) all.add(2.0 * p.radius_m[i], p.mass_kg[i]);
  if (const DustLedger* dust = sim.dust_ledger())  // the dust still in the gas
    for (int k = 0; k < dust->class_count(); ++k)
      all.add(dust->classes()[std::size_t(k)].diameter_m, dust->held_kg(k), 0.0);
  const PsdSummary total = summarize(all);
  s["total_psd"] = {{"d10_m", psd_size_json(total, total.d10_m)},
                    {"d50_m", psd_size_json(total, total.d50_m)},
                    {"d90_m", psd_size_json(total, total.d90_m)},
                    {"total_mass_kg", total.total_mass_kg},
                    {"cumulative_mass", total.cumulative_mass}};
}

void write_psd_h5(const Simulation& sim, H5Writer& h5) {
  const PsdTally& outlet = sim.outlet_tally();
  const PsdTally dust = sim.breakage() ? sim.breakage()->dust() : PsdTally(outlet.edges_m);
  const PsdSummary product = summarize(sim.product_tally());
  h5.write_columns("/psd",
                   {"edges_m", "outlet_count", "outlet_mass_kg", "dust_count", "dust_mass_kg",
                    "product_cumulative_mass"},
                   {outlet.edges_m, outlet.count, outlet.mass_kg, dust.count, dust.mass_kg,
                    product.cumulative_mass});
}

// What the simulated vortex says about classification: the force-balance cut size at the outlet
// radius (between floor and tube mouth) and at nine radii out to the mantle, and the nozzles'
// flows (process/classification.h).
nlohmann::ordered_json mill_gas_json(const GasCoupling& gas, const MillConfig& mill,
                                     double particle_density_kg_per_m3, const GradeEfficiency& g) {
  const GasView view = gas.view();
  const double mu = gas.config().viscosity_pa_s;
  // The gas density at the outlet radius half-way up (the compressible model's varies).
  const double rho_g =
      view.density_at(mill.axis_point_m +
                      Vec3{mill.outlet.radius_m, 0.0, 0.5 * (mill.height_m - mill.outlet.depth_m)});
  const VortexSample v =
      sample_vortex(view, mill, mill.outlet.radius_m, 0.0, mill.height_m - mill.outlet.depth_m);
  const double x_c = force_balance_cut_size_m(mu, particle_density_kg_per_m3, rho_g, v);
  nlohmann::ordered_json m;
  m["force_balance"] = {{"radius_m", v.radius_m},
                        {"tangential_gas_m_per_s", v.tangential_m_per_s},
                        {"radial_gas_m_per_s", v.radial_m_per_s},
                        {"particle_density_kg_per_m3", particle_density_kg_per_m3},
                        {"cut_size_m", x_c}};
  if (g.cut_size_m && x_c > 0.0) m["cut_size_ratio"] = *g.cut_size_m / x_c;
  if (g.reduced_cut_size_m && x_c > 0.0) m["reduced_cut_size_ratio"] = *g.reduced_cut_size_m / x_c;
  nlohmann::ordered_json profile = nlohmann::ordered_json::array();
  std::vector<VortexSample> samples;
  for (int k = 0; k <= 8; ++k) {
    const double r = mill.outlet.radius_m + (mill.radius_m - mill.outlet.radius_m) * k / 8.5;
    const VortexSample p = sample_vortex(view, mill, r, 0.0, mill.height_m);
    samples.push_back(p);
    profile.push_back({{"radius_m", r},
                       {"tangential_gas_m_per_s", p.tangential_m_per_s},
                       {"radial_gas_m_per_s", p.radial_m_per_s},
                       {"force_balance_cut_size_m",
                        force_balance_cut_size_m(mu, particle_density_kg_per_m3, rho_g, p)}});
  }
  m["vortex_profile"] = profile;
  // u_t r^n = const: from the outlet radius to the mantle, and outside the fastest sample (a
  // free-type vortex's region, past its core).
  std::size_t peak = 0;
  for (std::size_t k = 1; k < samples.size(); ++k)
    if (samples[k].tangential_m_per_s > samples[peak].tangential_m_per_s) peak = k;
  const auto exponent_json = [](const VortexExponent& e) -> nlohmann::ordered_json {
    if (e.points < 2) return nullptr;
    return {{"n", e.n},
            {"from_radius_m", e.from_radius_m},
            {"to_radius_m", e.to_radius_m},
            {"points", e.points}};
  };
  m["vortex_exponent"] = {
      {"outlet_to_mantle", exponent_json(vortex_exponent(samples, 0, samples.size() - 1))},
      {"outside_peak", exponent_json(vortex_exponent(samples, peak, samples.size() - 1))}};
  nlohmann::ordered_json jets = nlohmann::ordered_json::array();
  const GasGrid& grid = gas.grid();
  if (const CompressibleSolver* c = gas.compressible()) {
    for (std::size_t k = 0; k < gas.config().jets.size(); ++k) {
      const GasJetConfig& jet = gas.config().jets[k];
      const NozzleExit& e = c->jets()[k];
      nlohmann::ordered_json j = {{"name", jet.name},
                                  {"faces", grid.jet_faces[k]},
                                  {"throat_diameter_m", 2.0 * jet.radius_m},
                                  {"mass_flow_kg_per_s", e.mass_flow_kg_per_s},
                                  {"speed_m_per_s", e.speed_m_per_s},
                                  {"mach", e.mach},
                                  {"temperature_k", e.temperature_k}};
      if (jet.supply_pressure_pa) {
        j["supply_pressure_pa"] = *jet.supply_pressure_pa;
        j["choked"] = e.choked;
        j["throat_speed_m_per_s"] = e.throat_speed_m_per_s;
        j["throat_pressure_pa"] = e.throat_pressure_pa;
        j["notional_diameter_m"] = std::sqrt(4.0 * e.area_m2 / std::numbers::pi);
      }
      jets.push_back(j);
    }
    m["nozzles"] = jets;
    return m;
  }
  for (std::size_t k = 0; k < gas.config().jets.size(); ++k) {
    GasJetConfig jet = gas.config().jets[k];
    jet.speed_m_per_s = gas.gas().jet_speed_m_per_s(k);  // now, if it follows a schedule
    jets.push_back({{"name", jet.name},
                    {"faces", grid.jet_faces[k]},
                    {"speed_m_per_s", jet.speed_m_per_s},
                    {"set_flow_m3_per_s", jet.volume_flow_m3_per_s()},
                    {"grid_flow_m3_per_s", grid.jet_flow_m3_per_s[k]}});
  }
  m["nozzles"] = jets;
  return m;
}

// The mill's classification: the grade efficiency of the run (outlet against hold-up) and, with
// gas, the cut sizes the simulated vortex gives.
void add_mill_summary(const Simulation& sim, nlohmann::ordered_json& s) {
  PsdTally retained(sim.outlet_tally().edges_m);
  const ParticleStore& p = sim.particles();
  for (std::size_t i = 0; i < p.size(); ++i) retained.add(2.0 * p.radius_m[i], p.mass_kg[i]);
  const GradeEfficiency g = grade_efficiency(sim.outlet_tally(), retained);
  const auto optional_json = [](const std::optional<double>& v) {
    return v ? nlohmann::ordered_json(*v) : nlohmann::ordered_json();
  };
  nlohmann::ordered_json m = {{"grade_efficiency",
                               {{"size_m", g.size_m},
                                {"outlet_kg", g.outlet_kg},
                                {"retained_kg", g.retained_kg},
                                {"share_to_outlet", g.share_to_outlet}}},
                              {"cut_size_m", optional_json(g.cut_size_m)},
                              {"largest_share_to_outlet", g.max_share},
                              {"reduced_cut_size_m", optional_json(g.reduced_cut_size_m)}};
  if (const GasCoupling* gas = sim.gas()) {
    const int material = sim.feeders().empty() ? 0 : sim.feeders().front().config().material;
    m.update(
        mill_gas_json(*gas, *sim.mill(), sim.materials().material(material).density_kg_per_m3, g));
  }
  s["mill"] = m;
}

// The pressure drops' time series (GasConfig::pressure_drops), for result.json.
nlohmann::ordered_json pressure_drops_json(const Simulation& sim, const TimeSeries& series) {
  const GasConfig& config = sim.gas()->config();
  const auto end = [&](const PressurePlane& p) -> nlohmann::ordered_json {
    if (p.patch >= 0) return config.boundaries[std::size_t(p.patch)].name;
    return {{"axis", std::string(1, char('x' + p.axis))}, {"at_m", p.at_m}};
  };
  const auto column = [&](const std::string& name) -> const std::vector<double>& {
    return series.columns[std::size_t(std::find(series.names.begin(), series.names.end(), name) -
                                      series.names.begin())];
  };
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const PressureDropConfig& d : series.drops) {
    out.push_back({{"name", d.name},
                   {"from", end(d.from)},
                   {"to", end(d.to)},
                   {"time_s", series.columns[0]},
                   {"gas_time_s", column("gas_time_s")},
                   {"drop_pa", column(TimeSeries::pressure_drop_column(d))}});
  }
  return out;
}

std::vector<double> components(const Vec3& v) {
  return {v.x, v.y, v.z};
}

// What the coupling did, for either gas model: the volume fraction's range, the drag cache and the
// impulse balance, where the time went (gas solve, deposit, fluid forces, the rest of the DEM).
nlohmann::ordered_json coupling_summary(const Simulation& sim) {
  const GasCoupling& g = *sim.gas();
  const CouplingStats& c = g.stats();
  const std::uint64_t lookups = c.drag_evaluations + c.drag_reuses;
  const std::array<double, std::size_t(Phase::Count)>& t = sim.profile().seconds;
  const double gas_s = t[std::size_t(Phase::Gas)], fluid_s = t[std::size_t(Phase::Fluid)];
  return {
      {"cfd_steps", c.cfd_steps},
      {"gas_substeps", c.gas_substeps},
      {"spin_up_steps", c.spin_up_steps},
      {"dem_steps_per_cfd_step",
       {{"last", c.steps_per_cfd}, {"min", c.min_steps_per_cfd}, {"max", c.max_steps_per_cfd}}},
      {"min_volume_fraction", c.min_volume_fraction},
      {"clamped_cell_steps", c.clamped_cells},
      {"unplaced_deposits", c.unplaced_deposits},
      {"drag_cache_threshold", g.config().cache_threshold},
      {"drag_evaluations", c.drag_evaluations},
      {"drag_reuses", c.drag_reuses},
      {"drag_evaluation_fraction", lookups ? double(c.drag_evaluations) / double(lookups) : 0.0},
      {"dem_cell_states_filled", g.table().fills()},
      {"particle_impulse_n_s", components(c.particle_impulse_n_s)},
      {"seconds",
       {{"gas_solve", c.gas_seconds},
        {"deposit", c.deposit_seconds},
        {"fluid_forces", fluid_s},
        {"dem", sim.profile().total() - gas_s - fluid_s}}}};
}

// The incompressible model's gas: its patches' inflow, the pressure solve, the continuity error.
void add_incompressible_gas_summary(const Simulation& sim, nlohmann::ordered_json& s) {
  const GasCoupling& g = *sim.gas();
  const GasStepStats& gs = g.gas().stats();
  nlohmann::ordered_json patches = nlohmann::ordered_json::array();
  const GasGrid& grid = g.gas().grid();
  for (std::size_t k = 0; k < g.config().boundaries.size(); ++k) {
    const GasBoundaryPatch& b = g.config().boundaries[k];
    const Vec3 inflow = g.gas().inlet_velocity_m_per_s(k);  // now, if it follows a schedule
    const double normal_speed = inflow[b.face / 2] * (b.face % 2 == 0 ? 1.0 : -1.0);
    patches.push_back(
        {{"name", b.name},
         {"faces", grid.patch_faces[k]},
         {"area_m2", grid.patch_area_m2[k]},
         {"inflow_m3_per_s",
          b.kind == GasBoundaryKind::Inlet ? normal_speed * grid.patch_area_m2[k] : 0.0}});
  }
  s["gas"] = {{"cells", g.config().cells},
              {"boundaries", patches},
              {"fluid_cells", grid.fluid_cells},
              {"pressure_iterations_mean",
               gs.steps ? double(gs.pressure_iterations) / double(gs.steps) : 0.0},
              {"max_pressure_residual", gs.max_pressure_residual},
              {"max_continuity_error_m3_per_s", g.gas().max_continuity_error_m3_per_s()},
              {"pressure_matrix_builds", gs.matrix_builds},
              {"gas_received_impulse_n_s", components(g.gas().received_impulse_n_s())}};
  s["gas"].update(coupling_summary(sim));
}

// The compressible model's gas: its mass, pressure range and fastest Mach number, the mass flow
// through each patch and the jets, and the range of slip Mach and Knudsen numbers the drag met.
void add_compressible_gas_summary(const Simulation& sim, nlohmann::ordered_json& s) {
  const GasCoupling& g = *sim.gas();
  const CompressibleSolver& gas = *g.compressible();
  const CouplingStats& c = g.stats();
  const GasGrid& grid = gas.grid();
  nlohmann::ordered_json patches = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < g.config().boundaries.size(); ++k)
    patches.push_back({{"name", g.config().boundaries[k].name},
                       {"faces", grid.patch_faces[k]},
                       {"area_m2", grid.patch_area_m2[k]},
                       {"mass_inflow_kg_per_s", gas.patch_inflow_kg_per_s()[k]}});
  double p_min = 1e300, p_max = 0.0, mach_max = 0.0;
  for (std::size_t cell = 0; cell < grid.padded_size; ++cell) {
    if (!grid.fluid[cell]) continue;
    p_min = std::min(p_min, gas.pressure_pa(cell));
    p_max = std::max(p_max, gas.pressure_pa(cell));
    mach_max = std::max(mach_max, gas.mach(cell));
  }
  double jets_in = 0.0;
  for (double m : gas.jet_inflow_kg_per_s()) jets_in += m;
  s["gas"] = {{"model", "compressible"},
              {"cells", g.config().cells},
              {"boundaries", patches},
              {"jets_mass_inflow_kg_per_s", jets_in},
              {"fluid_cells", grid.fluid_cells},
              {"mass_kg", gas.total_mass_kg()},
              {"min_pressure_pa", p_min},
              {"max_pressure_pa", p_max},
              {"max_mach", mach_max},
              {"gas_steps", gas.steps()},
              {"slip_correction", g.config().slip_correction ? "cunningham" : "none"},
              {"max_slip_mach", c.max_slip_mach},
              {"max_knudsen", c.max_knudsen},
              {"drag_evaluations_past_mach_0_3", c.drag_evaluations_past_mach_0_3},
              {"mach_correction", g.config().mach_correction ? "loth" : "none"},
              {"max_mach_drag_factor", c.max_mach_drag_factor},
              {"gas_received_impulse_n_s", components(gas.received_impulse_n_s())}};
  if (sim.dust_two_way()) {
    s["gas"]["dust_impulse_n_s"] = components(gas.dust_impulse_n_s());
    s["gas"]["dust_work_j"] = gas.dust_work_j();
  }
  s["gas"].update(coupling_summary(sim));
}

// The gas solver and the coupling, for result.json's `gas` section.
void add_gas_summary(const Simulation& sim, nlohmann::ordered_json& s) {
  if (sim.gas()->compressible())
    add_compressible_gas_summary(sim, s);
  else
    add_incompressible_gas_summary(sim, s);
}

// The final gas field at the fluid cell centres, as columns under /gas in run.h5.
void write_gas_h5(const Simulation& sim, H5Writer& h5) {
  const GasView gas = sim.gas()->view();
  const GasGrid& g = gas.grid();
  std::vector<std::vector<double>> cols(8);
  for (int k = 1; k <= g.n[2]; ++k)
    for (int j = 1; j <= g.n[1]; ++j)
      for (int i = 1; i <= g.n[0]; ++i) {
        const std::size_t c = g.index(i, j, k);
        if (!g.fluid[c]) continue;
        const Vec3 x = g.cell_center(i, j, k), u = gas.velocity_at(x);
        const double row[8] = {x.x, x.y, x.z, gas.cell_pressure_pa(c), gas.cell_volume_fraction(c),
                               u.x, u.y, u.z};
        for (std::size_t col = 0; col < 8; ++col) cols[col].push_back(row[col]);
      }
  h5.write_columns("/gas",
                   {"x_m", "y_m", "z_m", "pressure_pa", "volume_fraction", "velocity_x_m_per_s",
                    "velocity_y_m_per_s", "velocity_z_m_per_s"},
                   cols);
}

// The gas field at the cell centres for a snapshot (solid cells: zero velocity, fluid = 0).
GasFieldSnapshot gas_field(const GasView& gas, const DustLedger* dust) {
  const GasGrid& g = gas.grid();
  GasFieldSnapshot f;
  f.cells = {g.n[0], g.n[1], g.n[2]};
  f.origin_m = g.origin_m;
  f.spacing_m = g.h_m;
  const std::size_t n = std::size_t(g.n[0]) * std::size_t(g.n[1]) * std::size_t(g.n[2]);
  f.velocity_m_per_s.reserve(n), f.pressure_pa.reserve(n), f.volume_fraction.reserve(n);
  f.fluid.reserve(n);
  for (int k = 1; k <= g.n[2]; ++k)
    for (int j = 1; j <= g.n[1]; ++j)
      for (int i = 1; i <= g.n[0]; ++i) {
        const std::size_t c = g.index(i, j, k);
        const bool fluid = g.fluid[c] != 0;
        f.velocity_m_per_s.push_back(fluid ? gas.velocity_at(g.cell_center(i, j, k)) : Vec3{});
        f.pressure_pa.push_back(fluid ? gas.cell_pressure_pa(c) : 0.0);
        f.volume_fraction.push_back(fluid ? gas.cell_volume_fraction(c) : 0.0);
        f.fluid.push_back(fluid ? 1 : 0);
        if (const CompressibleSolver* compressible = gas.compressible) {
          f.density_kg_per_m3.push_back(fluid ? compressible->density_kg_per_m3(c) : 0.0);
          f.temperature_k.push_back(fluid ? compressible->temperature_k(c) : 0.0);
          f.mach.push_back(fluid ? compressible->mach(c) : 0.0);
        }
      }
  if (dust) {
    f.dust_kg_per_m3.resize(std::size_t(dust->class_count()));
    for (int m = 0; m < dust->class_count(); ++m) {
      std::vector<double>& field = f.dust_kg_per_m3[std::size_t(m)];
      field.reserve(n);
      for (int k = 1; k <= g.n[2]; ++k)
        for (int j = 1; j <= g.n[1]; ++j)
          for (int i = 1; i <= g.n[0]; ++i)
            field.push_back(dust->cell_mass_kg(m)[g.index(i, j, k)] / g.cell_volume_m3());
    }
  }
  return f;
}

// The partner of an impact group: a material's name, or a wall's.
const std::string& impact_partner_name(const ImpactGroup& g, const Simulation& sim,
                                       const SceneConfig& scene) {
  return g.with_wall ? sim.walls()[std::size_t(g.partner)].name
                     : scene.materials[std::size_t(g.partner)].name;
}

// "particle-particle salt/salt", "particle-wall salt/mantle": who met whom.
std::string impact_group_name(const ImpactGroup& g, const Simulation& sim,
                              const SceneConfig& scene) {
  return std::string(g.with_wall ? "particle-wall " : "particle-particle ") +
         scene.materials[std::size_t(g.material)].name + "/" + impact_partner_name(g, sim, scene);
}

// [size class][energy bin] as rows.
nlohmann::ordered_json count_rows(const std::vector<std::uint64_t>& counts, std::size_t bins) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (std::size_t at = 0; at < counts.size(); at += bins)
    rows.push_back(std::vector<std::uint64_t>(counts.begin() + std::ptrdiff_t(at),
                                              counts.begin() + std::ptrdiff_t(at + bins)));
  return rows;
}

// Per energy bin, summed over the size classes.
std::vector<std::uint64_t> by_energy(const std::vector<std::uint64_t>& counts, std::size_t bins) {
  std::vector<std::uint64_t> sum(bins, 0);
  for (std::size_t k = 0; k < counts.size(); ++k) sum[k % bins] += counts[k];
  return sum;
}

// The spectrum over the run (per group, size class and energy bin) and per output interval
// (per group and energy bin, summed over sizes; run.h5 has them by size too).
nlohmann::ordered_json impact_spectrum_json(const ImpactSpectrum& spectrum, const Simulation& sim,
                                            const SceneConfig& scene) {
  const std::size_t bins = spectrum.energy_bins();
  nlohmann::ordered_json groups = nlohmann::ordered_json::array();
  for (std::size_t g = 0; g < spectrum.groups().size(); ++g) {
    const ImpactGroup& group = spectrum.groups()[g];
    nlohmann::ordered_json intervals_n = nlohmann::ordered_json::array(),
                           intervals_t = nlohmann::ordered_json::array();
    for (std::size_t k = 0; k < spectrum.interval_end_s().size(); ++k) {
      intervals_n.push_back(by_energy(spectrum.interval_normal_counts(k, g), bins));
      intervals_t.push_back(by_energy(spectrum.interval_tangential_counts(k, g), bins));
    }
    nlohmann::ordered_json entry;
    entry["name"] = impact_group_name(group, sim, scene);
    entry["kind"] = group.with_wall ? "particle-wall" : "particle-particle";
    entry["material"] = scene.materials[std::size_t(group.material)].name;
    entry["partner"] = impact_partner_name(group, sim, scene);
    entry["normal_counts"] = count_rows(spectrum.normal_counts(g), bins);
    entry["tangential_counts"] = count_rows(spectrum.tangential_counts(g), bins);
    entry["interval_normal_counts"] = intervals_n;
    entry["interval_tangential_counts"] = intervals_t;
    groups.push_back(entry);
  }
  return {{"definition",
           "impacts met per particle (a pair impact counts for both), by specific energy v^2/2 "
           "of the normal and of the tangential relative speed at the contact point"},
          {"energy_edges_j_per_kg", spectrum.energy_edges_j_per_kg()},
          {"size_edges_m", spectrum.size_edges_m()},
          {"simulated_time_s", sim.time_s()},
          {"impacts", spectrum.impacts()},
          {"interval_end_s", spectrum.interval_end_s()},
          {"groups", groups}};
}

// /impact_spectrum: the edges, the interval ends, the group names (attribute "groups", one per
// line) and the counts, [group][size class][energy bin] over the run and
// [interval][group][size class][energy bin] per output interval.
void write_impact_spectrum_h5(const ImpactSpectrum& spectrum, const Simulation& sim,
                              const SceneConfig& scene, H5Writer& h5) {
  h5.write_columns(
      "/impact_spectrum", {"energy_edges_j_per_kg", "size_edges_m", "interval_end_s"},
      {spectrum.energy_edges_j_per_kg(), spectrum.size_edges_m(), spectrum.interval_end_s()});
  std::string names;
  for (const ImpactGroup& g : spectrum.groups()) names += impact_group_name(g, sim, scene) + "\n";
  h5.write_group_attribute("/impact_spectrum", "groups", names);
  const std::size_t groups = spectrum.groups().size(), sizes = spectrum.size_classes(),
                    bins = spectrum.energy_bins(), intervals = spectrum.interval_end_s().size();
  std::vector<std::uint64_t> normal, tangential, interval_normal, interval_tangential;
  for (std::size_t g = 0; g < groups; ++g) {
    const auto& n = spectrum.normal_counts(g);
    const auto& t = spectrum.tangential_counts(g);
    normal.insert(normal.end(), n.begin(), n.end());
    tangential.insert(tangential.end(), t.begin(), t.end());
  }
  for (std::size_t k = 0; k < intervals; ++k)
    for (std::size_t g = 0; g < groups; ++g) {
      const std::vector<std::uint64_t> n = spectrum.interval_normal_counts(k, g);
      const std::vector<std::uint64_t> t = spectrum.interval_tangential_counts(k, g);
      interval_normal.insert(interval_normal.end(), n.begin(), n.end());
      interval_tangential.insert(interval_tangential.end(), t.begin(), t.end());
    }
  h5.write_count_array("/impact_spectrum", "normal_counts", {groups, sizes, bins}, normal);
  h5.write_count_array("/impact_spectrum", "tangential_counts", {groups, sizes, bins}, tangential);
  h5.write_count_array("/impact_spectrum", "interval_normal_counts",
                       {intervals, groups, sizes, bins}, interval_normal);
  h5.write_count_array("/impact_spectrum", "interval_tangential_counts",
                       {intervals, groups, sizes, bins}, interval_tangential);
}

// /breakage_events: one row per logged event.
void write_breakage_events_h5(const Breakage& breakage, H5Writer& h5) {
  const std::vector<BreakageEvent>& log = breakage.event_log();
  std::vector<std::vector<double>> c(11);
  for (const BreakageEvent& e : log) {
    const double row[] = {e.time_s,
                          e.position_m.x,
                          e.position_m.y,
                          e.position_m.z,
                          double(e.parent_id),
                          e.parent_diameter_m,
                          double(e.generation),
                          e.specific_energy_j_per_kg,
                          double(e.crushed),
                          double(e.fragments),
                          e.dust_mass_kg};
    for (std::size_t k = 0; k < c.size(); ++k) c[k].push_back(row[k]);
  }
  h5.write_columns("/breakage_events",
                   {"time_s", "x_m", "y_m", "z_m", "parent_id", "parent_diameter_m", "generation",
                    "specific_energy_j_per_kg", "crushed", "fragments", "dust_mass_kg"},
                   c);
}

// One snapshot: the particles, and the gas field when the scene has gas.
void write_snapshot(H5Writer& h5, const Simulation& sim) {
  h5.write_snapshot(sim.step_index(), sim.time_s(), sim.particles());
  if (const GasCoupling* gas = sim.gas())
    h5.write_gas_snapshot(gas_field(gas->view(), sim.dust_ledger()));
}

// Steps between outputs; an interval longer than any run (1e300 s) means "never" (the first and
// last states are written anyway), not an overflowed count.
std::int64_t steps_per_interval(std::optional<double> interval_s, double fallback_s, double dt) {
  const double steps = std::round(interval_s.value_or(fallback_s) / dt);
  return std::int64_t(std::clamp(steps, 1.0, 4e18));
}

// One hold-up fill (time.fill_to_projection_s): the flows where its window starts, and what it
// did, or why it did not.
struct FillRecord {
  std::optional<MassFlows> start_flows;
  double start_s = 0.0, at_s = 0.0;
  std::optional<HoldupFill> fill;
  std::string skipped;
  std::vector<int> fixed;  // compartments held at their hold-up (CompartmentRates::fixed_held_kg)
  std::vector<int> few_counts;       // of those, the ones held for too few counts (fill_min_events)
  std::vector<double> projected_kg;  // per compartment: the projection, before the relaxation
  // Where the particle classes' rates were fitted from (time.fill_particle_rate_windows: an
  // earlier fill's window start; else start_s), and the counts they rest on, per particle slot.
  double particle_rates_from_s = 0.0;
  std::vector<double> particle_events, particles_left;
  // The dust of the fill's own window (its mean hold-up and exit rates), for the fill after it;
  // in a fill of the dust alone, how its exit rates followed the load
  // (time.fill_dust_exit_follows_load).
  DustExitWindow dust_window;
  std::optional<DustExitLoad> dust_load;
  bool done() const { return fill || !skipped.empty(); }
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, start_flows, start_s, at_s, fill, skipped, fixed, few_counts, projected_kg);
    io_all(a, particle_rates_from_s, particle_events, particles_left);
    io_all(a, dust_window, dust_load);
  }
};

// What the run loop keeps besides the Simulation, in each checkpoint.
struct LoopState {
  std::size_t initial_particles = 0;
  EnergyReport initial_energy;
  std::vector<HoldupRow> holdup;  // at the snapshot interval, in runs with a product
  // The mass flows at the rows that bound the steady window (the first at or after its start,
  // the last at or before its end), for the steady-state projection.
  std::optional<MassFlows> window_start_flows, window_end_flows;
  double window_start_s = 0.0, window_end_s = 0.0;
  // time.fill_to_projection_s: per fill, the flows where its window starts and what it did.
  std::vector<FillRecord> fills;
  template <class A>
  void checkpoint_io(A& a, TimeSeries& series) {
    io_all(a, initial_particles, initial_energy, series.columns, holdup);
    io_all(a, window_start_flows, window_end_flows, window_start_s, window_end_s);
    io_all(a, fills);
  }
};

// The feed the scene declares over [from_s, to_s] (process/feed.h) in place of the particles a
// window saw inserted. A projection's feed is its one input the run knows exactly, and a short
// window counts a handful of feed particles: 5 mg/s of 100-300 um particles is one every 2.6 ms,
// and a fill's window 3.3 ms, which can hold none (the feed then projects an empty mill).
void take_declared_feed(CompartmentRates& rates, const SceneConfig& scene,
                        const std::vector<double>& edges_m, double from_s, double to_s) {
  const std::vector<double> feed = declared_feed_kg_per_s(scene.feeds, edges_m, from_s, to_s);
  if (int(feed.size()) != rates.slots)
    throw std::logic_error("take_declared_feed: the rates are not over these edges");
  std::copy(feed.begin(), feed.end(), rates.feed_kg_per_s.begin());
}

// The steps of the hold-up fills (time.fill_to_projection_s): each fill's own, and where the
// window its projection is fitted over starts: two thirds of the way from the fill before it (or
// from the start) to it.
struct FillSteps {
  std::int64_t window_start = -1, fill = -1;
};
std::vector<FillSteps> fill_steps(const SceneConfig& scene, double dt, std::int64_t total) {
  std::vector<FillSteps> steps;
  std::int64_t previous = 0;
  for (const double at_s : scene.time.fill_to_projection_s) {
    FillSteps f;
    f.fill = std::clamp(std::int64_t(std::llround(at_s / dt)), previous + 1,
                        std::max<std::int64_t>(total - 1, previous + 1));
    f.window_start = previous + (2 * (f.fill - previous)) / 3;
    steps.push_back(f);
    previous = f.fill;
  }
  return steps;
}

// Whether fill `index` moves the ledger's dust alone (time.fill_dust_only_from_s): declared at or
// after that time.
bool moves_dust_only(const SceneConfig& scene, std::size_t index) {
  const std::optional<double>& from = scene.time.fill_dust_only_from_s;
  return from && scene.time.fill_to_projection_s[index] >= *from;
}

// How far fill `index` moves each class towards its projection (time.fill_relaxation).
double fill_relaxation(const SceneConfig& scene, std::size_t index) {
  const std::vector<double>& omega = scene.time.fill_relaxation;
  return index < omega.size() ? omega[index] : 1.0;
}

// At the fill's step: the steady state projected from the window before it (the particle
// classes' rates from an earlier fill's window on, time.fill_particle_rate_windows), and the fill
// to it (Simulation::fill_holdup); without a steady state, the reason instead.
void fill_to_projection(Simulation& sim, const SceneConfig& scene, std::vector<FillRecord>& fills,
                        std::size_t index) {
  FillRecord& record = fills[index];
  const FillRecord& first =
      fills[index - std::min(index, std::size_t(scene.time.fill_particle_rate_windows - 1))];
  record.at_s = sim.time_s();
  const std::optional<MassFlows> now = sim.mass_flows();
  if (!record.start_flows || !now || !(sim.time_s() > record.start_s)) {
    record.skipped = "no mass flows over a window before the fill";
    return;
  }
  CompartmentRates rates =
      fit_rates(flows_between(*record.start_flows, *now), sim.time_s() - record.start_s);
  record.dust_window = dust_exit_window(rates);
  record.particle_rates_from_s = record.start_s;
  if (&first != &record && first.start_flows) {
    take_particle_rates(
        rates, fit_rates(flows_between(*first.start_flows, *now), sim.time_s() - first.start_s));
    record.particle_rates_from_s = first.start_s;
  }
  take_declared_feed(rates, scene, sim.outlet_tally().edges_m, record.start_s, sim.time_s());
  record.particle_events.assign(rates.events.begin(), rates.events.begin() + rates.slots);
  record.particles_left.assign(rates.left_count.begin(), rates.left_count.begin() + rates.slots);
  const std::vector<double> held = sim.holdup_by_compartment_kg();
  // A particle class whose rates rest on fewer counts than time.fill_min_events keeps what it
  // holds and passes mass on at its measured rates. In a fill of the dust alone every particle
  // class is held at its mean over the fill's window, so it passes on to the dust what the window
  // saw it pass: a class that holds nothing at the fill's instant but carries mass through (a
  // feed size that breaks at its first impact) still feeds the dust.
  const bool dust_only = moves_dust_only(scene, index);
  rates.fixed_held_kg.assign(held.size(), -1.0);
  for (int c = 0; c < rates.slots; ++c) {
    const std::size_t k = std::size_t(c);
    if (dust_only) {
      rates.fixed_held_kg[k] = rates.mean_held_kg[k];
      continue;
    }
    const double counts = rates.events[k] + rates.left_count[k];
    if (held[k] > 0.0 && counts < double(scene.time.fill_min_events))
      rates.fixed_held_kg[k] = held[k], record.few_counts.push_back(c);
  }
  // In a fill of the dust alone, the dust's exit rates follow its hold-up as the window and the
  // one before it measured them, when the fill between the two moved the dust alone (the
  // particles, which weigh on the gas too, then changed only as the mill moved them); the first
  // fill of the dust alone projects at its window's rates.
  DustExitLoad load;
  if (dust_only && scene.time.fill_dust_exit_follows_load && index > 0 &&
      moves_dust_only(scene, index - 1) && !fills[index - 1].dust_window.empty()) {
    load = fit_dust_exit_load(fills[index - 1].dust_window, record.dust_window);
    record.dust_load = load;
  }
  LoadedProjection loaded = project_steady_at_own_load(rates, load, held, 2);
  // A class the window saw receive mass but neither break nor leave (say the sliver of a size
  // class above the dust threshold) has no steady hold-up of its own: it keeps what it holds, and
  // the rest of the mill is projected around it (it passes nothing on).
  if (!loaded.projection.exists && !loaded.projection.accumulating.empty()) {
    for (int c : loaded.projection.accumulating)
      rates.fixed_held_kg[std::size_t(c)] = held[std::size_t(c)];
    loaded = project_steady_at_own_load(rates, load, held, 2);
  }
  const SteadyProjection& projection = loaded.projection;
  if (!projection.exists) {
    const std::vector<double>& edges = sim.outlet_tally().edges_m;
    std::string names;
    const auto micrometres = [](double m) {
      std::ostringstream text;
      text << std::setprecision(3) << m * 1e6;
      return text.str();
    };
    for (int c : projection.accumulating) {
      const int slot = c % rates.slots;
      names +=
          concat(names.empty() ? "" : ", ", c < rates.slots ? "particles " : "dust ",
                 slot == 0 ? "0" : micrometres(edges[std::size_t(slot - 1)]), "-",
                 slot < int(edges.size()) ? micrometres(edges[std::size_t(slot)]) : "inf", " um");
    }
    record.skipped =
        "no steady state projected: these compartments receive mass but neither "
        "break nor leave in the window: " +
        names;
    return;
  }
  record.projected_kg = projection.held_kg;
  std::vector<double> target =
      relaxed_target_kg(held, projection.held_kg, fill_relaxation(scene, index));
  // The particles' targets are what they hold, to the bit (a relaxation of a class towards its
  // own hold-up need not round back to it), so the fill copies and removes none.
  if (dust_only) std::copy_n(held.begin(), rates.slots, target.begin());
  record.fill = sim.fill_holdup(target,
                                scene.seed ^ (0x66696c6cULL + index),  // "fill", one seed each
                                scene.time.fill_removes);
  record.fixed = projection.fixed;
}

// One line for the log: what a fill moved (µg), or why it did not.
std::string fill_notice(const SceneConfig& scene, const FillRecord& record, std::size_t index) {
  std::ostringstream line;
  line << std::fixed << std::setprecision(1) << "fill " << index + 1 << " at " << record.at_s * 1e3
       << " ms" << (moves_dust_only(scene, index) ? " (the dust alone)" : "") << ": ";
  if (!record.fill) return line.str() + "skipped: " + record.skipped;
  const HoldupFill& f = *record.fill;
  const auto micrograms = [](const std::vector<double>& v, std::size_t from, std::size_t to) {
    double sum = 0.0;
    for (std::size_t c = from; c < to && c < v.size(); ++c) sum += v[c];
    return sum * 1e9;
  };
  const std::size_t slots = f.before_kg.size() / 2, all = f.before_kg.size();
  line << "particles " << micrograms(f.before_kg, 0, slots) << " -> "
       << micrograms(f.after_kg, 0, slots) << " ug (projected "
       << micrograms(record.projected_kg, 0, slots) << "), ledger dust "
       << micrograms(f.before_kg, slots, all) << " -> " << micrograms(f.after_kg, slots, all)
       << " ug (projected " << micrograms(record.projected_kg, slots, all) << "); "
       << f.particles_added << " copied, " << f.particles_removed << " removed, "
       << record.few_counts.size() << " classes held for few counts";
  return line.str();
}

nlohmann::ordered_json fill_json(const Simulation& sim, const SceneConfig& scene,
                                 const FillRecord& record, std::size_t index) {
  nlohmann::ordered_json j;
  // What the fill moves (time.fill_dust_only_from_s), as declared, whether or not it was reached.
  j["moves"] = moves_dust_only(scene, index) ? "dust" : "particles and dust";
  j["relaxation"] = fill_relaxation(scene, index);
  if (!record.done()) {
    j["status"] = "not reached";  // a run stopped before the fill
    return j;
  }
  j["window_s"] = {record.start_s, record.at_s};
  if (!record.particle_events.empty()) {
    // The span the particle classes' rates were fitted over, and the counts they rest on.
    j["particle_rates_window_s"] = {record.particle_rates_from_s, record.at_s};
    j["particle_events_by_slot"] = record.particle_events;
    j["particles_left_by_slot"] = record.particles_left;
  }
  if (!record.fill) {
    j["status"] = "skipped";
    j["reason"] = record.skipped;
    return j;
  }
  const HoldupFill& f = *record.fill;
  const int slots = int(sim.outlet_tally().edges_m.size()) + 1;
  auto part = [&](const std::vector<double>& v, bool dust) {
    return std::vector<double>(v.begin() + (dust ? slots : 0), v.begin() + (dust ? 2 : 1) * slots);
  };
  auto total = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v) sum += x;
    return sum;
  };
  j["status"] = "filled";
  j["time_s"] = f.time_s;
  j["particles_added"] = f.particles_added;
  j["particles_kg"] = f.particles_kg;
  j["dust_kg"] = f.dust_kg;
  j["particles_removed"] = f.particles_removed;
  j["particles_removed_kg"] = f.particles_removed_kg;
  j["dust_removed_kg"] = f.dust_removed_kg;
  j["energy_j"] = f.energy_j;
  j["rejected_draws"] = f.rejected_draws;
  j["slots_without_source"] = f.without_source;
  j["slots_out_of_room"] = f.out_of_room;
  j["dust_classes_without_mass"] = f.dust_without_mass;
  // Classes that received mass in the window but neither broke nor left: held at their hold-up.
  nlohmann::ordered_json fixed = nlohmann::ordered_json::array();
  for (int c : record.fixed)
    fixed.push_back({{"phase", c < slots ? "particles" : "dust"}, {"slot", c % slots}});
  j["held_as_they_were"] = fixed;
  // Of those, the particle classes held because their window counted too few events.
  j["held_for_few_counts"] = record.few_counts;
  // How the dust's exit rates followed its hold-up (a fill of the dust alone after another).
  j["dust_exit_load"] =
      record.dust_load
          ? dust_exit_load_json(*record.dust_load, total(part(record.projected_kg, true)))
          : nullptr;
  for (const bool dust : {false, true}) {
    nlohmann::ordered_json& held = j[dust ? "dust" : "particles"];
    if (!record.projected_kg.empty()) {
      held["projected_kg"] = total(part(record.projected_kg, dust));
      held["projected_by_slot_kg"] = part(record.projected_kg, dust);
    }
    held["target_kg"] = total(part(f.target_kg, dust));
    held["before_kg"] = total(part(f.before_kg, dust));
    held["after_kg"] = total(part(f.after_kg, dust));
    held["target_by_slot_kg"] = part(f.target_kg, dust);
    held["before_by_slot_kg"] = part(f.before_kg, dust);
    held["after_by_slot_kg"] = part(f.after_kg, dust);
  }
  return j;
}

// A hold-up row now, and the mass flows when the row bounds the steady window.
void record_holdup(const Simulation& sim, const SceneConfig& scene, LoopState& loop) {
  loop.holdup.push_back(holdup_row(sim));
  const double t = loop.holdup.back().time_s;
  const std::array<double, 2> window = steady_window_s(sim, scene);
  // As steady_window matches rows: within a step of either end.
  const double slack = sim.time_step().step_s;
  if (t > window[1] + slack) return;
  const std::optional<MassFlows> flows = sim.mass_flows();
  if (!flows) return;
  if (t >= window[0] - slack && !loop.window_start_flows)
    loop.window_start_flows = flows, loop.window_start_s = t;
  if (loop.window_start_flows) loop.window_end_flows = flows, loop.window_end_s = t;
}

// The steady state projected from the window's rates (process/steady_projection.h); null before
// the window has two rows.
nlohmann::ordered_json projection_json(const Simulation& sim, const SceneConfig& scene,
                                       const LoopState& loop) {
  if (!loop.window_start_flows || !loop.window_end_flows ||
      !(loop.window_end_s > loop.window_start_s))
    return nullptr;
  const MassFlows window = flows_between(*loop.window_start_flows, *loop.window_end_flows);
  CompartmentRates rates = fit_rates(window, loop.window_end_s - loop.window_start_s);
  const std::vector<double>& edges = sim.outlet_tally().edges_m;
  take_declared_feed(rates, scene, edges, loop.window_start_s, loop.window_end_s);
  const std::vector<double> held = sim.holdup_by_compartment_kg();
  const SteadyProjection projection = project_steady(rates, held);
  const ProjectionSpread spread =
      projection_spread(rates, held, edges, kProjectionDraws, scene.seed);
  nlohmann::ordered_json j;
  j["window_s"] = {loop.window_start_s, loop.window_end_s};
  j["window_from"] = sim.product_window_s() ? "product_window_s" : "last third";
  j["from_time_s"] = sim.time_s();
  const nlohmann::ordered_json body = steady_projection_json(rates, projection, spread, edges);
  for (auto it = body.begin(); it != body.end(); ++it) j[it.key()] = it.value();
  return j;
}

struct ResumePoint {
  std::filesystem::path checkpoint;
  CheckpointHeader header;
  std::vector<std::string> skipped;  // damaged newer checkpoints, each with its reason
};

// Restores the newest usable checkpoint of `dir` into `sim`, `loop` and `series`; none when the
// folder holds no checkpoint. Throws ResumeError for a foreign or incompatible one, or when
// every one is damaged.
std::optional<ResumePoint> resume_from(const std::filesystem::path& dir, std::uint64_t hash,
                                       Simulation& sim, LoopState& loop, TimeSeries& series) {
  std::vector<std::string> skipped;
  for (const std::filesystem::path& path : list_checkpoints(dir)) {
    Checkpoint c;
    try {
      c = read_checkpoint(path);
    } catch (const CheckpointError& e) {
      skipped.push_back(path.string() + ": " + e.what());
      continue;
    }
    const CheckpointHeader& h = c.header;
    if (h.layout != checkpoint_layout())
      throw ResumeError(path.string() + ": written by millsim " + h.millsim_version + " (commit " +
                        h.git_commit + "), whose state layout differs from this build's (" +
                        kMillsimVersion + ", commit " + kGitCommit +
                        "): continue it with that build, or run again without --resume");
    if (h.scene_hash != hash)
      throw ResumeError(path.string() +
                        ": a checkpoint of another scene (the scene's hash differs, so the scene "
                        "changed since it was written): resume with the scene it was written "
                        "for, or run again without --resume");
    ArchiveReader r(c.state.data(), c.state.size());
    try {
      sim.checkpoint_io(r);
      loop.checkpoint_io(r, series);
      if (!r.at_end()) throw CheckpointError("its state is longer than this build reads");
    } catch (const CheckpointError& e) {
      throw ResumeError(path.string() + ": " + e.what());
    }
    return ResumePoint{path, h, skipped};
  }
  if (!skipped.empty()) {
    std::string all = "no usable checkpoint in " + dir.string() + ":";
    for (const std::string& s : skipped) all += "\n  " + s;
    throw ResumeError(all);
  }
  return std::nullopt;
}

// "SIGTERM" for 15.
std::string sigabbrev(int signal) {
  const char* name = sigabbrev_np(signal);
  return name ? std::string("SIG") + name : "signal " + std::to_string(signal);
}

// How the gas got its spin-up in this attempt, for result.json.
nlohmann::ordered_json spin_up_json(const SpinUpReport& r, const Simulation& sim) {
  nlohmann::ordered_json j = {{"source", r.source},
                              {"gas_time_s", sim.gas()->config().spin_up_s},
                              {"done_s", r.done_s},
                              {"seconds", r.wall_s}};
  if (r.source == "resumed") j["resumed_from_s"] = r.resumed_from_s;
  if (r.waited_s > 0.01) j["waited_s"] = r.waited_s;
  if (!r.cache_file.empty()) {
    j["cache_file"] = r.cache_file.string();
    j["cache_written"] = r.cache_written;
  }
  if (!r.note.empty()) j["note"] = r.note;
  return j;
}

// A run stopped during its gas spin-up: result.json says so and where the gas state is (the
// spin-up checkpoint, which --resume continues); no step was taken, so there is no run.h5.
RunOutcome spin_up_interrupted(const SceneConfig& scene, const SpinUpReport& r,
                               const Simulation& sim, const RunOptions& options) {
  RunOutcome outcome;
  outcome.interrupted_by = r.interrupted_by;
  nlohmann::ordered_json& s = outcome.summary;
  s["millsim_version"] = kMillsimVersion;
  s["scene"] = scene.name;
  s["status"] = "interrupted";
  s["interrupted"] = {{"signal", sigabbrev(r.interrupted_by)},
                      {"phase", "gas_spin_up"},
                      {"step", 0},
                      {"time_s", 0.0},
                      {"spin_up_done_s", r.done_s}};
  s["steps"] = 0;
  s["steps_planned"] = sim.total_steps();
  s["wall_time_s"] = r.wall_s;
  if (r.earlier_wall_s > 0.0) s["wall_time_total_s"] = r.earlier_wall_s + r.wall_s;
  s["spin_up"] = spin_up_json(r, sim);
  if (!options.out_dir.empty()) {
    const std::filesystem::path checkpoint =
        spin_up_checkpoint_path(options.out_dir / "checkpoints");
    if (std::filesystem::exists(checkpoint))
      s["checkpoints"] = {{"written", 1}, {"last", checkpoint.filename().string()}};
    s["outputs"] = {{"result", "result.json"}};
    write_text_atomically(options.out_dir / "result.json", readable_json(s) + "\n");
  }
  return outcome;
}

}  // namespace

nlohmann::ordered_json energy_json(const EnergyReport& e) {
  return {{"kinetic_j", e.kinetic_j},
          {"rotational_j", e.rotational_j},
          {"potential_j", e.potential_j},
          {"elastic_j", e.elastic_j},
          {"total_j", e.total_j()}};
}

RunOutcome run_simulation(Simulation& sim, const SceneConfig& scene, const RunOptions& options) {
  const auto start = Clock::now();
  const bool write_files = !options.out_dir.empty();
  const std::filesystem::path checkpoint_dir = options.out_dir / "checkpoints";
  auto prepare_folder = [&] {
    if (!write_files) return;
    std::filesystem::create_directories(options.out_dir);
    // A copy of the scene beside its results (not over itself: the service runs scene.json in
    // the run's own directory).
    const std::filesystem::path copy = options.out_dir / "scene.json";
    std::error_code ec;
    if (!options.scene_text.empty() && !(std::filesystem::exists(copy) &&
                                         std::filesystem::equivalent(copy, options.scene_path, ec)))
      write_text_atomically(copy, options.scene_text);
  };

  std::optional<SpinUpReport> spin_up;
  if (sim.start_pending()) {
    SpinUpOptions o;
    if (write_files) o.checkpoint_dir = checkpoint_dir;
    o.cache_dir = options.spin_up_cache_dir;
    o.scene_text = options.scene_text;
    o.resume = options.resume;
    o.stop_request = options.stop_request;
    o.on_progress = options.on_spin_up_progress;
    o.progress_interval_s = options.progress_interval_s;
    spin_up = run_gas_spin_up(sim, o);
    if (spin_up->interrupted_by != 0) {
      prepare_folder();
      return spin_up_interrupted(scene, *spin_up, sim, options);
    }
  }
  const double dt = sim.time_step().step_s;
  const std::int64_t total = sim.total_steps();
  const std::int64_t snapshot_every =
      steps_per_interval(scene.output.snapshot_interval_s, scene.time.end_s / 10.0, dt);
  const std::int64_t series_every =
      steps_per_interval(scene.output.timeseries_interval_s, scene.time.end_s / 200.0, dt);
  const std::int64_t checkpoint_every =
      scene.output.checkpoint_interval_s
          ? steps_per_interval(scene.output.checkpoint_interval_s, 0.0, dt)
          : 0;
  const bool write_h5 = write_files && scene.output.write_h5;
  const std::uint64_t hash = options.scene_text.empty() ? 0 : scene_hash(options.scene_text);
  LoopState loop;
  loop.initial_particles = sim.particles().size();
  loop.initial_energy = sim.energy();
  TimeSeries series(has_product(sim), sim);
  const std::optional<ResumePoint> resumed =
      options.resume && write_files ? resume_from(checkpoint_dir, hash, sim, loop, series)
                                    : std::nullopt;
  prepare_folder();

  std::unique_ptr<H5Writer> h5;
  const std::filesystem::path h5_partial = options.out_dir / "run.h5.partial";
  // A resumed run carries the earlier attempts' snapshots up to its checkpoint. It takes them
  // from the first readable of: the file the last attempt left (flushed before each of its
  // checkpoints), the source the attempt before it carried from, the last finished run.h5. The
  // one it read is kept as the next attempt's source until this run completes.
  const std::filesystem::path h5_source = options.out_dir / "run.h5.resume-source";
  const std::filesystem::path h5_last_attempt = options.out_dir / "run.h5.last-attempt";
  long carried_snapshots = 0;
  if (write_h5 && resumed && std::filesystem::exists(h5_partial))
    std::filesystem::rename(h5_partial, h5_last_attempt);
  if (write_h5) {
    // The name table of the `material` array: "0 salt", "1 steel", one per line.
    std::string material_names;
    for (std::size_t m = 0; m < scene.materials.size(); ++m)
      material_names.append(std::to_string(m))
          .append(" ")
          .append(scene.materials[m].name)
          .append("\n");
    h5 = std::make_unique<H5Writer>(h5_partial);
    if (resumed) {
      carried_snapshots = -1;
      for (const std::filesystem::path& earlier :
           {h5_last_attempt, h5_source, options.out_dir / "run.h5"}) {
        if (carried_snapshots >= 0 || !std::filesystem::exists(earlier)) continue;
        carried_snapshots = h5->carry_snapshots(earlier, resumed->header.step, snapshot_every);
        if (carried_snapshots >= 0 && earlier == h5_last_attempt)
          std::filesystem::rename(h5_last_attempt, h5_source);
      }
      std::filesystem::remove(h5_last_attempt);
    }
    h5->write_root_attribute("scene", scene.name);
    h5->write_root_attribute("millsim_version", kMillsimVersion);
    h5->write_meta({{"scene_name", scene.name},
                    {"scene_json", options.scene_text},
                    {"seed", std::to_string(scene.seed)},
                    {"millsim_version", kMillsimVersion},
                    {"git_commit", kGitCommit},
                    {"compiler", kCompiler},
                    {"materials", material_names}});
    h5->write_geometry(
        scene_geometry(scene, sim.walls(), sim.box(), sim.gas() ? &sim.gas()->config() : nullptr));
  }

  const bool with_holdup = has_product(sim);
  const std::vector<FillSteps> fill = fill_steps(scene, dt, total);
  loop.fills.resize(fill.size());  // a resumed run's records are restored below
  // Before an advance that ends at step `step`: a fill's flows and the fill itself.
  auto fill_events = [&](std::int64_t step) {
    for (std::size_t k = 0; k < fill.size(); ++k) {
      FillRecord& record = loop.fills[k];
      if (step == fill[k].window_start && !record.start_flows) {
        record.start_flows = sim.mass_flows();
        record.start_s = sim.time_s();
      }
      if (step == fill[k].fill && !record.done()) {
        sim.profile().time(Phase::Population,
                           [&] { fill_to_projection(sim, scene, loop.fills, k); });
        if (options.on_notice) options.on_notice(fill_notice(scene, record, k));
      }
    }
  };
  if (!resumed) {
    fill_events(sim.step_index());
    series.record(sim);
    if (with_holdup) record_holdup(sim, scene, loop);
    if (h5) write_snapshot(*h5, sim);
  }
  if (h5) h5->flush();  // readable from the start, should this attempt be killed too
  const std::size_t initial_particles = loop.initial_particles;
  const EnergyReport initial_energy = loop.initial_energy;
  const double earlier_wall_s = resumed   ? resumed->header.wall_time_s
                                : spin_up ? spin_up->earlier_wall_s
                                          : 0.0;
  int checkpoints_written = 0;
  double checkpoint_seconds = 0.0, checkpoint_bytes = 0.0;
  std::filesystem::path last_checkpoint;
  auto last_checkpoint_wall = Clock::now();
  auto write_state = [&] {
    const auto started = Clock::now();
    ArchiveWriter w;
    sim.checkpoint_io(w);
    loop.checkpoint_io(w, series);
    const CheckpointHeader header{
        kMillsimVersion,
        kGitCommit,
        checkpoint_layout(),
        hash,
        sim.step_index(),
        sim.time_s(),
        earlier_wall_s + std::chrono::duration<double>(Clock::now() - start).count()};
    if (h5) h5->flush();  // first: a checkpoint on disk means run.h5 holds what came before it
    last_checkpoint = write_checkpoint(checkpoint_dir, header, w.data(), options.checkpoints_kept);
    ++checkpoints_written;
    checkpoint_bytes += double(w.data().size());
    last_checkpoint_wall = Clock::now();
    checkpoint_seconds += std::chrono::duration<double>(last_checkpoint_wall - started).count();
  };

  RunOutcome outcome;
  auto last_progress = Clock::now();
  EtaEstimator eta;
  auto progress_now = [&](std::int64_t step, double elapsed) {
    eta.add(step, elapsed, sim.particles().size());
    RunProgress p{step, total, sim.time_s(), sim.particles().size(), elapsed, eta.eta_s(total)};
    p.contacts = sim.contact_stats().touching_pairs + sim.contact_stats().touching_walls;
    p.kinetic_j = sim.energy().kinetic_j;
    p.time_step_s = dt;
    const double step_seconds = sim.profile().total();
    p.particle_steps_per_s = step_seconds > 0 ? sim.particle_steps() / step_seconds : 0.0;
    return p;
  };
  if (options.on_progress)
    options.on_progress(progress_now(sim.step_index(), seconds_since(start)));
  while (sim.step_index() < total) {
    // Advance to the next step anything is recorded at, and at most 256 steps, so progress
    // (checked between advances) stays timely.
    const std::int64_t now = sim.step_index();
    std::int64_t next = std::min({total, now + 256, (now / series_every + 1) * series_every});
    if (h5 || sim.impact_spectrum() || with_holdup)
      next = std::min(next, (now / snapshot_every + 1) * snapshot_every);
    if (checkpoint_every > 0)
      next = std::min(next, (now / checkpoint_every + 1) * checkpoint_every);
    for (const FillSteps& f : fill)
      for (const std::int64_t at : {f.window_start, f.fill})
        if (at > now) next = std::min(next, at);
    outcome.failure = sim.advance(next - now);
    const std::int64_t step = sim.step_index();
    if (!outcome.failure) fill_events(step);
    if (options.stop_request && !outcome.failure)
      outcome.interrupted_by = options.stop_request->load(std::memory_order_relaxed);
    const bool last = step == total || outcome.failure || outcome.interrupted_by != 0;
    if (step % series_every == 0 || last)
      sim.profile().time(Phase::Output, [&] { series.record(sim); });
    if (h5 && (step % snapshot_every == 0 || last))
      sim.profile().time(Phase::Output, [&] { write_snapshot(*h5, sim); });
    // Not at a stop: the resumed run goes on to the same rows as one that never stopped.
    if (with_holdup && (step % snapshot_every == 0 || step == total || outcome.failure))
      sim.profile().time(Phase::Output, [&] { record_holdup(sim, scene, loop); });
    // The impact spectrum's intervals end on the snapshot schedule and at the run's end (not at
    // a stop, whose resumed run carries on the same interval).
    if (step % snapshot_every == 0 || step == total) sim.close_impact_interval();
    if (options.on_progress &&
        (last || Clock::now() - last_progress >
                     std::chrono::duration<double>(options.progress_interval_s))) {
      last_progress = Clock::now();
      const double elapsed = std::chrono::duration<double>(last_progress - start).count();
      options.on_progress(progress_now(step, elapsed));
    }
    const bool checkpoint_due = (checkpoint_every > 0 && step % checkpoint_every == 0) ||
                                (options.checkpoint_wall_s > 0.0 &&
                                 Clock::now() - last_checkpoint_wall >
                                     std::chrono::duration<double>(options.checkpoint_wall_s)) ||
                                outcome.interrupted_by != 0;
    if (write_files && !outcome.failure && step < total && checkpoint_due)
      sim.profile().time(Phase::Output, write_state);
    if (outcome.failure || outcome.interrupted_by != 0) break;
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();

  const EnergyReport final_energy = sim.energy();
  nlohmann::ordered_json& s = outcome.summary;
  s["millsim_version"] = kMillsimVersion;
  s["scene"] = scene.name;
  s["status"] = outcome.failure ? "failed" : outcome.interrupted_by != 0 ? "interrupted" : "ok";
  if (outcome.interrupted_by != 0)
    s["interrupted"] = {{"signal", sigabbrev(outcome.interrupted_by)},
                        {"step", sim.step_index()},
                        {"time_s", sim.time_s()}};
  if (outcome.failure) {
    const StepFailure& f = *outcome.failure;
    s["failure"] = {{"step", f.step},
                    {"time_s", f.time_s},
                    {"particle_id", f.particle_id},
                    {"cause", f.cause},
                    {"message", f.detail}};
  }
  s["particles"] = {{"initial", initial_particles}, {"final", sim.particles().size()}};
  s["steps"] = sim.step_index();
  s["steps_planned"] = total;
  const TimeStepInfo& ts = sim.time_step();
  s["time_step_s"] = dt;
  s["time_step"] = {{"step_s", dt},
                    {"automatic", ts.automatic},
                    {"rayleigh_time_min_s", ts.bounds.rayleigh_s},
                    {"contact_time_min_s", ts.bounds.contact_s},
                    {"penetration_travel_bound_s", ts.travel_bound_s},
                    {"impact_speed_m_per_s", ts.impact_speed_m_per_s},
                    {"stable_bound_s", ts.stable_bound_s}};
  if (const auto& rs = sim.reduced_stiffness())
    s["reduced_stiffness"] = {{"threshold_diameter_m", rs->threshold_diameter_m},
                              {"automatic", rs->automatic},
                              {"reduced_particles", rs->reduced_particles},
                              {"predicted_penetration_ratio", rs->predicted_penetration_ratio},
                              {"limited_by_real_stiffness", rs->limited_by_real_stiffness},
                              {"time_step_gain", rs->time_step_gain}};
  if (const MultiRate* mr = sim.multi_rate()) {
    // Particle-steps at the contact step, and those the particles in free flight did not take
    // (sim/multi_rate.h): their share is the work the long step saved.
    const double taken = sim.particle_steps(), waited = mr->stats.waiting_particle_steps;
    s["multi_rate"] = {{"particle_steps_taken", taken},
                       {"particle_steps_waited", waited},
                       {"waited_share", taken + waited > 0 ? waited / (taken + waited) : 0.0},
                       {"long_steps", mr->stats.long_steps},
                       {"catch_ups", mr->stats.catch_ups},
                       {"full_steps", mr->stats.full_steps},
                       {"kept_fluid_force_steps", mr->stats.held_fluid_steps},
                       {"fluid_refreshes", mr->stats.fluid_refreshes},
                       {"max_wait_steps", mr->max_wait_steps}};
    if (mr->riders_on) {
      // Particles on walls alone, each on the level of its own step (2^level run steps).
      nlohmann::json by_level = nlohmann::json::array();
      for (const RiderLevel& level : mr->riders) by_level.push_back(level.slots.size());
      s["multi_rate"]["wall_riders"] = {{"own_steps", mr->stats.rider_steps},
                                        {"steps_not_taken", mr->stats.rider_waited_steps},
                                        {"level_catch_ups", mr->stats.rider_catch_ups},
                                        {"riders_by_level_at_end", by_level}};
    }
  }
  s["simulated_time_s"] = sim.time_s();
  s["wall_time_s"] = wall_s;  // with the gas spin-up, when this attempt did it
  s["threads"] = thread_count();
  if (spin_up) s["spin_up"] = spin_up_json(*spin_up, sim);
  if (resumed || earlier_wall_s > 0.0) s["wall_time_total_s"] = earlier_wall_s + wall_s;
  if (resumed) {
    s["resumed"] = {{"checkpoint", resumed->checkpoint.filename().string()},
                    {"step", resumed->header.step},
                    {"time_s", resumed->header.time_s},
                    {"skipped_damaged", resumed->skipped},
                    {"snapshots_carried", carried_snapshots}};
  }
  if (checkpoints_written > 0)
    s["checkpoints"] = {{"written", checkpoints_written},
                        {"last", last_checkpoint.filename().string()},
                        {"state_bytes_each", checkpoint_bytes / checkpoints_written},
                        {"seconds", checkpoint_seconds}};
  const double step_seconds = sim.profile().total();
  s["particle_steps_per_second"] = step_seconds > 0 ? sim.particle_steps() / step_seconds : 0.0;
  nlohmann::ordered_json phases = nlohmann::ordered_json::object();
  for (std::size_t k = 0; k < kPhaseNames.size(); ++k)
    phases[std::string(kPhaseNames[k])] = sim.profile().seconds[k];
  s["phase_seconds"] = phases;
  const ContactStepStats& c = sim.contact_stats();
  // The last step's wall contacts, and the wall riders' at their last own steps.
  std::uint64_t rider_walls = 0;
  if (const MultiRate* mr = sim.multi_rate())
    for (const RiderLevel& level : mr->riders) rider_walls += level.touching_walls;
  s["contacts"] = {{"pairs", c.touching_pairs},
                   {"walls", c.touching_walls + rider_walls},
                   {"max_overlap_ratio", c.max_overlap_ratio},
                   {"penetration_limiter_events", sim.penetration_limiter_events()}};
  const NeighborStats& n = sim.neighbors().stats();
  s["search"] = {
      {"method", sim.neighbors().settings().method == SearchMethod::Nbs ? "nbs" : "hashed"},
      {"skin_m", sim.neighbors().skin_m()},
      {"rebuilds", n.rebuilds},
      {"distance_tests", n.distance_tests},
      {"candidate_pairs", sim.neighbors().pairs.size()},
      {"cell_m", n.last_search.cell_m},
      {"subcells_per_axis", n.last_search.subcells_per_axis},
      {"grid_levels", n.last_search.levels},
      {"level_particles",
       std::vector<std::uint64_t>(n.last_search.level_particles,
                                  n.last_search.level_particles + n.last_search.levels)},
      {"occupied_cells", n.last_search.cells},
      {"occupied_subcells", n.last_search.subcells},
      {"fine_particles", n.last_search.fine_particles}};
  const MomentumBalance momentum = sim.momentum_balance();
  auto vec3 = [](const Vec3& v) { return std::vector<double>{v.x, v.y, v.z}; };
  s["momentum_kg_m_per_s"] = {{"initial", vec3(momentum.initial)},
                              {"fed", vec3(momentum.fed)},
                              {"particles", vec3(momentum.particles)},
                              {"in_flight", vec3(momentum.in_flight)},
                              {"outlet", vec3(momentum.outlet)},
                              {"dust", vec3(momentum.dust)},
                              {"external_impulse", vec3(momentum.external_impulse())},
                              {"scale", sim.momentum_scale_kg_m_per_s()}};
  const bool fills = !scene.time.fill_to_projection_s.empty();
  if (fills) s["momentum_kg_m_per_s"]["filled"] = vec3(momentum.filled);
  s["energy"] = {{"initial", energy_json(initial_energy)}, {"final", energy_json(final_energy)}};
  if (fills) s["energy"]["filled_j"] = sim.filled_energy_j();
  s["energy"]["dissipated_j"] =
      initial_energy.total_j() + sim.filled_energy_j() - final_energy.total_j();
  if (fills) {
    nlohmann::ordered_json& list = s["holdup_fills"] = nlohmann::ordered_json::array();
    for (std::size_t k = 0; k < loop.fills.size(); ++k)
      list.push_back(fill_json(sim, scene, loop.fills[k], k));
  }
  if (has_product(sim)) {
    add_product_summary(sim, s);
    s["holdup_history"] = holdup_history_json(loop.holdup);
    s["steady_state"] = steady_state_json(sim, scene, loop.holdup);
    s["steady_projection"] = projection_json(sim, scene, loop);
  }
  if (sim.gas()) add_gas_summary(sim, s);
  if (const DustLedger* dust = sim.dust_ledger()) {
    // Hold-up and outflow by class over time, at the time series' interval.
    nlohmann::ordered_json held = nlohmann::ordered_json::array(),
                           out = nlohmann::ordered_json::array();
    for (int k = 0; k < dust->class_count(); ++k) {
      held.push_back(series.columns[series.dust_column + 2 + 2 * std::size_t(k)]);
      out.push_back(series.columns[series.dust_column + 3 + 2 * std::size_t(k)]);
    }
    s["dust_ledger"]["history"] = {{"time_s", series.columns[0]},
                                   {"held_kg", series.columns[series.dust_column]},
                                   {"outflow_kg", series.columns[series.dust_column + 1]},
                                   {"held_by_class_kg", held},
                                   {"outflow_by_class_kg", out}};
  }
  if (!series.drops.empty()) s["pressure_drops"] = pressure_drops_json(sim, series);
  if (sim.mill() && has_product(sim)) add_mill_summary(sim, s);
  if (const ImpactSpectrum* spectrum = sim.impact_spectrum())
    s["impact_spectrum"] = impact_spectrum_json(*spectrum, sim, scene);

  if (write_files) {
    nlohmann::ordered_json outputs = nlohmann::ordered_json::object();
    if (h5) {
      h5->write_timeseries(series.names, series.columns);
      if (has_product(sim)) write_psd_h5(sim, *h5);
      if (sim.gas()) write_gas_h5(sim, *h5);
      if (sim.impact_spectrum()) write_impact_spectrum_h5(*sim.impact_spectrum(), sim, scene, *h5);
      if (sim.breakage()) write_breakage_events_h5(*sim.breakage(), *h5);
      h5->write_vertex_index();
      h5->close();
      std::filesystem::rename(h5_partial, options.out_dir / "run.h5");
      std::filesystem::remove(h5_source);
      write_xdmf(options.out_dir / "run.xdmf", "run.h5", h5->snapshots());
      outputs = {{"h5", "run.h5"}, {"xdmf", "run.xdmf"}, {"snapshots", h5->snapshots().size()}};
      if (h5->extras().gas_cells[0] > 0) {
        write_gas_xdmf(options.out_dir / "gas.xdmf", "run.h5", h5->snapshots(), h5->extras());
        outputs["gas_xdmf"] = "gas.xdmf";
      }
      if (h5->extras().geometry_triangles > 0) {
        write_geometry_xdmf(options.out_dir / "geometry.xdmf", "run.h5", h5->extras());
        outputs["geometry_xdmf"] = "geometry.xdmf";
      }
    }
    outputs["result"] = "result.json";
    if (s.contains("impact_spectrum")) {
      const std::string svg = impact_spectrum_svg(s["impact_spectrum"], scene.name);
      if (!svg.empty()) {
        write_text_atomically(options.out_dir / "impact_spectrum.svg", svg);
        outputs["impact_spectrum_svg"] = "impact_spectrum.svg";
      }
    }
    s["outputs"] = outputs;
    write_text_atomically(options.out_dir / "result.json", readable_json(s) + "\n");
    // A run that reached its end needs its checkpoints no more.
    if (!outcome.failure && outcome.interrupted_by == 0) remove_checkpoints(checkpoint_dir);
  }
  return outcome;
}

}  // namespace millsim
