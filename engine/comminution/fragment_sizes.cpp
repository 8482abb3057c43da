#include "comminution/fragment_sizes.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace millsim {
namespace {

constexpr int kGridPoints = 1024;

// Unnormalised B(r) of the model.
double raw_cumulative(const FragmentConfig& c, double r) {
  if (c.model == FragmentModel::PowerLaw) return std::pow(r, c.exponent);
  return -std::expm1(-r);  // Broadbent–Callcott: 1 − e^{−r}
}

// Unnormalised mass density per unit ln r: r B'(r).
double raw_mass_density_per_log(const FragmentConfig& c, double r) {
  if (c.model == FragmentModel::PowerLaw) return c.exponent * std::pow(r, c.exponent);
  return r * std::exp(-r);
}

}  // namespace

FragmentSizeSampler::FragmentSizeSampler(const FragmentConfig& config) : config_(config) {
  if (config_.model == FragmentModel::Equal) return;
  const double lo = std::log(config_.min_ratio), hi = std::log(config_.max_ratio);
  log_ratio_.resize(kGridPoints);
  number_cdf_.assign(kGridPoints, 0.0);
  std::vector<double> density(kGridPoints);
  for (int g = 0; g < kGridPoints; ++g) {
    log_ratio_[g] = lo + (hi - lo) * g / (kGridPoints - 1);
    const double r = std::exp(log_ratio_[g]);
    density[g] = raw_mass_density_per_log(config_, r) / (r * r * r);  // number per ln r
  }
  for (int g = 1; g < kGridPoints; ++g)
    number_cdf_[g] = number_cdf_[g - 1] +
                     0.5 * (density[g] + density[g - 1]) * (log_ratio_[g] - log_ratio_[g - 1]);
  for (double& v : number_cdf_) v /= number_cdf_.back();
}

double FragmentSizeSampler::mass_cumulative(double r) const {
  if (config_.model == FragmentModel::Equal) return r >= std::cbrt(1.0 / config_.count) ? 1 : 0;
  r = std::clamp(r, config_.min_ratio, config_.max_ratio);
  const double a = raw_cumulative(config_, config_.min_ratio);
  const double b = raw_cumulative(config_, config_.max_ratio);
  return (raw_cumulative(config_, r) - a) / (b - a);
}

double FragmentSizeSampler::draw_one(Rng& rng) const {
  const double u = uniform01(rng);
  const auto it = std::upper_bound(number_cdf_.begin(), number_cdf_.end(), u);
  const std::size_t hi =
      std::clamp<std::size_t>(std::size_t(it - number_cdf_.begin()), 1, number_cdf_.size() - 1);
  const std::size_t lo = hi - 1;
  const double span = number_cdf_[hi] - number_cdf_[lo];
  const double t = span > 0.0 ? (u - number_cdf_[lo]) / span : 0.0;
  return std::exp(log_ratio_[lo] + t * (log_ratio_[hi] - log_ratio_[lo]));
}

std::vector<double> FragmentSizeSampler::draw_ratios(Rng& rng) const {
  std::vector<double> ratios;
  if (config_.model == FragmentModel::Equal) {
    ratios.assign(std::size_t(config_.count), std::cbrt(1.0 / config_.count));
    return ratios;
  }
  double remaining = 1.0;  // volume left, in parent volumes
  while (true) {
    const double r = draw_one(rng);
    if (r * r * r >= remaining || int(ratios.size()) + 1 >= config_.max_fragments) {
      ratios.push_back(std::cbrt(remaining));
      break;
    }
    ratios.push_back(r);
    remaining -= r * r * r;
  }
  std::sort(ratios.begin(), ratios.end(), std::greater<>());
  return ratios;
}

}  // namespace millsim
