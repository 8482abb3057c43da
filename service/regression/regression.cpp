#include "regression/regression.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <set>

#include "build_info.h"
#include "core/json_reader.h"

namespace millsim {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;

// Repeats of one scene check: enough for a spread, few enough for a night.
constexpr long long kMaxCheckRepeats = 64;

bool is_plain_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (const char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
      return false;
  return true;
}

const json* at_pointer(const json& doc, const std::string& pointer) {
  try {
    const json::json_pointer p(pointer);
    return doc.contains(p) ? &doc.at(p) : nullptr;
  } catch (const json::exception&) {
    return nullptr;
  }
}

std::optional<double> number_at(const json& doc, const std::string& pointer) {
  const json* v = at_pointer(doc, pointer);
  if (!v || !v->is_number()) return std::nullopt;
  return v->get<double>();
}

constexpr const char* kToleranceForms =
    "\"exact\", {\"absolute\": x}, {\"relative\": x} or {\"sigmas\": k}";

Tolerance parse_tolerance(const json* t, const std::string& path, InputErrors& errors) {
  Tolerance tol;
  if (!t) {
    errors.push_back({path, "", std::string("missing; expected ") + kToleranceForms});
    return tol;
  }
  if (t->is_string() && t->get<std::string>() == "exact") {
    tol.kind = Tolerance::Kind::Exact;
    return tol;
  }
  static const std::pair<const char*, Tolerance::Kind> kinds[] = {
      {"absolute", Tolerance::Kind::Absolute},
      {"relative", Tolerance::Kind::Relative},
      {"sigmas", Tolerance::Kind::Sigmas}};
  if (t->is_object() && t->size() == 1)
    for (const auto& [key, kind] : kinds) {
      if (!t->contains(key)) continue;
      const json& v = (*t)[key];
      const bool sigmas = kind == Tolerance::Kind::Sigmas;
      if (!v.is_number() || !std::isfinite(v.get<double>()) ||
          !(sigmas ? v.get<double>() > 0 : v.get<double>() >= 0)) {
        errors.push_back(
            {path + "/" + key, json_value_text(v),
             sigmas ? "expected a finite number > 0" : "expected a finite number >= 0"});
        return tol;
      }
      tol.kind = kind;
      tol.value = v.get<double>();
      return tol;
    }
  errors.push_back(
      {path, json_value_text(*t), std::string("expected ") + kToleranceForms + " (one of them)"});
  return tol;
}

std::vector<RegressionQuantity> parse_quantities(JsonObjectReader& check, bool is_study,
                                                 int repeats, InputErrors& errors) {
  std::vector<RegressionQuantity> out;
  const json* list = check.array("quantities");
  if (!list || list->empty()) {
    errors.push_back({check.path_of("quantities"), list ? "[]" : "",
                      "expected a list of at least one quantity"});
    return out;
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < list->size(); ++i) {
    const std::string path = json_pointer_join(check.path_of("quantities"), i);
    JsonObjectReader r((*list)[i], path, errors);
    if (!r.is_object()) continue;
    RegressionQuantity q;
    q.pointer = r.string("pointer", "");
    q.derived = r.string("derived", "");
    if (q.pointer.empty() == q.derived.empty()) {
      errors.push_back({path, "", "give exactly one of pointer (a JSON pointer) or derived"});
    } else if (!q.pointer.empty()) {
      try {
        (void)json::json_pointer(q.pointer);
      } catch (const json::exception&) {
        errors.push_back({r.path_of("pointer"), "\"" + q.pointer + "\"",
                          "expected a JSON pointer such as /energy/final/kinetic_j"});
      }
    } else {
      const std::vector<std::string>& known = derived_quantity_names();
      if (std::find(known.begin(), known.end(), q.derived) == known.end()) {
        std::string allowed;
        for (const std::string& k : known) allowed += (allowed.empty() ? "" : ", ") + k;
        errors.push_back({r.path_of("derived"), "\"" + q.derived + "\"", "expected " + allowed});
      } else if (is_study) {
        errors.push_back({r.path_of("derived"), "\"" + q.derived + "\"",
                          "derived quantities read a run's result.json; a study check picks "
                          "from its results table by pointer (e.g. /runs/1/error)"});
      }
    }
    q.name = r.string("name", q.derived.empty() ? q.pointer : q.derived);
    q.tolerance = parse_tolerance(r.child("tolerance"), r.path_of("tolerance"), errors);
    q.reason = r.required_string("reason");
    q.expect = r.optional_number("expect", NumberRange::any());
    if (q.tolerance.kind == Tolerance::Kind::Sigmas && (repeats < 2 || q.expect))
      errors.push_back({r.path_of("tolerance"), "{\"sigmas\": ...}",
                        q.expect ? "a tolerance in sigmas compares with a baseline's spread, not "
                                   "with expect; give an absolute or relative band"
                                 : "a tolerance in sigmas needs a scene check with repeats >= 2 "
                                   "(the spread of its runs)"});
    r.finish();
    if (!names.insert(q.name).second)
      errors.push_back({r.path_of("name"), "\"" + q.name + "\"",
                        "each quantity of a check once (give a name to tell two apart)"});
    out.push_back(std::move(q));
  }
  return out;
}

// A check's study spec: a scene check is a study of its scene (with `set`, `limits`) of one run,
// or of `repeats` runs with seeds scene.seed + 0, 1, ….
json check_study_spec(const std::string& suite, const std::string& check, const json* scene,
                      const json* set, const json* limits, int repeats) {
  json spec = {{"name", "regress:" + suite + "/" + check}};
  if (scene) spec["scene"] = *scene;
  if (set) spec["set"] = *set;
  if (limits) spec["limits"] = *limits;
  if (repeats > 1) spec["repeats"] = repeats;
  return spec;
}

// The spec with its scene read from file and made inline, its file paths absolute.
json inline_scene(json spec, const std::filesystem::path& dir) {
  if (spec.contains("scene") && spec["scene"].is_string()) {
    std::filesystem::path p = spec["scene"].get<std::string>();
    if (p.is_relative()) p = dir / p;
    json scene = read_json_file(p, "/scene");
    absolutize_paths(scene, p.parent_path());
    spec["scene"] = std::move(scene);
  } else if (spec.contains("scene")) {
    absolutize_paths(spec["scene"], dir);
  }
  return spec;
}

// "commit eec31aa01f11, GNU 12.2.0, host vm".
std::string build_summary(const json& build) {
  if (!build.is_object()) return "an unknown build";
  std::string host = "?";
  if (build.contains("machine") && build["machine"].is_object())
    host = build["machine"].value("host", "?");
  return "commit " + build.value("git_commit", "?") + ", " + build.value("compiler", "?") +
         ", host " + host;
}

std::string number_text(const std::optional<double>& v) {
  if (!v) return "-";
  char text[40];
  std::snprintf(text, sizeof text, "%.9g", *v);
  return text;
}

std::string xml_escaped(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        // XML 1.0 allows no control characters but tab, newline and return.
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r')
          out += ' ';
        else
          out += c;
    }
  }
  return out;
}

}  // namespace

