#include "process/impact_spectrum.h"

#include <algorithm>
#include <cmath>

namespace millsim {

ImpactSpectrum::ImpactSpectrum(std::vector<double> size_edges_m, double min_j_per_kg,
                               double max_j_per_kg, int bins_per_decade)
    : size_edges_m_(std::move(size_edges_m)),
      log_min_(std::log10(min_j_per_kg)),
      bins_per_decade_(bins_per_decade) {
  const int bins = int(std::lround(std::log10(max_j_per_kg / min_j_per_kg) * bins_per_decade));
  for (int k = 0; k <= bins; ++k)
    energy_edges_.push_back(std::pow(10.0, log_min_ + double(k) / bins_per_decade_));
}

std::size_t ImpactSpectrum::size_class(double diameter_m) const {
  const auto it = std::upper_bound(size_edges_m_.begin(), size_edges_m_.end(), diameter_m);
  const std::ptrdiff_t k = (it - size_edges_m_.begin()) - 1;
  return std::size_t(std::clamp<std::ptrdiff_t>(k, 0, std::ptrdiff_t(size_classes()) - 1));
}

std::size_t ImpactSpectrum::energy_bin(double j_per_kg) const {
  if (!(j_per_kg > 0.0)) return 0;
  if (!std::isfinite(j_per_kg)) return energy_bins() - 1;  // no long from an infinite log
  // The edge itself belongs to the bin above it; the log may round an edge down by one ulp,
  // so the result is checked against the edges.
  long k = long(std::floor((std::log10(j_per_kg) - log_min_) * bins_per_decade_));
  k = std::clamp(k, 0L, long(energy_bins()) - 1);
  while (k > 0 && j_per_kg < energy_edges_[std::size_t(k)]) --k;
  while (k + 1 < long(energy_bins()) && j_per_kg >= energy_edges_[std::size_t(k) + 1]) ++k;
  return std::size_t(k);
}

std::size_t ImpactSpectrum::group_index(const ImpactGroup& group) {
  for (std::size_t g = 0; g < groups_.size(); ++g)
    if (groups_[g] == group) return g;
  groups_.push_back(group);
  normal_.emplace_back(size_classes() * energy_bins(), 0);
  tangential_.emplace_back(size_classes() * energy_bins(), 0);
  return groups_.size() - 1;
}

void ImpactSpectrum::add(const ImpactGroup& group, double diameter_m, double normal_speed_m_per_s,
                         double tangential_speed_m_per_s) {
  const std::size_t g = group_index(group);
  const std::size_t row = size_class(diameter_m) * energy_bins();
  normal_[g][row + energy_bin(0.5 * normal_speed_m_per_s * normal_speed_m_per_s)] += 1;
  tangential_[g][row + energy_bin(0.5 * tangential_speed_m_per_s * tangential_speed_m_per_s)] += 1;
  ++impacts_;
}

void ImpactSpectrum::close_interval(double time_s) {
  interval_end_s_.push_back(time_s);
  marks_normal_.push_back(normal_);
  marks_tangential_.push_back(tangential_);
}

std::vector<std::uint64_t> ImpactSpectrum::interval_counts(
    const std::vector<std::vector<std::vector<std::uint64_t>>>& marks, std::size_t k,
    std::size_t g) const {
  std::vector<std::uint64_t> out(size_classes() * energy_bins(), 0);
  if (k >= marks.size() || g >= marks[k].size()) return out;
  out = marks[k][g];
  if (k > 0 && g < marks[k - 1].size())
    for (std::size_t c = 0; c < out.size(); ++c) out[c] -= marks[k - 1][g][c];
  return out;
}

std::vector<std::uint64_t> ImpactSpectrum::interval_normal_counts(std::size_t k,
                                                                  std::size_t g) const {
  return interval_counts(marks_normal_, k, g);
}

std::vector<std::uint64_t> ImpactSpectrum::interval_tangential_counts(std::size_t k,
                                                                      std::size_t g) const {
  return interval_counts(marks_tangential_, k, g);
}

}  // namespace millsim
