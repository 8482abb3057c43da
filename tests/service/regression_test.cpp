// Regression suites without running anything: the suite parser reports every problem at once,
// quantities are measured from result.json documents as their definitions say, each tolerance
// decides pass and drift at its edge, `exact` is compared only against the same build, a failed
// check fails its quantities, the JUnit text counts them, and a stored record is validated. A
// check with repeats compares means: its tolerance in sigmas decides at the standard error of the
// difference, and raises false alarms at Student's t rate when nothing but the seed changed.
#include "regression/regression.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "build_info.h"

namespace millsim {
namespace {

using nlohmann::json;

const std::filesystem::path kCases = MILLSIM_SOURCE_DIR "/cases";

// A scene check on the two-sphere impact with the given quantities.
json suite_with(const json& quantities) {
  return {{"name", "unit"},
          {"checks",
           {{{"name", "impact"},
             {"scene", (kCases / "impact_two_spheres.json").string()},
             {"quantities", quantities}}}}};
}

json quantity(const json& fields) {
  json q = fields;
  q["reason"] = "test";
  return q;
}

// result.json-like: kinetic energy 4 → 1, 3 pairs and 2 wall contacts, an outlet d50.
json document() {
  return {{"energy", {{"initial", {{"kinetic_j", 4.0}}}, {"final", {{"kinetic_j", 1.0}}}}},
          {"contacts", {{"pairs", 3}, {"walls", 2}}},
          {"outlet_psd", {{"d50_m", 2e-5}}},
          {"steps", 517}};
}

std::map<std::string, CheckOutcome> ok_outcome(const json& doc = document()) {
  return {{"impact", CheckOutcome{true, "", doc, {}}}};
}

json baseline_of(const json& values, const json& build) {
  return {{"suite", "unit"}, {"build", build}, {"values", {{"impact", values}}}};
}

TEST(RegressionSuite, TheShippedSuiteValidates) {
  const RegressionSuite suite = load_regression_suite(kCases / "regression/physics.json", 1000);
  EXPECT_EQ(suite.name, "physics");
  EXPECT_GE(suite.checks.size(), 8u);
  EXPECT_EQ(suite.baseline_path, kCases / "regression/baseline.json");
  bool has_study = false;
  for (const RegressionCheck& c : suite.checks) has_study = has_study || c.is_study;
  EXPECT_TRUE(has_study);
}

TEST(RegressionSuite, EveryProblemIsReportedAtOnce) {
  json spec = suite_with(json::array({
      quantity({{"pointer", "/steps"}, {"derived", "outlet_d50"}, {"tolerance", "exact"}}),
      quantity({{"derived", "outlet_d51"}, {"tolerance", {{"relative", -1}}}}),
      {{"pointer", "steps"}, {"tolerance", {{"absolute", 1}, {"relative", 1}}}},
  }));
  spec["checks"].push_back({{"name", "impact"},
                            {"scene", (kCases / "impact_two_spheres.json").string()},
                            {"study", "x.json"},
                            {"quantities", json::array()}});
  spec["checks"].push_back(
      {{"name", "bad scene"},
       {"scene", (kCases / "impact_two_spheres.json").string()},
       {"set", {{"materials.0.restitution", 2.0}}},
       {"quantities", {quantity({{"pointer", "/steps"}, {"tolerance", "exact"}})}}});
  std::vector<std::string> paths;
  try {
    parse_regression_suite(spec, kCases, 1000);
    FAIL() << "the suite was accepted";
  } catch (const InputErrorList& e) {
    for (const InputError& err : e.errors()) paths.push_back(err.path + " | " + err.allowed);
  }
  auto reported = [&](const std::string& needle) {
    for (const std::string& p : paths)
      if (p.find(needle) != std::string::npos) return true;
    return false;
  };
  std::string all;
  for (const std::string& p : paths) all += p + "\n";
  EXPECT_TRUE(reported("/checks/0/quantities/0 | give exactly one of pointer")) << all;
  EXPECT_TRUE(reported("/checks/0/quantities/1/derived | expected outlet_d10")) << all;
  EXPECT_TRUE(reported("/checks/0/quantities/1/tolerance/relative")) << all;
  EXPECT_TRUE(reported("/checks/0/quantities/2/pointer | expected a JSON pointer")) << all;
  EXPECT_TRUE(reported("/checks/0/quantities/2/tolerance | expected \"exact\"")) << all;
  EXPECT_TRUE(reported("/checks/0/quantities/2/reason")) << all;
  EXPECT_TRUE(reported("/checks/1/name | each check name once")) << all;
  EXPECT_TRUE(reported("/checks/1/quantities | expected a list of at least one")) << all;
  EXPECT_TRUE(reported("/checks/1 | give exactly one of scene")) << all;
  EXPECT_TRUE(reported("/checks/2/name | expected 1-64 characters")) << all;
  EXPECT_TRUE(reported("/checks/2 run 0 () /materials/0/restitution")) << all;
}

TEST(RegressionSuite, DerivedQuantitiesFollowTheirDefinitions) {
  auto q = [](const std::string& derived) {
    RegressionQuantity r;
    r.derived = derived;
    return r;
  };
  std::string problem;
  EXPECT_DOUBLE_EQ(*measure_quantity(document(), q("kinetic_energy_ratio"), problem), 0.25);
  EXPECT_DOUBLE_EQ(*measure_quantity(document(), q("contact_count"), problem), 5.0);
  EXPECT_DOUBLE_EQ(*measure_quantity(document(), q("outlet_d50"), problem), 2e-5);
  EXPECT_FALSE(measure_quantity(document(), q("outlet_d90"), problem));
  EXPECT_NE(problem.find("/outlet_psd/d90_m"), std::string::npos) << problem;
  RegressionQuantity p;
  p.pointer = "/contacts/pairs";
  EXPECT_DOUBLE_EQ(*measure_quantity(document(), p, problem), 3.0);
}

// The baseline 0.2 for a measured 0.25: relative 0.25 passes (0.05 ≤ 0.25·0.2 = 0.05), 0.2 does
// not; absolute 0.05 passes, 0.049 does not.
TEST(RegressionSuite, TolerancesDecideAtTheirEdge) {
  const json build = build_description();
  struct Case {
    json tolerance;
    std::string verdict;
  };
  for (const Case& c :
       {Case{{{"relative", 0.25}}, "pass"}, Case{{{"relative", 0.2}}, "drift"},
        Case{{{"absolute", 0.0500001}}, "pass"}, Case{{{"absolute", 0.049}}, "drift"}}) {
    const RegressionSuite suite = parse_regression_suite(
        suite_with(json::array(
            {quantity({{"derived", "kinetic_energy_ratio"}, {"tolerance", c.tolerance}})})),
        kCases, 10);
    const auto rows = compare_with_baseline(
        suite, ok_outcome(), baseline_of({{"kinetic_energy_ratio", 0.2}}, build), build);
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(rows[0].verdict, c.verdict) << c.tolerance.dump();
    EXPECT_DOUBLE_EQ(*rows[0].measured, 0.25);
    EXPECT_DOUBLE_EQ(*rows[0].reference, 0.2);
    if (c.verdict == "drift") {
      EXPECT_NE(rows[0].message.find("measured 0.25, baseline 0.2, off by"), std::string::npos)
          << rows[0].message;
      EXPECT_NE(rows[0].message.find("tolerance " + rows[0].tolerance), std::string::npos);
    }
  }
}

TEST(RegressionSuite, ExactComparesOnlyAgainstTheSameBuild) {
  const json build = build_description();
  json other = build;
  other["git_commit"] = "0123456789ab";
  const RegressionSuite suite = parse_regression_suite(
      suite_with(json::array({quantity({{"pointer", "/steps"}, {"tolerance", "exact"}})})), kCases,
      10);
  auto verdict = [&](double base, const json& from) {
    return compare_with_baseline(suite, ok_outcome(), baseline_of({{"/steps", base}}, from),
                                 build)[0]
        .verdict;
  };
  EXPECT_EQ(verdict(517, build), "pass");
  EXPECT_EQ(verdict(518, build), "drift");
  EXPECT_EQ(verdict(518, other), "skipped");
  // An expected value is compared exactly whatever the baseline's build.
  const RegressionSuite expect = parse_regression_suite(
      suite_with(json::array(
          {quantity({{"pointer", "/steps"}, {"tolerance", "exact"}, {"expect", 516}})})),
      kCases, 10);
  const auto rows =
      compare_with_baseline(expect, ok_outcome(), baseline_of({{"/steps", 517}}, other), build);
  EXPECT_EQ(rows[0].verdict, "drift");
  EXPECT_EQ(rows[0].reference_kind, "expected");
}

TEST(RegressionSuite, FailedRunsMissingValuesAndNoBaselineFail) {
  const json build = build_description();
  const RegressionSuite suite = parse_regression_suite(
      suite_with(json::array(
          {quantity({{"pointer", "/steps"}, {"tolerance", {{"relative", 0.1}}}}),
           quantity({{"pointer", "/nothing/here"}, {"tolerance", {{"relative", 0.1}}}})})),
      kCases, 10);
  const json base = baseline_of({{"/steps", 517}, {"/nothing/here", 1}}, build);
  std::map<std::string, CheckOutcome> failed = {
      {"impact",
       CheckOutcome{false, "run s000001-r0 ended EXECUTOR_ERROR (exit 3): unstable", {}, {}}}};
  for (const RegressionRow& r : compare_with_baseline(suite, failed, base, build)) {
    EXPECT_EQ(r.verdict, "failed");
    EXPECT_NE(r.message.find("EXECUTOR_ERROR (exit 3)"), std::string::npos);
    EXPECT_TRUE(row_fails(r));
  }
  const auto rows = compare_with_baseline(suite, ok_outcome(), base, build);
  EXPECT_EQ(rows[0].verdict, "pass");
  EXPECT_EQ(rows[1].verdict, "missing");
  EXPECT_EQ(compare_with_baseline(suite, ok_outcome(), nullptr, build)[0].verdict, "no_baseline");

  const json record = regression_record(suite, rows, base, build, 1.8e9, false, {});
  EXPECT_FALSE(record["passed"].get<bool>());
  EXPECT_EQ(record["counts"]["failures"], 1);
  EXPECT_TRUE(validate_regression_record(record).empty());
  const std::string xml = junit_xml(record);
  EXPECT_NE(xml.find("tests=\"2\" failures=\"1\""), std::string::npos) << xml;
  EXPECT_NE(xml.find("<failure type=\"missing\""), std::string::npos) << xml;
  const std::string table = drift_table_text(record);
  EXPECT_NE(table.find("unit: FAILED, 2 quantities in 1 checks, 1 failing"), std::string::npos)
      << table;
}

TEST(RegressionSuite, StoredRecordsAreValidated) {
  json record = {{"suite", "physics"},
                 {"passed", true},
                 {"build", json::object()},
                 {"rows", {{{"check", "a"}, {"quantity", "b"}, {"verdict", "drift"}}}}};
  InputErrors errors = validate_regression_record(record);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "/passed");
  record["rows"][0]["verdict"] = "fine";
  record["rows"][0]["measured"] = "1.0";
  record.erase("build");
  errors = validate_regression_record(record);
  ASSERT_EQ(errors.size(), 1u) << errors[0].path;
  EXPECT_EQ(errors[0].path, "/build");
  record["build"] = json::object();
  errors = validate_regression_record(record);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].path, "/rows/0/measured");
  EXPECT_EQ(errors[1].path, "/rows/0/verdict");
}