std::string Tolerance::text() const {
  char out[48];
  switch (kind) {
    case Kind::Exact:
      return "exact";
    case Kind::Absolute:
      std::snprintf(out, sizeof out, "abs %.3g", value);
      break;
    case Kind::Relative:
      std::snprintf(out, sizeof out, "rel %.3g", value);
      break;
    case Kind::Sigmas:
      std::snprintf(out, sizeof out, "%.3g sigma", value);
      break;
  }
  return out;
}

namespace {

// The derived quantities that are one number of result.json, and what its absence means.
struct DerivedPointer {
  const char* name;
  const char* pointer;
  const char* missing;
};
constexpr DerivedPointer kDerivedPointers[] = {
    {"outlet_d10", "/outlet_psd/d10_m", "the run has no outlet PSD"},
    {"outlet_d50", "/outlet_psd/d50_m", "the run has no outlet PSD"},
    {"outlet_d90", "/outlet_psd/d90_m", "the run has no outlet PSD"},
    {"total_d50", "/total_psd/d50_m", "the run has no total PSD"},
    {"mass_balance", "/mass_balance/relative_error", "the run has no mass balance"},
    {"particles_final", "/particles/final", "no particle count"},
    {"breakage_events", "/breakage/events", "the run has no breakage"},
    {"particle_steps_per_second", "/particle_steps_per_second", "no speed"},
};

}  // namespace

