// Regression suites (docs/regression.md): a list of checks, each a scene (or a study) run through
// the same queue and workers as studies, and the quantities to compare after it ran — picked by
// JSON pointer or by a named derived quantity, each with a tolerance (absolute, relative, exact,
// or standard errors of the mean over a check's repeats) and a reason. This module owns the suite
// format, the baseline file, the comparison into a drift table, and the record kept in the history
// (its JSON, text and JUnit forms). Running the checks is the caller's (cli/cmd_regress.cpp):
// locally or through a server.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "studies/study.h"

namespace millsim {

struct Tolerance {
  // Sigmas: |mean − baseline mean| ≤ value · √(s²/n + s_b²/n_b), the standard error of the
  // difference of two means over a check's repeats (s, s_b: the sample standard deviations).
  enum class Kind { Absolute, Relative, Exact, Sigmas };
  Kind kind = Kind::Relative;
  double value = 0.0;
  std::string text() const;  // "abs 0.001", "rel 0.02", "exact", "4 sigma"
};

// Derived quantities a check may name instead of a pointer (on a scene's result.json).
const std::vector<std::string>& derived_quantity_names();

struct RegressionQuantity {
  std::string name;     // its key in the baseline and the table: the derived name or the pointer
  std::string pointer;  // a JSON pointer into the check's document, or ""
  std::string derived;  // one of derived_quantity_names(), or ""
  Tolerance tolerance;
  std::string reason;
  std::optional<double> expect;  // a fixed value (analytic, published) compared instead
};

struct RegressionCheck {
  std::string name;
  bool is_study = false;  // quantities come from the study's results table, else from result.json
  // Runs of a scene check, seeds scene.seed + 0 … repeats − 1 (a study's `repeats`): its
  // quantities are then the mean over them, and the baseline keeps their standard deviation.
  int repeats = 1;
  Study study;                 // expanded and validated
  nlohmann::json submit_spec;  // the same study with its scene inline (for a server)
  std::vector<RegressionQuantity> quantities;
};

struct RegressionSuite {
  std::string name;
  std::string description;
  std::filesystem::path baseline_path;
  std::vector<RegressionCheck> checks;
};

// Parses and validates a suite; every problem at once (InputErrorList), paths like
// /checks/2/quantities/0/tolerance. Scene and study paths resolve against `dir`.
RegressionSuite parse_regression_suite(const nlohmann::json& spec, const std::filesystem::path& dir,
                                       int max_runs_per_check);
RegressionSuite load_regression_suite(const std::filesystem::path& path, int max_runs_per_check);

// What one check produced: the document its quantities are read from, or why there is none.
struct CheckOutcome {
  bool ok = false;
  std::string failure;      // e.g. "run s000004-r0 ended EXECUTOR_ERROR (exit 3): …"
  nlohmann::json document;  // a study check's results table (or a one-run scene check's result)
  // A scene check: each run's result.json in seed order (one per repeat).
  std::vector<nlohmann::json> run_documents;
};

// A quantity over a check's runs (run_documents, else document): each run's value in seed order,
// their mean and sample standard deviation (0 for one run).
struct RepeatedValue {
  std::vector<double> values;
  double mean = 0.0, sd = 0.0;
};
// nullopt with `problem` (naming the repeat) when any run lacks the number.
std::optional<RepeatedValue> measure_repeats(const CheckOutcome& outcome,
                                             const RegressionQuantity& q, std::string& problem);

// The quantity's value in `document`; nullopt with `problem` set when it is absent or not a
// number.
std::optional<double> measure_quantity(const nlohmann::json& document, const RegressionQuantity& q,
                                       std::string& problem);

struct RegressionRow {
  std::string check;
  std::string quantity;
  std::optional<double> reference;  // the baseline's value, or the expected one
  std::string reference_kind;       // "baseline" or "expected"
  std::optional<double> measured;   // with repeats: the mean (against `expect`: the worst run)
  // With repeats: the runs' standard deviation now and in the baseline, and the run counts.
  std::optional<double> measured_sd, reference_sd;
  int repeats = 1, reference_repeats = 0;
  std::string tolerance;
  std::string verdict;  // pass, drift, failed, missing, no_baseline, skipped
  std::string message;  // why, for anything but pass
  std::string reason;
};

bool row_fails(const RegressionRow& row);  // anything but pass and skipped

// Compares every quantity of every check. `outcomes` is keyed by check name; `baseline` is the
// baseline document (or null); an `exact` tolerance is compared only when the baseline comes
// from the same build (build_fingerprint), and is skipped otherwise.
std::vector<RegressionRow> compare_with_baseline(
    const RegressionSuite& suite, const std::map<std::string, CheckOutcome>& outcomes,
    const nlohmann::json& baseline, const nlohmann::json& build);

// The record of one regression run, as stored in the history and served by the API:
// {suite, created_at, build, passed, counts {checks, quantities, failures, skipped},
//  baseline {path, git_commit, created}, baseline_update, rows [...], runs {check: study}}.
nlohmann::ordered_json regression_record(const RegressionSuite& suite,
                                         const std::vector<RegressionRow>& rows,
                                         const nlohmann::json& baseline,
                                         const nlohmann::json& build, double now,
                                         bool baseline_update,
                                         const std::map<std::string, std::string>& studies);

// Problems with a record sent to POST /v1/regressions (empty when it is well formed).
InputErrors validate_regression_record(const nlohmann::json& record);

// The drift table (check, quantity, reference, measured, tolerance, verdict) and a summary.
std::string drift_table_text(const nlohmann::json& record);
// JUnit XML: one testsuite, one testcase per quantity; failures carry the message.
std::string junit_xml(const nlohmann::json& record);

// A new baseline from what the checks measured (only complete checks); `date` ISO 8601. A check
// with repeats keeps each quantity's mean in `values` and its spread in
// `spread` {check: {quantity: {sd, n}}}.
nlohmann::ordered_json make_baseline(const RegressionSuite& suite,
                                     const std::map<std::string, CheckOutcome>& outcomes,
                                     const nlohmann::json& build, const std::string& date);
// What changed between two baselines, one line per quantity ("" when nothing did).
std::string baseline_changes(const nlohmann::json& before, const nlohmann::json& after);

// ISO 8601 UTC of a Unix time ("2026-11-24T10:31:05Z").
std::string iso_utc(double unix_s);

}  // namespace millsim