TEST(RegressionSuite, BaselineChangesNameEveryValueThatMoved) {
  const json before = {{"values", {{"a", {{"x", 1.0}, {"y", 2.0}, {"gone", 3.0}}}}}};
  const json after = {{"values", {{"a", {{"x", 1.0}, {"y", 2.5}}}, {"b", {{"z", 4.0}}}}}};
  const std::string changes = baseline_changes(before, after);
  EXPECT_EQ(changes, "a y: 2 -> 2.5\nb z: new, 4\na gone: removed (was 3)\n");
  EXPECT_EQ(baseline_changes(after, after), "");
}

// A scene check of `repeats` runs of the breakage-probability scene (its result depends on the
// seed) with the given quantities.
json repeated_suite(int repeats, const std::vector<json>& quantities) {
  return {{"name", "unit"},
          {"checks",
           {{{"name", "impact"},
             {"scene", (kCases / "regression/breakage_probability.json").string()},
             {"repeats", repeats},
             {"quantities", json(quantities)}}}}};
}

// An outcome of one result.json per repeat, each with /breakage/events = values[i].
CheckOutcome repeated_outcome(const std::vector<double>& values) {
  CheckOutcome o{true, "", {}, {}};
  for (const double v : values) o.run_documents.push_back({{"breakage", {{"events", v}}}});
  return o;
}

