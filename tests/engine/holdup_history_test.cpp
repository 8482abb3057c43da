// The hold-up history and the steady-state window (process/holdup_history.h, issue 31).
//
// Expectations from first principles:
// - a system whose outflow lags its constant feed F by a first-order delay τ (hold-up
//   F τ (1 − e^{−t/τ})) leaves, over [a, b], F (b − a) − F τ (e^{−a/τ} − e^{−b/τ}): the window's
//   ratio to the feed follows to rounding, and the flag turns at 10 %;
// - an outflow equal to the feed is not steady while one phase of the hold-up fills as the other
//   drains by more than a tenth of the feed (the mass balance alone cannot tell);
// - a stream fed at a constant rate and falling freely through an outlet plane leaves nothing
//   until its fall time t_f (from h = v0 t + g t²/2), then leaves at the feed rate: its run's
//   last third is steady with an outflow equal to the feed within a particle per window, its
//   hold-up is F t_f, and a product window before t_f is not steady (nothing left).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <numbers>

#include "process/holdup_history.h"
#include "process/mass_flows.h"
#include "scene/scene_json.h"
#include "sim/run.h"
#include "sim/simulation.h"
#include "support/scenes.h"

namespace millsim {
namespace {

std::vector<HoldupRow> lagged_rows(double feed_kg_per_s, double tau_s, double end_s, int rows,
                                   bool ledger) {
  std::vector<HoldupRow> out;
  for (int i = 0; i <= rows; ++i) {
    HoldupRow r;
    r.time_s = end_s * i / rows;
    r.fed_kg = feed_kg_per_s * r.time_s;
    r.particles_kg = feed_kg_per_s * tau_s * (1.0 - std::exp(-r.time_s / tau_s));
    const double left = r.fed_kg - r.particles_kg;
    // With the ledger, what left is the dust carried out, and a third of the hold-up is dust
    // still in the gas: made, which the table would have counted as product at once.
    if (ledger) {
      r.dust_out_kg = left;
      r.dust_held_kg = r.particles_kg / 3.0;
      r.dust_made_kg = left + r.dust_held_kg;
      r.particles_kg -= r.dust_held_kg;
    } else {
      r.dust_made_kg = left;
    }
    out.push_back(r);
  }
  return out;
}

TEST(SteadyWindow, AFirstOrderLagLeavesTheAnalyticShareOfItsFeed) {
  const double F = 2e-4, tau = 5e-3, end = 0.06;
  for (bool ledger : {false, true}) {
    const std::vector<HoldupRow> rows = lagged_rows(F, tau, end, 60, ledger);
    for (double a : {0.0, 0.005, 0.01, 0.02, 0.04}) {
      const std::optional<SteadyWindow> w = steady_window(rows, a, end, ledger);
      ASSERT_TRUE(w) << a;
      const double expected = 1.0 - tau * (std::exp(-a / tau) - std::exp(-end / tau)) / (end - a);
      EXPECT_NEAR(w->outflow_to_feed, expected, 1e-12) << "window from " << a;
      EXPECT_EQ(w->steady, std::abs(expected - 1.0) <= 0.1) << a;
      EXPECT_NEAR(w->fed_kg, F * (end - a), 1e-15);
      EXPECT_NEAR(w->particles_change_kg + w->dust_held_change_kg + w->outflow_kg, w->fed_kg, 1e-15)
          << "what was fed stayed or left";
      // The dust made is what left and a third of what stayed: (1 + 2 × outflow / fed) / 3.
      EXPECT_NEAR(w->made_to_feed, ledger ? (1.0 + 2.0 * expected) / 3.0 : expected, 1e-12);
      // The hold-up follows the outflow here: each phase's change is a share of fed − outflow.
      EXPECT_EQ(w->holdup_steady, std::abs(expected - 1.0) <= 0.1) << a;
    }
  }
  // τ = 10 ms: over the whole 60 ms the outflow is 1 − τ/60 ms = 0.83 of the feed (not steady);
  // over the last 20 ms it is 1 − (τ/20 ms)(e^{-4} − e^{-6}) = 0.992 (steady).
  const std::vector<HoldupRow> rows = lagged_rows(F, 0.01, end, 60, false);
  EXPECT_FALSE(steady_window(rows, 0.0, end, false)->steady);
  EXPECT_TRUE(steady_window(rows, 0.04, end, false)->steady);
}

// A mill whose outflow equals its feed while its dust drains as fast as its particles pile up
// (the filled 50 µm mill over 38–56 ms: particles +55 mg/s, dust −53 mg/s, outflow 0.98 of the
// feed) keeps its total hold-up, not its state: not steady. Phases trading less than a tenth of
// the feed are.
TEST(SteadyWindow, AnOutflowAtTheFeedRateWhileOnePhaseFillsAndTheOtherDrainsIsNotSteady) {
  const double feed = 1e-4;
  for (const double trade : {0.55, 0.08}) {
    std::vector<HoldupRow> rows;
    for (int i = 0; i <= 18; ++i) {
      HoldupRow r;
      r.time_s = 1e-3 * i;
      r.fed_kg = feed * r.time_s;
      r.particles_kg = 2e-5 + trade * feed * r.time_s;
      r.dust_held_kg = 6e-5 - trade * feed * r.time_s;
      r.dust_out_kg = feed * r.time_s;  // the outflow is the feed
      r.dust_made_kg = r.dust_out_kg + r.dust_held_kg;
      rows.push_back(r);
    }
    const std::optional<SteadyWindow> w = steady_window(rows, 0.0, 0.018, true);
    ASSERT_TRUE(w);
    EXPECT_NEAR(w->outflow_to_feed, 1.0, 1e-12);
    EXPECT_TRUE(w->outflow_steady);
    EXPECT_NEAR(w->particles_change_kg, trade * w->fed_kg, 1e-15);
    EXPECT_NEAR(w->dust_held_change_kg, -trade * w->fed_kg, 1e-15);
    EXPECT_EQ(w->holdup_steady, trade <= 0.1) << trade;
    EXPECT_EQ(w->steady, trade <= 0.1) << trade;
    const nlohmann::ordered_json j = steady_window_json(*w);
    EXPECT_EQ(j["outflow_steady"].get<bool>(), true);
    EXPECT_EQ(j["holdup_steady"].get<bool>(), trade <= 0.1);
    EXPECT_EQ(j["steady"].get<bool>(), trade <= 0.1);
  }
}

TEST(SteadyWindow, AWindowWithoutTwoRowsOrWithoutFeedHasNoAnswer) {
  const std::vector<HoldupRow> rows = lagged_rows(2e-4, 5e-3, 0.06, 6, false);
  EXPECT_FALSE(steady_window(rows, 0.031, 0.039, false)) << "no row inside";
  EXPECT_FALSE(steady_window(rows, 0.07, 0.08, false)) << "past the rows";
  std::vector<HoldupRow> stopped = rows;
  for (HoldupRow& r : stopped) r.fed_kg = 1e-6;
  EXPECT_FALSE(steady_window(stopped, 0.0, 0.06, false)) << "nothing fed";
}

// A run's last row lies up to a step past its end (steps = ⌈end / step⌉): within a step of the
// window's end it bounds the window, beyond it not.
TEST(SteadyWindow, ARowWithinAStepOfTheEndBoundsIt) {
  std::vector<HoldupRow> rows = lagged_rows(2e-4, 5e-3, 0.06, 6, false);
  const double step = 1e-5;
  rows.back().time_s = 0.06 + 0.5 * step;
  ASSERT_TRUE(steady_window(rows, 0.0, 0.06, false, step));
  EXPECT_EQ(steady_window(rows, 0.0, 0.06, false, step)->end_s, rows.back().time_s);
  EXPECT_EQ(steady_window(rows, 0.0, 0.06, false)->end_s, rows[rows.size() - 2].time_s);
  rows.back().time_s = 0.06 + 1.5 * step;
  EXPECT_EQ(steady_window(rows, 0.0, 0.06, false, step)->end_s, rows[rows.size() - 2].time_s);
}

// Monodisperse 1 mm beads fed at a constant rate 50 mm above an outlet plane at 1 m/s downwards,
// through still space under gravity: they never touch (each is inserted where it overlaps
// nothing and they all fall alike).
nlohmann::json falling_stream_scene(double end_s) {
  return {{"name", "falling_stream"},
          {"seed", 5},
          {"domain",
           {{"min_m", {0, 0, -0.01}}, {"max_m", {0.02, 0.02, 0.06}}, {"wall_material", "glass"}}},
          {"materials",
           {{{"name", "glass"},
             {"youngs_modulus_pa", 1e7},
             {"poisson_ratio", 0.25},
             {"density_kg_per_m3", 2500},
             {"restitution", 0.5},
             {"friction", 0.3}}}},
          {"sources", nlohmann::json::array()},
          {"feeds",
           {{{"name", "top"},
             {"material", "glass"},
             {"mass_rate_kg_per_s", 2e-3},
             {"region", {{"min_m", {0.002, 0.002, 0.049}}, {"max_m", {0.018, 0.018, 0.051}}}},
             {"sizes", {{"distribution", "uniform"}, {"min_m", 1e-3}, {"max_m", 1e-3}}},
             {"velocity_m_per_s", {0, 0, -1}}}}},
          {"outlets",
           {{{"name", "floor"}, {"type", "plane"}, {"point_m", {0, 0, 0}}, {"normal", {0, 0, 1}}}}},
          {"gravity_m_per_s2", {0, 0, -9.81}},
          {"time", {{"end_s", end_s}, {"step_s", 2e-5}}},
          {"output", {{"h5", false}, {"snapshot_interval_s", 0.01}}}};
}

TEST(HoldupHistory, AStreamFallingThroughAnOutletIsSteadyAfterItsFallTime) {
  const double end_s = 0.3, g = 9.81, h = 0.05, v0 = 1.0, rate = 2e-3;
  const double fall_s = (-v0 + std::sqrt(v0 * v0 + 2.0 * g * h)) / g;  // 41.5 ms
  const double bead_kg = 2500.0 * std::numbers::pi / 6.0 * 1e-9;
  const nlohmann::json result = test::run_scene_document(falling_stream_scene(end_s));
  ASSERT_TRUE(result.contains("steady_state"));
  const nlohmann::json& steady = result["steady_state"];
  ASSERT_TRUE(steady.is_object());
  EXPECT_EQ(steady["window_from"], "last third");
  EXPECT_NEAR(steady["window_s"][0].get<double>(), 0.2, 1e-9);
  EXPECT_NEAR(steady["window_s"][1].get<double>(), end_s, 1e-9);
  // A bead is fed when the accrued mass covers it and leaves at a population update (at most 64
  // steps late): the counts in a 0.1 s window may differ by one bead each way.
  const double fed = steady["fed_kg"].get<double>();
  EXPECT_NEAR(fed, rate * 0.1, 1.01 * bead_kg);
  EXPECT_NEAR(steady["outflow_kg"].get<double>(), fed, 2.01 * bead_kg);
  EXPECT_TRUE(steady["steady"].get<bool>());
  EXPECT_NEAR(steady["particles_change_kg"].get<double>(), 0.0, 2.01 * bead_kg);
  // The hold-up is what the feed brings in one fall time.
  const nlohmann::json& history = result["holdup_history"];
  ASSERT_TRUE(history.is_object());
  const nlohmann::json& held = history["particles_kg"];
  ASSERT_EQ(held.size(), 31u) << "a row every 10 ms and one at the start";
  EXPECT_NEAR(held.back().get<double>(), rate * fall_s, 2.01 * bead_kg);
  EXPECT_NEAR(history["time_s"][3].get<double>(), 0.03, 1e-9);
  EXPECT_EQ(history["outlet_kg"][3].get<double>(), 0.0) << "nothing left before its fall time";
  // Projected from the same window (process/steady_projection.h): the stream is steady already,
  // holds F t_f, and its product is the feed's beads at the feed rate.
  const nlohmann::json& projection = result["steady_projection"];
  ASSERT_TRUE(projection.is_object());
  EXPECT_TRUE(projection["steady_state_exists"].get<bool>());
  EXPECT_NEAR(projection["holdup_kg"]["particles"].get<double>(), rate * fall_s, 2.01 * bead_kg);
  EXPECT_NEAR(projection["product"]["kg_per_s"].get<double>(), fed / 0.1, 2.01 * bead_kg / 0.1);
  EXPECT_NEAR(projection["product"]["d50_m"].get<double>(), 1e-3, 0.3e-3) << "the beads' class";
  EXPECT_EQ(projection["time_to_steady_s"].get<double>(), 0.0);
  // A product window before the fall time: nothing left, nothing steady; and with nothing seen
  // leaving, the projection finds the beads accumulating.
  nlohmann::json early = falling_stream_scene(0.1);
  early["psd"] = {{"product_window_s", {0.0, 0.04}}};
  const nlohmann::json early_result = test::run_scene_document(early);
  const nlohmann::json& w = early_result["steady_state"];
  ASSERT_TRUE(w.is_object());
  EXPECT_EQ(w["window_from"], "product_window_s");
  EXPECT_EQ(w["outflow_kg"].get<double>(), 0.0);
  EXPECT_FALSE(w["steady"].get<bool>());
  const nlohmann::json& early_projection = early_result["steady_projection"];
  ASSERT_TRUE(early_projection.is_object());
  EXPECT_FALSE(early_projection["steady_state_exists"].get<bool>());
  ASSERT_EQ(early_projection["accumulating"].size(), 1u);
  EXPECT_EQ(early_projection["accumulating"][0]["phase"], "particles");
  EXPECT_TRUE(early_projection["time_to_steady_s"].is_null());
}

// The last row of a breakage run's history against the run's own tallies: the hold-up by class
// sums to the particles' mass, the dust made by class to the dust table's, the events by
// generation to the events; every row's fed = particles + outlet + dust made (to rounding).
TEST(HoldupHistory, ItsRowsAddUpToTheRunsTallies) {
  std::ifstream file(std::string(MILLSIM_SOURCE_DIR) + "/cases/attrition_target.json");
  nlohmann::json doc = nlohmann::json::parse(file);
  doc["time"]["end_s"] = 0.0012;
  doc["dust"]["threshold_diameter_m"] = 6e-5;  // a coarser threshold: a larger step
  doc["output"] = {{"h5", false}, {"snapshot_interval_s", 3e-4}};
  std::unique_ptr<Simulation> run;
  const nlohmann::json h = test::run_scene_document(doc, &run)["holdup_history"];
  ASSERT_TRUE(run);
  const Simulation& sim = *run;
  ASSERT_TRUE(h.is_object());
  ASSERT_GE(h["time_s"].size(), 5u) << "rows at 0, 0.3, 0.6, 0.9 ms and at the end";
  EXPECT_EQ(h["time_s"].back().get<double>(), sim.time_s());
  auto sum = [](const nlohmann::json& v) {
    double s = 0.0;
    for (const auto& x : v) s += x.get<double>();
    return s;
  };
  const MassBalance m = sim.mass_balance();
  ASSERT_GT(m.dust_kg, 0.0);
  EXPECT_NEAR(sum(h["particles_by_class_kg"].back()), m.particles_kg, 1e-12 * m.fed_kg);
  EXPECT_NEAR(h["particles_kg"].back().get<double>(), m.particles_kg, 1e-12 * m.fed_kg);
  EXPECT_NEAR(sum(h["dust_made_by_class_kg"].back()), m.dust_kg, 1e-12 * m.fed_kg);
  const BreakageStats& b = sim.breakage()->stats();
  double events = 0.0;
  for (const auto& e : h["events_by_generation"].back()) events += e.get<double>();
  EXPECT_EQ(events, double(b.events));
  // The mass flows by slot (process/mass_flows.h): what breakage moved out of the particles is
  // the broken mass, what it moved into dust is the table's, its events are the run's, and the
  // particles' hold-up by slot is the store's.
  const std::optional<MassFlows> flows = sim.mass_flows();
  ASSERT_TRUE(flows);
  double moved_out = 0.0, moved_to_dust = 0.0, flow_events = 0.0, held = 0.0;
  for (int from = 0; from < flows->slots; ++from) {
    flow_events += flows->events[std::size_t(from)];
    held += flows->tracked_now_kg[std::size_t(from)];
    for (int to = 0; to < flows->compartments(); ++to) {
      moved_out += flows->moved(from, to);
      if (to >= flows->slots) moved_to_dust += flows->moved(from, to);
    }
  }
  EXPECT_NEAR(moved_out, b.broken_mass_kg, 1e-12 * m.fed_kg);
  EXPECT_NEAR(moved_to_dust, m.dust_kg, 1e-12 * m.fed_kg);
  EXPECT_EQ(flow_events, double(b.events));
  EXPECT_NEAR(held, m.particles_kg, 1e-12 * m.fed_kg);
  for (std::size_t i = 0; i < h["time_s"].size(); ++i) {
    const double fed = h["fed_kg"][i].get<double>();
    EXPECT_NEAR(h["particles_kg"][i].get<double>() + h["outlet_kg"][i].get<double>() +
                    h["dust_made_kg"][i].get<double>(),
                fed, 1e-12 * m.fed_kg)
        << "row " << i;
  }
}

}  // namespace
}  // namespace millsim
