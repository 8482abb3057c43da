// Particle size distributions on fixed size classes: the tally (counts and masses per class,
// with under- and overflow kept apart so no mass is ever dropped), its summary as number- and
// mass-based fractions, densities and cumulative distributions with d10/d50/d90, and the
// distance between two distributions (the service's "error against the reference run").
#pragma once

#include "checkpoint/archive.h"

#include <nlohmann/json.hpp>
#include <vector>

namespace millsim {

struct PsdTally {
  std::vector<double> edges_m;                    // ascending, bins = edges − 1
  std::vector<double> count;                      // per bin
  std::vector<double> mass_kg;                    // per bin
  double under_count = 0.0, under_mass_kg = 0.0;  // d < edges.front()
  double over_count = 0.0, over_mass_kg = 0.0;    // d >= edges.back()

  PsdTally() = default;
  explicit PsdTally(std::vector<double> edges);
  void add(double diameter_m, double mass_kg, double number = 1.0);
  void add(const PsdTally& other);  // same edges
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, edges_m, count, mass_kg, under_count, under_mass_kg, over_count, over_mass_kg);
  }
  double total_count() const;
  double total_mass_kg() const;
};

struct PsdSummary {
  std::vector<double> edges_m;
  std::vector<double> count, mass_kg;
  std::vector<double> number_fraction, mass_fraction;            // per bin, of the total
  std::vector<double> number_density_per_m, mass_density_per_m;  // fraction / bin width
  // Cumulative fractions below each edge (size edges.size()); the first is the underflow.
  std::vector<double> cumulative_number, cumulative_mass;
  double total_count = 0.0, total_mass_kg = 0.0;
  double under_mass_kg = 0.0, over_mass_kg = 0.0;
  // Mass-based quantiles: log-linear interpolation of cumulative_mass between edges; a quantile
  // in the underflow (overflow) reads as the first (last) edge. 0 when there is no mass.
  double d10_m = 0.0, d50_m = 0.0, d90_m = 0.0;
};

PsdSummary summarize(const PsdTally& tally);

// Size x with cumulative mass fraction `fraction`, as in PsdSummary.
double mass_quantile_m(const PsdSummary& s, double fraction);

struct PsdDistance {
  double ks = 0.0;  // max |Q3_a − Q3_b| over the edges (Kolmogorov–Smirnov on the classes)
  double l1 = 0.0;  // ∫ |Q3_a − Q3_b| d ln x / ln(x_max / x_min): mean gap, in [0, 1]
  double d50_relative_error = 0.0;  // (d50_a − d50_b) / d50_b
};

// Both summaries must share their edges; throws std::invalid_argument otherwise.
PsdDistance compare_psd(const PsdSummary& run, const PsdSummary& reference);

nlohmann::ordered_json psd_json(const PsdSummary& s);
// A size of the distribution (d10, d50, d90) for JSON: null when it holds no mass (an empty
// product has no d50, not a d50 of 0).
nlohmann::ordered_json psd_size_json(const PsdSummary& s, double d_m);
nlohmann::ordered_json psd_distance_json(const PsdDistance& d);

}  // namespace millsim