TEST(RegressionSuite, RepeatsRunOneSeedEachAndSigmasNeedThem) {
  const json events = quantity({{"derived", "breakage_events"}, {"tolerance", {{"sigmas", 4}}}});
  const RegressionSuite suite = parse_regression_suite(repeated_suite(3, {events}), kCases, 10);
  ASSERT_EQ(suite.checks[0].study.runs.size(), 3u);
  EXPECT_EQ(suite.checks[0].repeats, 3);
  for (std::size_t i = 0; i < 3; ++i)  // the scene's seed 11, then 12 and 13
    EXPECT_EQ(suite.checks[0].study.runs[i].seed, 11u + i);

  auto problems = [](const json& spec) {
    std::string all;
    try {
      parse_regression_suite(spec, kCases, 10);
    } catch (const InputErrorList& e) {
      for (const InputError& err : e.errors()) all += err.path + " | " + err.allowed + "\n";
    }
    return all;
  };
  std::string all = problems(repeated_suite(1, {events}));
  EXPECT_NE(all.find("/checks/0/quantities/0/tolerance | a tolerance in sigmas needs"),
            std::string::npos)
      << all;
  json with_expect = events;
  with_expect["expect"] = 200;
  all = problems(repeated_suite(4, {with_expect}));
  EXPECT_NE(all.find("not with expect"), std::string::npos) << all;
  all = problems(repeated_suite(0, {events}));
  EXPECT_NE(all.find("/checks/0/repeats"), std::string::npos) << all;
  all = problems(repeated_suite(65, {events}));
  EXPECT_NE(all.find("/checks/0/repeats"), std::string::npos) << all;
  all = problems(repeated_suite(
      4, {quantity({{"derived", "breakage_events"}, {"tolerance", {{"sigmas", 0}}}})}));
  EXPECT_NE(all.find("/checks/0/quantities/0/tolerance/sigmas | expected a finite number > 0"),
            std::string::npos)
      << all;
  json study_check = {
      {"name", "scan"},
      {"study", (kCases / "spiral_jet_mill_quick_scan.study.json").string()},
      {"repeats", 2},
      {"quantities",
       json::array({quantity({{"pointer", "/counts/COMPLETE"}, {"tolerance", "exact"}})})}};
  all = problems({{"name", "unit"}, {"checks", json::array({study_check})}});
  EXPECT_NE(all.find("/checks/0/repeats | repeats belong to scene checks"), std::string::npos)
      << all;
}