const std::vector<std::string>& derived_quantity_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const DerivedPointer& d : kDerivedPointers) out.push_back(d.name);
    out.push_back("kinetic_energy_ratio");  // computed below from two numbers
    out.push_back("contact_count");
    return out;
  }();
  return names;
}

std::optional<double> measure_quantity(const json& doc, const RegressionQuantity& q,
                                       std::string& problem) {
  const std::string& name = q.pointer.empty() ? q.derived : q.pointer;
  std::string pointer = q.pointer, missing = "no number";
  for (const DerivedPointer& d : kDerivedPointers)
    if (q.derived == d.name) pointer = d.pointer, missing = d.missing;
  if (!pointer.empty()) {
    const std::optional<double> v = number_at(doc, pointer);
    if (!v) problem = missing + " (" + pointer + ")";
    return v;
  }
  if (name == "kinetic_energy_ratio") {
    const std::optional<double> before = number_at(doc, "/energy/initial/kinetic_j");
    const std::optional<double> after = number_at(doc, "/energy/final/kinetic_j");
    if (before && after && *before > 0) return *after / *before;
    problem = "needs /energy/initial/kinetic_j > 0 and /energy/final/kinetic_j";
  } else if (name == "contact_count") {
    const std::optional<double> pairs = number_at(doc, "/contacts/pairs");
    const std::optional<double> walls = number_at(doc, "/contacts/walls");
    if (pairs && walls) return *pairs + *walls;
    problem = "needs /contacts/pairs and /contacts/walls";
  }
  return std::nullopt;
}

