// A study's results table: per run its parameters, state, attempts, wall time, particle-steps/s,
// phase timings, outlet PSD summary (d10/d50/d90) and its error against the study's reference
// run, by the study's metric:
//   psd_ks / psd_l1 — the KS or L1 distance between the cumulative mass distributions of the
//                     outlet PSDs (process/psd.h); d50 — |d50 − d50_ref| / d50_ref;
//   total_psd_ks / total_psd_l1 — the same on everything the run made (outlet + dust + hold-up);
//   a JSON pointer  — |x − x_ref| / |x_ref| of that number in result.json.
// Default metric: psd_ks when the reference has an outlet PSD, else the final kinetic energy.
// Rendered as JSON, CSV, a text table, an SVG plot of error against wall time, and an SVG plot of
// the runs' PSDs.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "queue/store.h"

namespace millsim {

nlohmann::ordered_json results_table(Store& store, const std::string& study_id);

// One run's error against the reference by `metric` (above), from their result.json
// documents; nullopt when it cannot be measured (a missing PSD, different classes, no mass).
std::optional<double> error_against(const nlohmann::json& run, const nlohmann::json& reference,
                                    const std::string& metric);

std::string results_csv(const nlohmann::ordered_json& table);
std::string results_text(const nlohmann::ordered_json& table);
std::string error_vs_time_svg(const nlohmann::ordered_json& table);
// The cumulative mass distribution of every complete run against size (log axis), one curve per
// run, the reference in red: the outlet PSD, or everything the run made for total_psd metrics.
// "" when no run has a PSD.
std::string psd_svg(Store& store, const std::string& study_id);

}  // namespace millsim