// Baseline: mean 10, sd 2 over 4 runs. Measured 11, 13, 9, 11: mean 11, sd √(8/3); the standard
// error of the difference √(2²/4 + (8/3)/4) = √(5/3) = 1.29099, so the difference 1 is 0.774597
// standard errors: 0.78 sigma passes, 0.77 drifts.
TEST(RegressionSuite, SigmasDecideAtTheStandardErrorOfTheDifference) {
  const json build = build_description();
  json base = baseline_of({{"breakage_events", 10.0}}, build);
  base["spread"] = {{"impact", {{"breakage_events", {{"sd", 2.0}, {"n", 4}}}}}};
  for (const auto& [sigmas, verdict] :
       std::vector<std::pair<double, std::string>>{{0.78, "pass"}, {0.77, "drift"}}) {
    const RegressionSuite suite = parse_regression_suite(
        repeated_suite(
            4, {quantity({{"derived", "breakage_events"}, {"tolerance", {{"sigmas", sigmas}}}})}),
        kCases, 10);
    const auto rows =
        compare_with_baseline(suite, {{"impact", repeated_outcome({11, 13, 9, 11})}}, base, build);
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(rows[0].verdict, verdict) << sigmas << " " << rows[0].message;
    EXPECT_DOUBLE_EQ(*rows[0].measured, 11.0);
    EXPECT_NEAR(*rows[0].measured_sd, std::sqrt(8.0 / 3.0), 1e-12);
    EXPECT_EQ(rows[0].repeats, 4);
    EXPECT_EQ(rows[0].reference_repeats, 4);
    if (verdict == "drift") {
      EXPECT_NE(rows[0].message.find("0.774596669 standard errors"), std::string::npos)
          << rows[0].message;
    }
  }
  // A baseline without the spread cannot judge in sigmas.
  const RegressionSuite suite = parse_regression_suite(
      repeated_suite(4,
                     {quantity({{"derived", "breakage_events"}, {"tolerance", {{"sigmas", 4}}}})}),
      kCases, 10);
  const auto rows = compare_with_baseline(suite, {{"impact", repeated_outcome({11, 13, 9, 11})}},
                                          baseline_of({{"breakage_events", 10.0}}, build), build);
  EXPECT_EQ(rows[0].verdict, "no_baseline");
  EXPECT_NE(rows[0].message.find("no spread over repeats"), std::string::npos);
}