RegressionSuite parse_regression_suite(const json& spec, const std::filesystem::path& dir,
                                       int max_runs_per_check) {
  InputErrors errors;
  RegressionSuite suite;
  JsonObjectReader top(spec, "", errors);
  if (!top.is_object()) throw InputErrorList(std::move(errors));
  suite.name = top.required_string("name");
  if (!suite.name.empty() && !is_plain_name(suite.name))
    errors.push_back(
        {"/name", "\"" + suite.name + "\"", "expected 1-64 characters of letters, digits, _ - ."});
  suite.description = top.string("description", "");
  suite.baseline_path = dir / top.string("baseline", "baseline.json");
  const json* checks = top.array("checks");
  if (!checks || checks->empty())
    errors.push_back({"/checks", checks ? "[]" : "", "expected a list of at least one check"});
  std::set<std::string> names;
  for (std::size_t i = 0; checks && i < checks->size(); ++i) {
    const std::string path = json_pointer_join("/checks", i);
    JsonObjectReader r((*checks)[i], path, errors);
    if (!r.is_object()) continue;
    RegressionCheck check;
    check.name = r.required_string("name");
    if (!check.name.empty() && !is_plain_name(check.name))
      errors.push_back({r.path_of("name"), "\"" + check.name + "\"",
                        "expected 1-64 characters of letters, digits, _ - ."});
    else if (!check.name.empty() && !names.insert(check.name).second)
      errors.push_back({r.path_of("name"), "\"" + check.name + "\"", "each check name once"});
    const json* scene = r.child("scene");
    const json* study = r.child("study");
    const json* set = r.child("set");
    const json* limits = r.child("limits");
    check.is_study = study != nullptr;
    const bool has_repeats = r.has("repeats");
    check.repeats = int(r.integer("repeats", 1, 1, kMaxCheckRepeats));
    if (has_repeats && study)
      errors.push_back({r.path_of("repeats"), json_value_text(*r.child("repeats")),
                        "repeats belong to scene checks; a study check's study file sets its own"});
    check.quantities = parse_quantities(r, check.is_study, check.repeats, errors);
    r.finish();
    if ((scene != nullptr) == (study != nullptr)) {
      errors.push_back(
          {path, "", "give exactly one of scene (a path or a scene) or study (a path)"});
      continue;
    }
    json study_spec;
    std::filesystem::path base = dir;
    try {
      if (study) {
        if (!study->is_string()) {
          errors.push_back({r.path_of("study"), json_value_text(*study), "expected a path"});
          continue;
        }
        if (set || limits)
          errors.push_back({path, "", "set and limits belong in the study file of a study check"});
        std::filesystem::path p = study->get<std::string>();
        if (p.is_relative()) p = dir / p;
        study_spec = read_json_file(p, r.path_of("study"));
        base = p.parent_path();
        if (study_spec.is_object()) study_spec["name"] = "regress:" + suite.name + "/" + check.name;
      } else {
        study_spec = check_study_spec(suite.name, check.name, scene, set, limits, check.repeats);
      }
      check.study = expand_study(study_spec, base, max_runs_per_check);
      check.submit_spec = inline_scene(check.study.spec, base);
    } catch (const InputErrorList& e) {
      for (const InputError& err : e.errors())
        errors.push_back({path + " " + err.path, err.value, err.allowed});
      continue;
    }
    if (!check.is_study && check.study.runs.size() != std::size_t(check.repeats))
      errors.push_back({path, "", "a scene check is one run per repeat"});
    suite.checks.push_back(std::move(check));
  }
  top.finish();
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  return suite;
}

RegressionSuite load_regression_suite(const std::filesystem::path& path, int max_runs_per_check) {
  if (!std::filesystem::is_regular_file(path))
    throw InputErrorList({{path.string(), "", "no such suite file"}});
  return parse_regression_suite(read_json_file(path, path.string()), path.parent_path(),
                                max_runs_per_check);
}

bool row_fails(const RegressionRow& row) {
  return row.verdict != "pass" && row.verdict != "skipped";
}

std::optional<RepeatedValue> measure_repeats(const CheckOutcome& outcome,
                                             const RegressionQuantity& q, std::string& problem) {
  const bool per_run = !outcome.run_documents.empty();
  const std::size_t n = per_run ? outcome.run_documents.size() : 1;
  RepeatedValue out;
  for (std::size_t i = 0; i < n; ++i) {
    const std::optional<double> v =
        measure_quantity(per_run ? outcome.run_documents[i] : outcome.document, q, problem);
    if (!v) {
      if (n > 1) problem = concat("repeat ", i, " of ", n, ": ", problem);
      return std::nullopt;
    }
    out.values.push_back(*v);
  }
  // Two passes (mean, then squares about it): no cancellation for values far from zero.
  for (const double v : out.values) out.mean += v;
  out.mean /= double(n);
  double squares = 0.0;
  for (const double v : out.values) squares += (v - out.mean) * (v - out.mean);
  out.sd = n > 1 ? std::sqrt(squares / double(n - 1)) : 0.0;
  return out;
}

