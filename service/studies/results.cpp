#include "studies/results.h"

#include <cmath>
#include <cstdio>
#include <optional>

#include "core/json_reader.h"
#include "io/svg_plot.h"
#include "process/psd.h"

namespace millsim {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;

// A number of `j` by key; `fallback` when it is absent or not a number (an empty product's sizes
// are null: it has none).
double number_or(const json& j, const char* key, double fallback) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : fallback;
}

std::optional<PsdSummary> outlet_psd(const json& result) {
  if (!result.contains("outlet_psd")) return std::nullopt;
  const json& p = result["outlet_psd"];
  PsdSummary s;
  s.edges_m = p.value("edges_m", std::vector<double>{});
  s.cumulative_mass = p.value("cumulative_mass", std::vector<double>{});
  s.d50_m = number_or(p, "d50_m", 0.0);
  s.total_mass_kg = number_or(p, "total_mass_kg", 0.0);
  return s;
}

// Everything the run made (product + hold-up), on the outlet PSD's classes: `total_psd` carries
// the cumulative distribution at the same edges. Short windows compare fairly on it.
std::optional<PsdSummary> total_psd(const json& result) {
  auto s = outlet_psd(result);
  if (!s || !result.contains("total_psd")) return std::nullopt;
  const json& t = result["total_psd"];
  s->cumulative_mass = t.value("cumulative_mass", std::vector<double>{});
  s->d50_m = number_or(t, "d50_m", 0.0);
  s->total_mass_kg = number_or(t, "total_mass_kg", 0.0);
  if (s->cumulative_mass.size() != s->edges_m.size()) return std::nullopt;
  return s;
}

std::optional<double> number_at(const json& result, const std::string& pointer) {
  try {
    const json& v = result.at(json::json_pointer(pointer));
    if (v.is_number()) return v.get<double>();
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

json parse_or_null(const std::string& text) {
  if (text.empty()) return nullptr;
  try {
    return json::parse(text);
  } catch (const std::exception&) {
    return nullptr;
  }
}

std::string number_text(const ordered_json& v, const char* format) {
  if (!v.is_number()) return "-";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v.get<double>());
  return buffer;
}

}  // namespace

// The run's error against the reference by `metric`; nullopt when it cannot be measured.
std::optional<double> error_against(const json& run, const json& reference,
                                    const std::string& metric) {
  if (metric == "total_psd_ks" || metric == "total_psd_l1") {
    const auto a = total_psd(run), b = total_psd(reference);
    if (!a || !b || a->edges_m != b->edges_m || a->total_mass_kg <= 0 || b->total_mass_kg <= 0)
      return std::nullopt;
    const PsdDistance d = compare_psd(*a, *b);
    return metric == "total_psd_ks" ? d.ks : d.l1;
  }
  if (metric == "psd_ks" || metric == "psd_l1" || metric == "d50") {
    const auto a = outlet_psd(run), b = outlet_psd(reference);
    if (!a || !b || a->edges_m != b->edges_m || a->total_mass_kg <= 0 || b->total_mass_kg <= 0)
      return std::nullopt;
    const PsdDistance d = compare_psd(*a, *b);
    return metric == "psd_ks" ? d.ks : metric == "psd_l1" ? d.l1 : std::abs(d.d50_relative_error);
  }
  const auto a = number_at(run, metric), b = number_at(reference, metric);
  if (!a || !b || *b == 0.0) return std::nullopt;
  return std::abs(*a - *b) / std::abs(*b);
}