// A value expected in every run (a conservation law) is held against each: the run farthest from
// it is the one reported.
TEST(RegressionSuite, AnExpectedValueHoldsInEveryRepeat) {
  const json build = build_description();
  const RegressionSuite suite =
      parse_regression_suite(repeated_suite(3, {quantity({{"derived", "breakage_events"},
                                                          {"expect", 200},
                                                          {"tolerance", {{"absolute", 30}}}})}),
                             kCases, 10);
  auto row = [&](const std::vector<double>& values) {
    return compare_with_baseline(suite, {{"impact", repeated_outcome(values)}}, nullptr, build)[0];
  };
  EXPECT_EQ(row({190, 215, 205}).verdict, "pass");
  const RegressionRow bad = row({190, 235, 205});  // the mean, 210, would pass
  EXPECT_EQ(bad.verdict, "drift");
  EXPECT_DOUBLE_EQ(*bad.measured, 235.0);
  EXPECT_NE(bad.message.find("repeat 1 of 3 (seed 12): measured 235"), std::string::npos)
      << bad.message;
}

// make_baseline keeps each repeated quantity's mean and spread, and a rerun of the same runs
// passes against it at any number of sigmas.
TEST(RegressionSuite, ABaselineKeepsTheSpreadOfItsRepeats) {
  const json build = build_description();
  const RegressionSuite suite = parse_regression_suite(
      repeated_suite(
          4, {quantity({{"derived", "breakage_events"}, {"tolerance", {{"sigmas", 1e-9}}}})}),
      kCases, 10);
  const std::map<std::string, CheckOutcome> outcomes = {
      {"impact", repeated_outcome({196, 207, 189, 212})}};
  const json baseline = make_baseline(suite, outcomes, build, "2026-12-01T00:00:00Z");
  EXPECT_DOUBLE_EQ(baseline["values"]["impact"]["breakage_events"].get<double>(), 201.0);
  // Σ (x − 201)² = 25 + 36 + 144 + 121 = 326, over n − 1 = 3.
  EXPECT_NEAR(baseline["spread"]["impact"]["breakage_events"]["sd"].get<double>(),
              std::sqrt(326.0 / 3.0), 1e-12);
  EXPECT_EQ(baseline["spread"]["impact"]["breakage_events"]["n"], 4);
  const auto rows = compare_with_baseline(suite, outcomes, baseline, build);
  EXPECT_EQ(rows[0].verdict, "pass") << rows[0].message;
  const json record = regression_record(suite, rows, baseline, build, 1.8e9, false, {});
  EXPECT_TRUE(validate_regression_record(record).empty());
  EXPECT_NE(drift_table_text(record).find("201 sd 10.4243"), std::string::npos)
      << drift_table_text(record);
}

// When a build changes only the trajectory (new draws of the same distribution), a check of n = 4
// repeats against a baseline of 4 flags the difference of the means past k standard errors with
// probability P(|T| > k), T Student's t with 2n − 2 = 6 degrees of freedom: with equal counts the
// standard error √(s₁²/n + s₂²/n) is the pooled one. P(|T| < t) = sin θ (1 + ½ cos²θ + ⅜ cos⁴θ),
// θ = atan(t/√6) (Abramowitz & Stegun 26.7.3), so 0.04653 at k = 2.5. 4000 trials of normal draws.
TEST(RegressionSuite, SigmasRaiseFalseAlarmsAtStudentsRate) {
  const double k = 2.5, theta = std::atan(k / std::sqrt(6.0)),
               c2 = std::cos(theta) * std::cos(theta);
  const double p = 1.0 - std::sin(theta) * (1.0 + 0.5 * c2 + 0.375 * c2 * c2);
  const json build = build_description();
  const RegressionSuite suite = parse_regression_suite(
      repeated_suite(4,
                     {quantity({{"derived", "breakage_events"}, {"tolerance", {{"sigmas", k}}}})}),
      kCases, 10);
  std::mt19937_64 rng(20261201);
  std::normal_distribution<double> draw(200.0, 10.0);
  auto four = [&] {
    return std::map<std::string, CheckOutcome>{
        {"impact", repeated_outcome({draw(rng), draw(rng), draw(rng), draw(rng)})}};
  };
  const int trials = 4000;
  int alarms = 0;
  for (int t = 0; t < trials; ++t) {
    const json baseline = make_baseline(suite, four(), build, "");
    alarms += compare_with_baseline(suite, four(), baseline, build)[0].verdict == "drift";
  }
  const double expected = p * trials, sigma = std::sqrt(trials * p * (1 - p));
  EXPECT_NEAR(alarms, expected, 4 * sigma) << "p " << p;
}

}  // namespace
}  // namespace millsim