namespace {

// Whether `measured` lies within the tolerance of `reference` (not for Sigmas).
bool within_band(const Tolerance& t, double measured, double reference) {
  const double diff = std::abs(measured - reference);
  switch (t.kind) {
    case Tolerance::Kind::Exact:
      return measured == reference;
    case Tolerance::Kind::Absolute:
      return diff <= t.value;
    case Tolerance::Kind::Relative:
      return diff <= t.value * std::abs(reference);
    case Tolerance::Kind::Sigmas:
      break;
  }
  return false;
}

// The baseline's spread of a repeated quantity: {sd, n}, or nothing.
void read_reference_spread(const json& baseline, const std::string& check,
                           const std::string& quantity, RegressionRow& row) {
  if (!baseline.is_object() || !baseline.contains("spread")) return;
  const json& spread = baseline["spread"];
  if (!spread.is_object() || !spread.contains(check) || !spread[check].is_object() ||
      !spread[check].contains(quantity))
    return;
  const json& s = spread[check][quantity];
  if (!s.is_object() || !s.contains("sd") || !s["sd"].is_number() || !s.contains("n") ||
      !s["n"].is_number_integer())
    return;
  row.reference_sd = s["sd"].get<double>();
  row.reference_repeats = s["n"].get<int>();
}

// The verdict of a measured (mean) value against its reference; fills message on drift.
void decide(const RegressionQuantity& q, RegressionRow& row) {
  const double diff = std::abs(*row.measured - *row.reference);
  std::string off = concat(", off by ", number_text(diff),
                           *row.reference != 0.0
                               ? " (" + number_text(diff / std::abs(*row.reference)) + " relative)"
                               : std::string());
  bool within = false;
  if (q.tolerance.kind == Tolerance::Kind::Sigmas) {
    if (!row.reference_sd || row.reference_repeats < 2) {
      row.verdict = "no_baseline";
      row.message =
          "the baseline has no spread over repeats for this quantity: run `millsim regress "
          "SUITE --update-baseline` to make one";
      return;
    }
    const double standard_error =
        std::sqrt(*row.reference_sd * *row.reference_sd / row.reference_repeats +
                  *row.measured_sd * *row.measured_sd / row.repeats);
    within = standard_error > 0 ? diff <= q.tolerance.value * standard_error : diff == 0.0;
    off += standard_error > 0
               ? concat(", ", number_text(diff / standard_error), " standard errors (sd ",
                        number_text(row.measured_sd), " over ", row.repeats, " runs, baseline sd ",
                        number_text(row.reference_sd), " over ", row.reference_repeats, ")")
               : std::string(", with no spread in either");
  } else {
    within = within_band(q.tolerance, *row.measured, *row.reference);
  }
  row.verdict = within ? "pass" : "drift";
  if (!within)
    row.message = concat("measured ", row.repeats > 1 ? "mean " : "", number_text(row.measured),
                         ", ", row.reference_kind, row.repeats > 1 ? " mean " : " ",
                         number_text(row.reference), off, "; tolerance ", row.tolerance);
}

}  // namespace