ordered_json results_table(Store& store, const std::string& study_id) {
  const std::optional<StudyRecord> study = store.study(study_id);
  if (!study) return nullptr;
  const std::vector<RunRecord> runs = store.runs(study_id);
  json reference = nullptr;
  if (study->reference_run)
    for (const RunRecord& r : runs)
      if (r.id == *study->reference_run && r.state == RunState::Complete)
        reference = parse_or_null(r.result);
  std::string metric = study->error_metric;
  if (metric.empty())
    metric = reference.is_object() && reference.contains("outlet_psd") ? "psd_ks"
                                                                       : "/energy/final/kinetic_j";
  ordered_json table;
  table["study"] = study->id;
  table["name"] = study->name;
  table["reference_run"] = study->reference_run ? ordered_json(*study->reference_run) : nullptr;
  table["error_metric"] = metric;
  const Progress progress = store.progress(study_id);
  ordered_json counts = ordered_json::object();
  for (int s = 0; s <= int(RunState::Canceled); ++s)
    if (progress.by_state[s])
      counts[std::string(run_state_name(RunState(s)))] = progress.by_state[s];
  table["counts"] = counts;
  ordered_json rows = ordered_json::array();
  for (const RunRecord& r : runs) {
    const json result = parse_or_null(r.result);
    ordered_json row;
    row["run"] = r.id;
    row["params"] = r.params;
    row["seed"] = r.seed;
    row["state"] = std::string(run_state_name(r.state));
    row["attempts"] = r.attempts;
    row["reference"] = r.is_reference;
    row["wall_time_s"] = r.state == RunState::Complete ? ordered_json(r.wall_time_s) : nullptr;
    // What the run's parameters cost: its wall time less the gas spin-up, which the runs of a
    // study with one gas share (computed by one, read by the others, sim/gas_spin_up.h).
    // -1 when result.json does not say (no gas, or an older run).
    const double spin_up_s =
        result.is_object() ? number_at(result, "/spin_up/seconds").value_or(-1.0) : -1.0;
    const double engine_s =
        result.is_object() ? number_at(result, "/wall_time_s").value_or(-1.0) : -1.0;
    row["spin_up_s"] = spin_up_s >= 0.0 ? ordered_json(spin_up_s) : ordered_json(nullptr);
    row["spin_up_source"] = result.is_object() && result.contains("spin_up") &&
                                    result["spin_up"].value("source", json()).is_string()
                                ? ordered_json(result["spin_up"]["source"].get<std::string>())
                                : ordered_json(nullptr);
    row["run_time_s"] = r.state != RunState::Complete ? ordered_json(nullptr)
                        : engine_s >= 0.0 && spin_up_s >= 0.0
                            ? ordered_json(std::max(0.0, engine_s - spin_up_s))
                            : ordered_json(r.wall_time_s);
    row["particle_steps_per_second"] =
        result.is_object() ? ordered_json(result.value("particle_steps_per_second", 0.0))
                           : ordered_json(nullptr);
    row["phase_seconds"] = result.is_object() && result.contains("phase_seconds")
                               ? ordered_json(result["phase_seconds"])
                               : ordered_json(nullptr);
    for (const char* d : {"d10_m", "d50_m", "d90_m"})
      row[d] = result.is_object() && result.contains("outlet_psd") &&
                       result["outlet_psd"].contains(d) && result["outlet_psd"][d].is_number()
                   ? ordered_json(result["outlet_psd"][d])
                   : ordered_json(nullptr);
    std::optional<double> error;
    if (result.is_object() && reference.is_object())
      error = error_against(result, reference, metric);
    row["error"] = error ? ordered_json(*error) : ordered_json(nullptr);
    row["message"] = r.state == RunState::Complete ? "" : std::string(utf8_prefix(r.error, 400));
    rows.push_back(row);
  }
  table["runs"] = rows;
  return table;
}

std::string results_csv(const ordered_json& table) {
  std::string out = "run,";
  const ordered_json& rows = table["runs"];
  if (!rows.empty())
    for (const auto& [key, value] : rows[0]["params"].items()) out += key + ",";
  out +=
      "state,attempts,wall_time_s,run_time_s,spin_up_s,particle_steps_per_second,d10_m,d50_m,d90_"
      "m,error\n";
  for (const ordered_json& r : rows) {
    out += r["run"].get<std::string>() + ",";
    for (const auto& [key, value] : r["params"].items()) out += value.dump() + ",";
    out += r["state"].get<std::string>() + "," + std::to_string(r["attempts"].get<int>()) + ",";
    for (const char* k : {"wall_time_s", "run_time_s", "spin_up_s", "particle_steps_per_second",
                          "d10_m", "d50_m", "d90_m"})
      out += (r[k].is_number() ? number_text(r[k], "%.6g") : std::string()) + ",";
    out += r["error"].is_number() ? number_text(r["error"], "%.6g") : std::string();
    out += "\n";
  }
  return out;
}

std::string results_text(const ordered_json& table) {
  std::string out = "study " + table["study"].get<std::string>() + " (" +
                    table["name"].get<std::string>() +
                    "), error: " + table["error_metric"].get<std::string>() + " against " +
                    (table["reference_run"].is_string() ? table["reference_run"].get<std::string>()
                                                        : std::string("no reference")) +
                    "\n";
  char line[512];
  std::snprintf(line, sizeof line, "%-12s %-36s %-14s %9s %10s %9s %9s %9s %9s\n", "run",
                "parameters", "state", "run s", "psteps/s", "d10 um", "d50 um", "d90 um", "error");
  out += line;
  for (const ordered_json& r : table["runs"]) {
    std::string params;
    for (const auto& [key, value] : r["params"].items()) {
      if (!params.empty()) params += ' ';
      params += key.substr(key.find_last_of("./") + 1);  // the last key of the path
      params += '=';
      params += value.dump();
    }
    if (r["reference"].get<bool>()) params += " (ref)";
    const auto um = [](const ordered_json& v) {
      return v.is_number() ? ordered_json(v.get<double>() * 1e6) : ordered_json(nullptr);
    };
    std::snprintf(
        line, sizeof line, "%-12s %-36s %-14s %9s %10s %9s %9s %9s %9s\n",
        r["run"].get<std::string>().c_str(), params.c_str(), r["state"].get<std::string>().c_str(),
        number_text(r["run_time_s"], "%.2f").c_str(),
        number_text(r["particle_steps_per_second"], "%.3g").c_str(),
        number_text(um(r["d10_m"]), "%.1f").c_str(), number_text(um(r["d50_m"]), "%.1f").c_str(),
        number_text(um(r["d90_m"]), "%.1f").c_str(), number_text(r["error"], "%.4f").c_str());
    out += line;
  }
  // The gas spin-up, shared by the runs with one gas: once, not in the run times above.
  double computed_s = 0.0;
  int computed = 0, read = 0;
  for (const ordered_json& r : table["runs"]) {
    if (!r.contains("spin_up_s") || !r["spin_up_s"].is_number()) continue;
    const std::string source =
        r["spin_up_source"].is_string() ? r["spin_up_source"].get<std::string>() : "";
    if (source == "cache")
      ++read;
    else if (source == "computed" || source == "resumed")
      ++computed, computed_s += r["spin_up_s"].get<double>();
  }
  if (computed + read > 0) {
    std::snprintf(line, sizeof line,
                  "gas spin-up: %.1f s, computed by %d run%s and read from the study's cache by %d "
                  "(not in the run times)\n",
                  computed_s, computed, computed == 1 ? "" : "s", read);
    out += line;
  }
  return out;
}

