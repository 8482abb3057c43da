#include "process/psd.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace millsim {

PsdTally::PsdTally(std::vector<double> edges)
    : edges_m(std::move(edges)),
      count(edges_m.size() > 1 ? edges_m.size() - 1 : 0, 0.0),
      mass_kg(count.size(), 0.0) {}

void PsdTally::add(double d, double m, double n) {
  if (edges_m.empty() || d < edges_m.front()) {
    under_count += n, under_mass_kg += m;
    return;
  }
  if (d >= edges_m.back()) {
    over_count += n, over_mass_kg += m;
    return;
  }
  const std::size_t bin =
      std::size_t(std::upper_bound(edges_m.begin(), edges_m.end(), d) - edges_m.begin()) - 1;
  count[bin] += n;
  mass_kg[bin] += m;
}

void PsdTally::add(const PsdTally& o) {
  for (std::size_t k = 0; k < count.size(); ++k) count[k] += o.count[k], mass_kg[k] += o.mass_kg[k];
  under_count += o.under_count, under_mass_kg += o.under_mass_kg;
  over_count += o.over_count, over_mass_kg += o.over_mass_kg;
}

double PsdTally::total_count() const {
  double n = under_count + over_count;
  for (double c : count) n += c;
  return n;
}

double PsdTally::total_mass_kg() const {
  double m = under_mass_kg + over_mass_kg;
  for (double v : mass_kg) m += v;
  return m;
}

double mass_quantile_m(const PsdSummary& s, double fraction) {
  const std::vector<double>& q = s.cumulative_mass;
  if (s.total_mass_kg <= 0.0 || q.empty()) return 0.0;
  if (fraction <= q.front()) return s.edges_m.front();
  for (std::size_t k = 1; k < q.size(); ++k) {
    if (fraction > q[k]) continue;
    const double t = (fraction - q[k - 1]) / (q[k] - q[k - 1]);
    return std::exp(std::log(s.edges_m[k - 1]) +
                    t * (std::log(s.edges_m[k]) - std::log(s.edges_m[k - 1])));
  }
  return s.edges_m.back();
}

PsdSummary summarize(const PsdTally& t) {
  PsdSummary s;
  s.edges_m = t.edges_m;
  s.count = t.count;
  s.mass_kg = t.mass_kg;
  s.total_count = t.total_count();
  s.total_mass_kg = t.total_mass_kg();
  s.under_mass_kg = t.under_mass_kg;
  s.over_mass_kg = t.over_mass_kg;
  const std::size_t bins = t.count.size();
  const double inv_n = s.total_count > 0 ? 1.0 / s.total_count : 0.0;
  const double inv_m = s.total_mass_kg > 0 ? 1.0 / s.total_mass_kg : 0.0;
  s.cumulative_number.assign(bins + 1, 0.0);
  s.cumulative_mass.assign(bins + 1, 0.0);
  if (bins + 1 == s.edges_m.size()) {
    s.cumulative_number[0] = t.under_count * inv_n;
    s.cumulative_mass[0] = t.under_mass_kg * inv_m;
  }
  for (std::size_t k = 0; k < bins; ++k) {
    const double width = t.edges_m[k + 1] - t.edges_m[k];
    s.number_fraction.push_back(t.count[k] * inv_n);
    s.mass_fraction.push_back(t.mass_kg[k] * inv_m);
    s.number_density_per_m.push_back(s.number_fraction.back() / width);
    s.mass_density_per_m.push_back(s.mass_fraction.back() / width);
    s.cumulative_number[k + 1] = s.cumulative_number[k] + s.number_fraction.back();
    s.cumulative_mass[k + 1] = s.cumulative_mass[k] + s.mass_fraction.back();
  }
  s.d10_m = mass_quantile_m(s, 0.1);
  s.d50_m = mass_quantile_m(s, 0.5);
  s.d90_m = mass_quantile_m(s, 0.9);
  return s;
}

PsdDistance compare_psd(const PsdSummary& a, const PsdSummary& b) {
  if (a.edges_m != b.edges_m)
    throw std::invalid_argument("compare_psd: the two distributions have different size classes");
  PsdDistance d;
  const std::size_t n = a.cumulative_mass.size();
  if (n < 2) return d;
  const double span = std::log(a.edges_m.back() / a.edges_m.front());
  for (std::size_t k = 0; k < n; ++k) {
    const double gap = std::abs(a.cumulative_mass[k] - b.cumulative_mass[k]);
    d.ks = std::max(d.ks, gap);
    if (k + 1 < n) {
      // Trapezoid of the gap over this class in ln x (exact for log-linear cumulatives that
      // do not cross inside the class).
      const double next = std::abs(a.cumulative_mass[k + 1] - b.cumulative_mass[k + 1]);
      d.l1 += 0.5 * (gap + next) * std::log(a.edges_m[k + 1] / a.edges_m[k]) / span;
    }
  }
  d.d50_relative_error = b.d50_m > 0.0 ? (a.d50_m - b.d50_m) / b.d50_m : 0.0;
  return d;
}

nlohmann::ordered_json psd_size_json(const PsdSummary& s, double d_m) {
  return s.total_mass_kg > 0.0 ? nlohmann::ordered_json(d_m) : nlohmann::ordered_json(nullptr);
}

nlohmann::ordered_json psd_json(const PsdSummary& s) {
  return {{"total_count", s.total_count},
          {"total_mass_kg", s.total_mass_kg},
          {"d10_m", psd_size_json(s, s.d10_m)},
          {"d50_m", psd_size_json(s, s.d50_m)},
          {"d90_m", psd_size_json(s, s.d90_m)},
          {"under_range_mass_kg", s.under_mass_kg},
          {"over_range_mass_kg", s.over_mass_kg},
          {"edges_m", s.edges_m},
          {"count", s.count},
          {"mass_kg", s.mass_kg},
          {"number_fraction", s.number_fraction},
          {"mass_fraction", s.mass_fraction},
          {"number_density_per_m", s.number_density_per_m},
          {"mass_density_per_m", s.mass_density_per_m},
          {"cumulative_number", s.cumulative_number},
          {"cumulative_mass", s.cumulative_mass}};
}

nlohmann::ordered_json psd_distance_json(const PsdDistance& d) {
  return {{"ks", d.ks}, {"l1", d.l1}, {"d50_relative_error", d.d50_relative_error}};
}

}  // namespace millsim
