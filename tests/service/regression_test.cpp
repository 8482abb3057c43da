// Regression suites without running anything: the suite parser reports every problem at once,
// quantities are measured from result.json documents as their definitions say, each tolerance
// decides pass and drift at its edge, `exact` is compared only against the same build, a failed
// check fails its quantities, the JUnit text counts them, and a stored record is validated.
#include "regression/regression.h"

#include <gtest/gtest.h>

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
  return {{"impact", CheckOutcome{true, "", doc}}};
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
       CheckOutcome{false, "run s000001-r0 ended EXECUTOR_ERROR (exit 3): unstable", {}}}};
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

}  // namespace
}  // namespace millsim