std::string error_vs_time_svg(const ordered_json& table) {
  PlotPanel panel;
  panel.title = "study " + table["study"].get<std::string>() + ": error against run time";
  panel.x_label = "run time (s, without the gas spin-up)";
  panel.y_label = "error (" + table["error_metric"].get<std::string>() + ")";
  PlotSeries runs, reference;
  runs.name = "runs", runs.color = "#1f77b4", runs.line = false;
  reference.name = "reference run", reference.color = "#d62728", reference.line = false;
  reference.hollow = true;
  double fastest = 1e300, slowest = 0.0;
  for (const ordered_json& r : table["runs"]) {
    if (!(r["run_time_s"].is_number() && r["error"].is_number())) continue;
    const double t = r["run_time_s"].get<double>();
    const std::string id = r["run"].get<std::string>();
    const std::string label = id.substr(id.find_last_of('-') + 1);  // "r3"
    PlotSeries& into = r["reference"].get<bool>() ? reference : runs;
    into.x.push_back(t);
    into.y.push_back(r["error"].get<double>());
    into.labels.push_back(label);
    fastest = std::min(fastest, t), slowest = std::max(slowest, t);
    // What each label stands for: its parameters.
    std::string note = label + ":";
    for (const auto& [key, value] : r["params"].items()) {
      note += ' ';
      note += key.substr(key.find_last_of("./") + 1);
      note += '=';
      note += value.dump();
    }
    if (panel.notes.size() < 16) panel.notes.push_back(note);
  }
  // Wall times spanning more than a decade read on a log axis.
  panel.log_x = fastest > 0.0 && slowest > 10.0 * fastest;
  if (panel.log_x) panel.x_label = "run time (s, without the gas spin-up, log scale)";
  panel.series.push_back(runs);
  if (!reference.x.empty()) panel.series.push_back(reference);
  return render_svg({panel}, 760, 400);
}

std::string psd_svg(Store& store, const std::string& study_id) {
  const std::optional<StudyRecord> study = store.study(study_id);
  if (!study) return "";
  const bool total = study->error_metric.rfind("total_", 0) == 0;
  PlotPanel panel;
  panel.title = "study " + study_id + ": " +
                (total ? "everything each run made (outlet, dust and hold-up)"
                       : "each run's product (outlet and dust)");
  panel.x_label = "particle size (um, log scale)";
  panel.y_label = "cumulative mass fraction";
  panel.log_x = true;
  static const char* kColors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b",
                                  "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  std::size_t k = 0;
  for (const RunRecord& r : store.runs(study_id, RunState::Complete)) {
    const json result = parse_or_null(r.result);
    const std::optional<PsdSummary> psd = total ? total_psd(result) : outlet_psd(result);
    if (!psd || psd->cumulative_mass.size() != psd->edges_m.size() || psd->total_mass_kg <= 0)
      continue;
    PlotSeries curve;
    const std::string label = r.id.substr(r.id.find_last_of('-') + 1);  // "r3"
    curve.name = label;
    for (const auto& [key, value] : r.params.items())
      curve.name += " " + key.substr(key.find_last_of("./") + 1) + "=" + value.dump();
    if (r.is_reference) {
      curve.name += " (reference)";
      curve.color = "#d62728";
    } else {
      curve.color = kColors[k++ % (sizeof kColors / sizeof kColors[0])];
    }
    curve.markers = false;
    for (std::size_t i = 0; i < psd->edges_m.size(); ++i)
      if (psd->edges_m[i] > 0) {
        curve.x.push_back(psd->edges_m[i] * 1e6);
        curve.y.push_back(psd->cumulative_mass[i]);
      }
    panel.series.push_back(std::move(curve));
  }
  if (panel.series.empty()) return "";
  return render_svg({panel}, 760, 400);
}

}  // namespace millsim