std::vector<RegressionRow> compare_with_baseline(
    const RegressionSuite& suite, const std::map<std::string, CheckOutcome>& outcomes,
    const json& baseline, const json& build) {
  const bool same_build = baseline.is_object() && baseline.contains("build") &&
                          build_fingerprint(baseline["build"]) == build_fingerprint(build);
  std::vector<RegressionRow> rows;
  for (const RegressionCheck& check : suite.checks) {
    const auto found = outcomes.find(check.name);
    for (const RegressionQuantity& q : check.quantities) {
      RegressionRow row;
      row.check = check.name;
      row.quantity = q.name;
      row.tolerance = q.tolerance.text();
      row.reason = q.reason;
      if (q.expect) {
        row.reference = q.expect;
        row.reference_kind = "expected";
      } else if (baseline.is_object() && baseline.contains("values")) {
        const json& values = baseline["values"];
        if (values.contains(check.name) && values[check.name].contains(q.name) &&
            values[check.name][q.name].is_number())
          row.reference = values[check.name][q.name].get<double>();
        row.reference_kind = "baseline";
        read_reference_spread(baseline, check.name, q.name, row);
      }
      if (found == outcomes.end() || !found->second.ok) {
        row.verdict = "failed";
        row.message = found == outcomes.end() ? "the check did not run" : found->second.failure;
        rows.push_back(std::move(row));
        continue;
      }
      std::string problem;
      const std::optional<RepeatedValue> value = measure_repeats(found->second, q, problem);
      if (value) {
        row.repeats = int(value->values.size());
        row.measured = value->mean;
        if (row.repeats > 1) row.measured_sd = value->sd;
      }
      if (!value) {
        row.verdict = "missing";
        row.message = problem;
      } else if (!row.reference) {
        row.verdict = "no_baseline";
        row.message =
            "no baseline value: run `millsim regress SUITE --update-baseline` to make one";
      } else if (q.tolerance.kind == Tolerance::Kind::Exact && !q.expect && !same_build) {
        row.verdict = "skipped";
        row.message = "exact needs a baseline from this build; the baseline is from " +
                      build_summary(baseline.value("build", json::object())) + ", this is " +
                      build_summary(build);
      } else if (q.expect && row.repeats > 1) {
        // An analytic value holds in every run: the run farthest from it is the one compared.
        std::size_t worst = 0;
        for (std::size_t i = 1; i < value->values.size(); ++i)
          if (std::abs(value->values[i] - *q.expect) > std::abs(value->values[worst] - *q.expect))
            worst = i;
        row.measured = value->values[worst];
        row.measured_sd.reset();
        row.verdict = within_band(q.tolerance, *row.measured, *q.expect) ? "pass" : "drift";
        if (row.verdict == "drift")
          row.message = concat(
              "repeat ", worst, " of ", row.repeats, " (seed ",
              check.study.runs.size() > worst ? std::to_string(check.study.runs[worst].seed)
                                              : std::string("?"),
              "): measured ", number_text(row.measured), ", expected ", number_text(row.reference),
              ", off by ", number_text(std::abs(*row.measured - *q.expect)), "; tolerance ",
              row.tolerance);
      } else {
        decide(q, row);
      }
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

ordered_json regression_record(const RegressionSuite& suite, const std::vector<RegressionRow>& rows,
                               const json& baseline, const json& build, double now,
                               bool baseline_update,
                               const std::map<std::string, std::string>& studies) {
  int failures = 0, skipped = 0;
  ordered_json list = ordered_json::array();
  for (const RegressionRow& r : rows) {
    failures += row_fails(r);
    skipped += r.verdict == "skipped";
    list.push_back(
        {{"check", r.check},
         {"quantity", r.quantity},
         {"reference", r.reference ? ordered_json(*r.reference) : ordered_json()},
         {"reference_kind", r.reference_kind},
         {"measured", r.measured ? ordered_json(*r.measured) : ordered_json()},
         {"measured_sd", r.measured_sd ? ordered_json(*r.measured_sd) : ordered_json()},
         {"reference_sd", r.reference_sd ? ordered_json(*r.reference_sd) : ordered_json()},
         {"repeats", r.repeats},
         {"tolerance", r.tolerance},
         {"verdict", r.verdict},
         {"message", r.message},
         {"reason", r.reason}});
  }
  ordered_json base = nullptr;
  if (baseline.is_object())
    base = {{"git_commit", baseline.contains("build") ? baseline["build"].value("git_commit", "")
                                                      : std::string()},
            {"created", baseline.value("created", "")}};
  return {{"suite", suite.name},
          {"created_at", now},
          {"created", iso_utc(now)},
          {"build", build},
          {"passed", failures == 0},
          {"counts",
           {{"checks", suite.checks.size()},
            {"quantities", rows.size()},
            {"failures", failures},
            {"skipped", skipped}}},
          {"baseline", base},
          {"baseline_update", baseline_update},
          {"studies", studies},
          {"rows", list}};
}

InputErrors validate_regression_record(const json& record) {
  InputErrors errors;
  if (!record.is_object()) return {{"", json_value_text(record), "expected a regression record"}};
  auto need = [&](const char* key, bool ok, const char* what) {
    if (!ok)
      errors.push_back(
          {std::string("/") + key, record.contains(key) ? json_value_text(record[key]) : "", what});
  };
  need("suite",
       record.contains("suite") && record["suite"].is_string() &&
           is_plain_name(record["suite"].get<std::string>()),
       "expected the suite's name (1-64 characters of letters, digits, _ - .)");
  need("passed", record.contains("passed") && record["passed"].is_boolean(), "expected a boolean");
  need("build", record.contains("build") && record["build"].is_object(), "expected an object");
  need("rows", record.contains("rows") && record["rows"].is_array(), "expected a list of rows");
  if (errors.empty()) {
    static const std::set<std::string> verdicts = {"pass",    "drift",       "failed",
                                                   "missing", "no_baseline", "skipped"};
    bool any_failure = false;
    for (std::size_t i = 0; i < record["rows"].size(); ++i) {
      const json& row = record["rows"][i];
      const std::string path = json_pointer_join("/rows", i);
      if (!row.is_object()) {
        errors.push_back({path, json_value_text(row), "expected an object"});
        continue;
      }
      for (const char* key : {"check", "quantity", "verdict"})
        if (!row.contains(key) || !row[key].is_string())
          errors.push_back({path + "/" + key, "", "expected a string"});
      for (const char* key : {"reference", "measured", "measured_sd", "reference_sd"})
        if (row.contains(key) && !row[key].is_null() && !row[key].is_number())
          errors.push_back({path + "/" + key, json_value_text(row[key]), "expected a number"});
      if (row.contains("verdict") && row["verdict"].is_string()) {
        const std::string v = row["verdict"].get<std::string>();
        if (!verdicts.count(v))
          errors.push_back({path + "/verdict", "\"" + v + "\"",
                            "expected pass, drift, failed, missing, no_baseline or skipped"});
        any_failure = any_failure || (v != "pass" && v != "skipped");
      }
      if (errors.size() >= 50) break;  // enough to show what is wrong
    }
    if (errors.empty() && record["passed"].get<bool>() == any_failure)
      errors.push_back({"/passed", record["passed"].dump(),
                        "must be true exactly when no row fails (pass or skipped)"});
  }
  return errors;
}

std::string drift_table_text(const json& record) {
  std::vector<std::vector<std::string>> cells = {
      {"check", "quantity", "reference", "measured", "tolerance", "verdict"}};
  for (const json& r : record["rows"]) {
    auto num = [&](const char* key) {
      return r.contains(key) && r[key].is_number() ? number_text(r[key].get<double>())
                                                   : std::string("-");
    };
    // A mean over repeats shows its runs' standard deviation: "2.1e-04 sd 1.1e-05".
    auto with_sd = [&](const char* key, const char* sd_key) {
      std::string text = num(key);
      if (r.contains(sd_key) && r[sd_key].is_number())
        text += " sd " + number_text(r[sd_key].get<double>());
      return text;
    };
    std::string reference = with_sd("reference", "reference_sd");
    if (r.value("reference_kind", "") == "expected") reference += " (expected)";
    cells.push_back({r.value("check", ""), r.value("quantity", ""), reference,
                     with_sd("measured", "measured_sd"), r.value("tolerance", ""),
                     r.value("verdict", "")});
  }
  std::vector<std::size_t> width(cells[0].size(), 0);
  for (const auto& row : cells)
    for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  std::string out;
  for (const auto& row : cells) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      out += row[c];
      if (c + 1 < row.size()) out += std::string(width[c] - row[c].size() + 2, ' ');
    }
    out += "\n";
  }
  for (const json& r : record["rows"])
    if (r.value("verdict", "") != "pass" && !r.value("message", "").empty())
      out += r.value("verdict", "") + ": " + r.value("check", "") + " " + r.value("quantity", "") +
             ": " + r.value("message", "") + "\n";
  const json& counts = record["counts"];
  out += concat(
      record.value("suite", ""), ": ", record.value("passed", false) ? "PASSED" : "FAILED", ", ",
      counts.value("quantities", 0), " quantities in ", counts.value("checks", 0), " checks, ",
      counts.value("failures", 0), " failing, ", counts.value("skipped", 0), " skipped\n");
  return out;
}

std::string junit_xml(const json& record) {
  const json& counts = record["counts"];
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += concat("<testsuites name=\"millsim regress\" tests=\"", counts.value("quantities", 0),
                "\" failures=\"", counts.value("failures", 0), "\" skipped=\"",
                counts.value("skipped", 0), "\">\n");
  out += concat("  <testsuite name=\"", xml_escaped(record.value("suite", "")), "\" tests=\"",
                counts.value("quantities", 0), "\" failures=\"", counts.value("failures", 0),
                "\" skipped=\"", counts.value("skipped", 0), "\" timestamp=\"",
                xml_escaped(record.value("created", "")), "\">\n");
  for (const json& r : record["rows"]) {
    out += "    <testcase classname=\"" +
           xml_escaped(record.value("suite", "") + "." + r.value("check", "")) + "\" name=\"" +
           xml_escaped(r.value("quantity", "")) + "\"";
    const std::string verdict = r.value("verdict", "");
    const std::string message = r.value("message", "");
    if (verdict == "pass") {
      out += "/>\n";
    } else if (verdict == "skipped") {
      out += ">\n      <skipped message=\"" + xml_escaped(message) + "\"/>\n    </testcase>\n";
    } else {
      out += ">\n      <failure type=\"" + xml_escaped(verdict) + "\" message=\"" +
             xml_escaped(message) + "\">" + xml_escaped(r.value("reason", "")) +
             "</failure>\n    </testcase>\n";
    }
  }
  out += "  </testsuite>\n</testsuites>\n";
  return out;
}

ordered_json make_baseline(const RegressionSuite& suite,
                           const std::map<std::string, CheckOutcome>& outcomes, const json& build,
                           const std::string& date) {
  ordered_json values = ordered_json::object(), spread = ordered_json::object();
  for (const RegressionCheck& check : suite.checks) {
    const auto found = outcomes.find(check.name);
    if (found == outcomes.end() || !found->second.ok) continue;
    ordered_json of_check = ordered_json::object(), spread_of_check = ordered_json::object();
    for (const RegressionQuantity& q : check.quantities) {
      std::string problem;
      if (const std::optional<RepeatedValue> v = measure_repeats(found->second, q, problem)) {
        of_check[q.name] = v->mean;
        if (v->values.size() > 1)
          spread_of_check[q.name] = {{"sd", v->sd}, {"n", v->values.size()}};
      }
    }
    values[check.name] = of_check;
    if (!spread_of_check.empty()) spread[check.name] = spread_of_check;
  }
  ordered_json out = {
      {"suite", suite.name}, {"created", date}, {"build", build}, {"values", values}};
  if (!spread.empty()) out["spread"] = spread;
  return out;
}

std::string baseline_changes(const json& before, const json& after) {
  std::string out;
  const json none = json::object();
  const json& old_values =
      before.is_object() && before.contains("values") ? before["values"] : none;
  for (const auto& [check, quantities] : after["values"].items())
    for (const auto& [name, value] : quantities.items()) {
      const json* old = old_values.contains(check) && old_values[check].contains(name)
                            ? &old_values[check][name]
                            : nullptr;
      if (!old)
        out += check + " " + name + ": new, " + number_text(value.get<double>()) + "\n";
      else if (*old != value)
        out += check + " " + name + ": " +
               number_text(old->is_number() ? std::optional<double>(old->get<double>())
                                            : std::nullopt) +
               " -> " + number_text(value.get<double>()) + "\n";
    }
  for (const auto& [check, quantities] : old_values.items())
    for (const auto& [name, value] : quantities.items())
      if (!after["values"].contains(check) || !after["values"][check].contains(name))
        out += check + " " + name + ": removed (was " +
               number_text(value.is_number() ? std::optional<double>(value.get<double>())
                                             : std::nullopt) +
               ")\n";
  return out;
}

std::string iso_utc(double unix_s) {
  const std::time_t t = std::time_t(unix_s);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

}  // namespace millsim
