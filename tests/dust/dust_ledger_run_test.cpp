// The dust ledger in a run (issue 31): particles fired at a target break, their sub-threshold
// mass enters the ledger in the gas cells where they broke, and a downward gas flow carries it
// out through the gas outlet while tracked rebounds and fragments fall through the particle
// outlet. Expectations from conservation alone: the ledger holds what the breakage made minus
// what left (to 1e-12), the mass balance closes (to 1e-12), the product is the outlet particles
// plus the dust that crossed the gas outlet, and a scene asking for a ledger without gas is
// refused naming the key.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "scene/scene_json.h"
#include "sim/run.h"
#include "sim/simulation.h"
#include "support/h5_read.h"
#include "support/scenes.h"

namespace millsim {
namespace {

nlohmann::json ledger_scene() {
  std::ifstream in(std::string(MILLSIM_SOURCE_DIR) + "/cases/attrition_target.json");
  nlohmann::json doc = nlohmann::json::parse(in);
  doc["dust"]["model"] = "ledger";
  doc["time"]["end_s"] = 0.0012;
  doc["dust"]["threshold_diameter_m"] = 6e-5;  // a coarser threshold: a larger step
  doc["output"] = {{"h5", false}};
  // Air blown down from the top at 8 m/s, out through the bottom face.
  doc["gas"] = {
      {"density_kg_per_m3", 1.2},
      {"viscosity_pa_s", 1.8e-5},
      {"cells", {8, 4, 10}},
      {"boundaries",
       {{{"name", "top"}, {"face", "z+"}, {"type", "inlet"}, {"velocity_m_per_s", {0, 0, -8.0}}},
        {{"name", "bottom"}, {"face", "z-"}, {"type", "outlet"}, {"pressure_pa", 0}}}}};
  return doc;
}

TEST(DustLedgerRun, BrokenDustRidesTheGasOutAndEveryKilogramIsAccountedFor) {
  InputErrors errors;
  const SceneConfig scene = parse_scene(ledger_scene(), ".", errors);
  for (const InputError& e : errors) ADD_FAILURE() << e.path << " " << e.value << ": " << e.allowed;
  ASSERT_TRUE(errors.empty());
  Simulation sim(scene);
  while (sim.step_index() < sim.total_steps()) ASSERT_FALSE(sim.step());
  const DustLedger* dust = sim.dust_ledger();
  ASSERT_NE(dust, nullptr);
  const double made = sim.breakage()->dust().total_mass_kg();
  ASSERT_GT(sim.breakage()->stats().events, 0u) << "the target broke particles";
  ASSERT_GT(made, 0.0);
  EXPECT_NEAR(dust->held_kg() + dust->outflow_kg(), made, 1e-12 * made) << "held + out = made";
  EXPECT_GT(dust->outflow_kg(), 0.0) << "the gas carried dust out";
  EXPECT_GT(dust->held_kg(), 0.0) << "and some is still on its way";
  EXPECT_GT(sim.outlet_tally().total_mass_kg(), 0.0) << "tracked particles left too";
  const MassBalance m = sim.mass_balance();
  EXPECT_LT(std::abs(m.relative_error()), 1e-12);
  // The product: outlet particles + dust out, not the dust made.
  EXPECT_NEAR(sim.product_tally().total_mass_kg(),
              sim.outlet_tally().total_mass_kg() + dust->outflow_kg(),
              1e-12 * sim.product_tally().total_mass_kg());
  EXPECT_LT(dust->outflow_kg(), made) << "the product is not the dust table";
}

TEST(DustLedgerRun, SnapshotsHoldTheDustConcentrationAndResultJsonItsHistory) {
  // Expectation: the snapshot's concentration per class, times the cell volume, sums to the
  // ledger's hold-up; result.json's history ends at the ledger's final held and out masses and
  // the outflow never falls.
  nlohmann::json doc = ledger_scene();
  doc["output"] = {{"h5", true}, {"snapshot_interval_s", 0.0006}};
  InputErrors errors;
  const SceneConfig scene = parse_scene(doc, ".", errors);
  ASSERT_TRUE(errors.empty());
  test::TempDir dir;
  Simulation sim(scene);
  RunOptions options;
  options.out_dir = dir.path();
  ASSERT_FALSE(run_simulation(sim, scene, options).failure);
  const DustLedger* dust = sim.dust_ledger();
  ASSERT_NE(dust, nullptr);
  ASSERT_GT(dust->held_kg(), 0.0);

  const hid_t file = H5Fopen((dir.path() / "run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  char group[64];
  std::snprintf(group, sizeof group, "/snapshots/s%09lld/",
                static_cast<long long>(sim.step_index()));
  const double cell_volume = dust->grid().cell_volume_m3();
  double held = 0.0;
  for (int k = 0; k < dust->class_count(); ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "gas_dust_c%02d_kg_per_m3", k);
    double class_held = 0.0;
    for (double c : test::read_doubles(file, std::string(group) + name))
      class_held += c * cell_volume;
    EXPECT_NEAR(class_held, dust->held_kg(k), 1e-12 * dust->held_kg() + 1e-30) << "class " << k;
    held += class_held;
  }
  H5Fclose(file);
  EXPECT_NEAR(held, dust->held_kg(), 1e-12 * dust->held_kg());
  std::ifstream xdmf(dir.path() / "gas.xdmf");
  std::stringstream text;
  text << xdmf.rdbuf();
  EXPECT_NE(text.str().find("Name=\"dust_c00_kg_per_m3\""), std::string::npos);

  std::ifstream in(dir.path() / "result.json");
  const nlohmann::json result = nlohmann::json::parse(in);
  const nlohmann::json& history = result["dust_ledger"]["history"];
  ASSERT_TRUE(history.contains("outflow_kg"));
  const std::vector<double> out = history["outflow_kg"].get<std::vector<double>>();
  ASSERT_GE(out.size(), 2u);
  for (std::size_t i = 1; i < out.size(); ++i) EXPECT_GE(out[i], out[i - 1]) << "row " << i;
  EXPECT_EQ(out.back(), dust->outflow_kg());
  EXPECT_EQ(history["held_kg"].back().get<double>(), dust->held_kg());
  EXPECT_EQ(history["held_by_class_kg"].size(), std::size_t(dust->class_count()));
}

// With psd.product_window_s = [t0, end], the product must be the outlet particles and the dust
// that left (the ledger's outflow, or the table's dust made) from the step reaching t0 on: the
// same run without a window, read just before that step and at the end, gives it by difference.
// `dust_out` reads the dust that counts as product so far.
template <class DustOut>
void expect_window_by_difference(nlohmann::json doc, double t0, DustOut dust_out) {
  InputErrors errors;
  const SceneConfig whole_scene = parse_scene(doc, ".", errors);
  doc["psd"]["product_window_s"] = {t0, doc["time"]["end_s"]};
  const SceneConfig window_scene = parse_scene(doc, ".", errors);
  ASSERT_TRUE(errors.empty());
  Simulation whole(whole_scene), windowed(window_scene);
  double outlet_before = 0.0, dust_before = 0.0;
  bool reached = false;
  while (whole.step_index() < whole.total_steps()) {
    const double outlet = whole.outlet_tally().total_mass_kg(), dust = dust_out(whole);
    ASSERT_FALSE(whole.step());
    if (!reached && whole.time_s() >= t0)
      reached = true, outlet_before = outlet, dust_before = dust;
  }
  while (windowed.step_index() < windowed.total_steps()) ASSERT_FALSE(windowed.step());
  const double outlet_in = whole.outlet_tally().total_mass_kg() - outlet_before;
  const double dust_in = dust_out(whole) - dust_before;
  ASSERT_GT(outlet_in, 0.0);
  ASSERT_GT(dust_in, 0.0);
  ASSERT_GT(dust_before, 0.0) << "the window leaves some dust out";
  const double product = windowed.product_tally().total_mass_kg();
  EXPECT_NEAR(product, outlet_in + dust_in, 1e-12 * product);
  EXPECT_LT(product, whole.product_tally().total_mass_kg());
}

TEST(DustLedgerRun, TheProductWindowCountsWhatLeavesInsideIt) {
  expect_window_by_difference(ledger_scene(), 0.0006,
                              [](const Simulation& s) { return s.dust_ledger()->outflow_kg(); });
}

TEST(DustLedgerRun, WithTheTableTheWindowCountsTheDustMadeInsideIt) {
  nlohmann::json doc = ledger_scene();
  doc.erase("gas");
  doc["dust"].erase("model");
  expect_window_by_difference(
      doc, 0.0006, [](const Simulation& s) { return s.breakage()->dust().total_mass_kg(); });
}

TEST(DustLedgerRun, AProductWindowOutsideTheRunIsRefused) {
  nlohmann::json doc = ledger_scene();
  doc["psd"]["product_window_s"] = {0.001, 0.002};  // the run ends at 1.2 ms
  bool named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/psd/product_window_s/1";
  EXPECT_TRUE(named);
  doc["psd"]["product_window_s"] = {0.001, 0.0005};
  named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/psd/product_window_s/1";
  EXPECT_TRUE(named) << "an end before the start";
}

TEST(DustLedgerRun, ALedgerNeedsAGas) {
  nlohmann::json doc = ledger_scene();
  doc.erase("gas");
  bool named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/dust/model";
  EXPECT_TRUE(named);
}

// The same scene on the compressible gas, its outlet at atmospheric pressure.
nlohmann::json compressible_ledger_scene() {
  nlohmann::json doc = ledger_scene();
  doc["gas"].erase("density_kg_per_m3");
  doc["gas"]["model"] = "compressible";
  doc["gas"]["boundaries"][1]["pressure_pa"] = 101325.0;
  return doc;
}

struct DustyRun {
  double weight_time_n_s = 0;  // g ∫ (dust held) dt
  double impulse_z_n_s = 0, max_loading = 0, mass_loading = 0;
  bool two_way = false, has_impulse = false;
  int lays = 0;                   // gas advances that took a new dust field
  double worst_lay_mismatch = 0;  // |Σ c V − dust held| / held over them
};

DustyRun run_dusty(const nlohmann::json& doc) {
  InputErrors errors;
  const SceneConfig scene = parse_scene(doc, ".", errors);
  for (const InputError& e : errors) ADD_FAILURE() << e.path << " " << e.value << ": " << e.allowed;
  Simulation sim(scene);
  DustyRun r;
  const double g = -scene.gravity_m_per_s2.z;
  std::vector<double> laid;
  while (sim.step_index() < sim.total_steps()) {
    const double dt = sim.time_step().step_s;
    const auto failure = sim.step();
    EXPECT_FALSE(failure);
    if (failure) break;
    r.weight_time_n_s += g * sim.dust_ledger()->held_kg() * dt;
    // The dust the gas carries is the ledger's: in a closed box it neither leaves nor is made
    // between the gas's advance and the ledger's, so the field laid on the gas holds it all.
    const CompressibleSolver* gas = sim.gas()->compressible();
    if (!gas->dust_density().empty() && gas->dust_density() != laid) {
      laid = gas->dust_density();
      double sum = 0;
      for (double c : laid) sum += c;
      const double held = sim.dust_ledger()->held_kg();
      sum *= gas->grid().cell_volume_m3();
      if (held > 0)
        r.worst_lay_mismatch = std::max(r.worst_lay_mismatch, std::abs(sum - held) / held);
      ++r.lays;
    }
  }
  // The steps are done: the run only writes its summary.
  const nlohmann::ordered_json summary = run_simulation(sim, scene, RunOptions{}).summary;
  r.two_way = summary["dust_ledger"]["gas_coupling"] == "two_way";
  r.max_loading = summary["dust_ledger"]["max_cell_mass_loading"].get<double>();
  r.mass_loading = summary["dust_ledger"]["mass_loading"].get<double>();
  r.has_impulse = summary["gas"].contains("dust_impulse_n_s");
  if (r.has_impulse) r.impulse_z_n_s = summary["gas"]["dust_impulse_n_s"][2].get<double>();
  EXPECT_GT(sim.breakage()->dust().total_mass_kg(), 0.0);
  EXPECT_NEAR(sim.dust_ledger()->held_kg() / sim.gas()->compressible()->total_mass_kg(),
              r.mass_loading, 1e-12 * r.mass_loading);
  return r;
}

TEST(DustLedgerRun, OnTheCompressibleGasTheDustItCarriesWeighsOnIt) {
  // The target's scene in a closed box of still gas, the particles' drag left off the gas: the
  // dust made is all that moves the gas. It falls at first, its weight unsupported, and the
  // gas below it takes its weight as it compresses: the impulse the gas gives it is upwards and
  // at most its weight over the time (the column needs a few ms of its own sound to stand
  // fully; DustyGas.* check that the balance it reaches is the mixture's).
  nlohmann::json doc = compressible_ledger_scene();
  doc["gas"]["coupling"] = "one_way";
  doc["gas"].erase("boundaries");
  doc["time"]["end_s"] = 0.0006;  // the target has broken for 0.4 ms by then
  const DustyRun two = run_dusty(doc);
  doc["dust"]["gas_coupling"] = "one_way";
  const DustyRun one = run_dusty(doc);
  std::printf(
      "dust impulse %.4e N s, its weight times time %.4e N s; largest cell loading %.3g, "
      "the domain's %.3g; %d dust fields laid, worst mismatch %.2e\n",
      two.impulse_z_n_s, two.weight_time_n_s, two.max_loading, two.mass_loading, two.lays,
      two.worst_lay_mismatch);
  EXPECT_TRUE(two.two_way) << "the default with the compressible gas";
  ASSERT_TRUE(two.has_impulse);
  EXPECT_GT(two.lays, 10);
  EXPECT_LT(two.worst_lay_mismatch, 1e-12);
  EXPECT_GT(two.impulse_z_n_s, 0.0);
  EXPECT_LT(two.impulse_z_n_s, two.weight_time_n_s);
  EXPECT_GT(two.max_loading, two.mass_loading);
  EXPECT_FALSE(one.two_way);
  EXPECT_FALSE(one.has_impulse);
  EXPECT_EQ(one.lays, 0);
  EXPECT_GT(one.max_loading, 0.0) << "reported one-way too, to judge it by";
}

struct CarriedRun {
  double made_kg = 0, held_kg = 0, out_kg = 0;
  std::uint64_t advances = 0, substeps = 0, cfd_steps = 0;
  int classes = 0;
};

CarriedRun run_carried(nlohmann::json doc, double carry_courant) {
  doc["dust"]["carry_courant"] = carry_courant;
  InputErrors errors;
  const SceneConfig scene = parse_scene(doc, ".", errors);
  for (const InputError& e : errors) ADD_FAILURE() << e.path << " " << e.value << ": " << e.allowed;
  Simulation sim(scene);
  while (sim.step_index() < sim.total_steps()) {
    const auto failure = sim.step();
    EXPECT_FALSE(failure);
    if (failure) break;
  }
  CarriedRun r;
  const DustLedger* dust = sim.dust_ledger();
  if (!dust) {
    ADD_FAILURE() << "no ledger";
    return r;
  }
  r.made_kg = sim.breakage()->dust().total_mass_kg();
  r.held_kg = dust->held_kg(), r.out_kg = dust->outflow_kg();
  r.advances = dust->stats().advances, r.substeps = dust->stats().substeps;
  r.cfd_steps = sim.gas()->stats().cfd_steps;
  r.classes = dust->class_count();
  return r;
}

TEST(DustLedgerRun, TheLedgerIsCarriedAtItsOwnCourantStepNotTheGassAcousticOne) {
  // Expectation: the compressible gas steps at its acoustic limit, Courant × h / (|u| + c), while
  // the dust moves at the gas's 8 m/s plus a slip of up to 34 m/s: carried at a Courant sum of
  // 0.5, it needs about 0.5 / Courant × (|u| + c) / |u_dust| fewer carries than the gas has
  // steps (at least 10 asked; 32 here), and few sub-steps (a class takes a second one only where
  // its rate rose since the last carry: fewer than two per class and carry on average). Carried
  // either way it is the same dust: held + out = made to 1e-12. What reached the outlet by the
  // end is the front of the dust made over the last millisecond, and an upwind scheme spreads a
  // front by a numerical diffusion u h (1 − C) / 2 that shrinks as the Courant number C grows,
  // so carried at C = 0.5 its front is sharper and arrives no earlier than at every CFD step (C
  // about 0.016): less outflow, but not 10 % less (measured, 0.02 / 0.1 / 0.25 / 0.5: 9.91 /
  // 9.83 / 9.66 / 9.40e-7 kg).
  nlohmann::json doc = compressible_ledger_scene();
  doc["dust"]["gas_coupling"] = "one_way";  // the same particles, the same dust made
  const CarriedRun every = run_carried(doc, 0.0);
  const CarriedRun own = run_carried(doc, 0.5);
  std::printf(
      "CFD steps %llu; every step: %llu carries, %llu sub-steps; own step: %llu carries, %llu "
      "sub-steps (%d classes); out %.4e against %.4e kg of %.4e made\n",
      (unsigned long long)every.cfd_steps, (unsigned long long)every.advances,
      (unsigned long long)every.substeps, (unsigned long long)own.advances,
      (unsigned long long)own.substeps, own.classes, own.out_kg, every.out_kg, own.made_kg);
  ASSERT_GT(every.made_kg, 0.0);
  EXPECT_EQ(own.made_kg, every.made_kg) << "one-way: the dust does not change the particles";
  EXPECT_GE(every.advances + 1, every.cfd_steps)
      << "every CFD step but the one before the first step";
  EXPECT_GT(own.advances, 0u);
  EXPECT_LE(own.advances * 10, every.advances);
  EXPECT_GE(own.substeps, own.advances * std::uint64_t(own.classes));
  EXPECT_LT(own.substeps, 2 * own.advances * std::uint64_t(own.classes));
  for (const CarriedRun* r : {&every, &own})
    EXPECT_NEAR(r->held_kg + r->out_kg, r->made_kg, 1e-12 * r->made_kg);
  ASSERT_GT(every.out_kg, 0.0);
  EXPECT_LE(own.out_kg, every.out_kg);
  EXPECT_GT(own.out_kg, 0.9 * every.out_kg);
}

TEST(DustLedgerRun, TheCarryCourantIsCheckedByName) {
  for (const nlohmann::json& bad :
       {nlohmann::json(-0.1), nlohmann::json(0.51), nlohmann::json("x")}) {
    nlohmann::json doc = compressible_ledger_scene();
    doc["dust"]["carry_courant"] = bad;
    bool named = false;
    for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/dust/carry_courant";
    EXPECT_TRUE(named) << bad.dump();
  }
  nlohmann::json doc = compressible_ledger_scene();
  doc["dust"]["model"] = "table";
  doc["dust"]["carry_courant"] = 0.25;
  bool named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/dust/carry_courant";
  EXPECT_TRUE(named) << "the table is not carried";
  doc["dust"]["model"] = "ledger";
  EXPECT_TRUE(test::scene_errors(doc).empty());
}

TEST(DustLedgerRun, TwoWayDustNeedsTheCompressibleGasAndTheLedger) {
  nlohmann::json doc = ledger_scene();
  doc["dust"]["gas_coupling"] = "two_way";
  bool named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/dust/gas_coupling";
  EXPECT_TRUE(named) << "the incompressible gas";
  doc = compressible_ledger_scene();
  doc["dust"]["gas_coupling"] = "both";
  named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/dust/gas_coupling";
  EXPECT_TRUE(named) << "not a coupling";
  doc = compressible_ledger_scene();
  doc["dust"]["model"] = "table";
  doc["dust"]["gas_coupling"] = "one_way";
  named = false;
  for (const InputError& e : test::scene_errors(doc)) named |= e.path == "/dust/gas_coupling";
  EXPECT_TRUE(named) << "the table has no gas to couple";
}

}  // namespace
}  // namespace millsim
