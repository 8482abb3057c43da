#include "comminution/fragment_sizes.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace millsim {
namespace {

constexpr int kGridPoints = 4096;
// With min_ratio = 0 the drawn sizes reach down to this ratio at most; the volume below it always
// goes with the volume below the floor (it holds B(1e-5) of the mass: 1e-5 for a power law q = 1).
constexpr double kSmallestDrawnRatio = 1e-5;
// A breakage ends after this many draws in a row that did not fit (they stay in the pool).
constexpr int kMissesToStop = 16;
// The pool never holds more draws than this; past it the smallest are dropped. Reached only by
// parents whose floor lies above most of the pooled sizes (see draw).
constexpr std::size_t kMaxPool = 4096;

// Unnormalised B(r) of the drawn part.
double raw_cumulative(const FragmentConfig& c, double r) {
  switch (c.model) {
    case FragmentModel::BroadbentCallcott:
      return -std::expm1(-r);  // 1 − e^{−r}
    case FragmentModel::AustinLuckie:
      return c.fine_fraction * std::pow(r, c.fine_exponent) +
             (1.0 - c.fine_fraction) * std::pow(r, c.coarse_exponent);
    default:  // power law, and the broken share of Vogel–Peukert
      return std::pow(r, c.exponent);
  }
}

// Unnormalised mass density per unit ln r of the drawn part: r B'(r).
double raw_mass_density_per_log(const FragmentConfig& c, double r) {
  switch (c.model) {
    case FragmentModel::BroadbentCallcott:
      return r * std::exp(-r);
    case FragmentModel::AustinLuckie:
      return c.fine_fraction * c.fine_exponent * std::pow(r, c.fine_exponent) +
             (1.0 - c.fine_fraction) * c.coarse_exponent * std::pow(r, c.coarse_exponent);
    default:
      return c.exponent * std::pow(r, c.exponent);
  }
}

}  // namespace

FragmentSizeSampler::FragmentSizeSampler(const FragmentConfig& config) : config_(config) {
  if (config_.model == FragmentModel::Equal) return;
  const double lo = std::log(std::max(config_.min_ratio, kSmallestDrawnRatio));
  const double hi = std::log(config_.max_ratio);
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

double FragmentSizeSampler::drawn_cumulative(double r) const {
  if (config_.model == FragmentModel::Equal) return r >= std::cbrt(1.0 / config_.count) ? 1 : 0;
  r = std::clamp(r, config_.min_ratio, config_.max_ratio);
  const double a = raw_cumulative(config_, config_.min_ratio);
  const double b = raw_cumulative(config_, config_.max_ratio);
  return (raw_cumulative(config_, r) - a) / (b - a);
}

double FragmentSizeSampler::broken_share(double parent_diameter_m) const {
  if (config_.model != FragmentModel::VogelPeukert) return 1.0;
  const double y1 = config_.chipping_diameter_m;
  return 0.5 * (1.0 + std::tanh((parent_diameter_m - y1) / y1));
}

double FragmentSizeSampler::mass_cumulative(double r, double parent_diameter_m) const {
  const double share = broken_share(parent_diameter_m);
  // Vogel–Peukert's unbroken share is one fragment of that volume.
  if (share < 1.0 && r > std::cbrt(1.0 - share)) return 1.0;
  return share * drawn_cumulative(r);
}

double FragmentSizeSampler::number_cdf_at(double r) const {
  const double x = std::log(r);
  if (x <= log_ratio_.front()) return 0.0;
  if (x >= log_ratio_.back()) return 1.0;
  const double step = (log_ratio_.back() - log_ratio_.front()) / double(kGridPoints - 1);
  const std::size_t g = std::min<std::size_t>(std::size_t((x - log_ratio_.front()) / step),
                                              std::size_t(kGridPoints - 2));
  const double t = (x - log_ratio_[g]) / (log_ratio_[g + 1] - log_ratio_[g]);
  return number_cdf_[g] + t * (number_cdf_[g + 1] - number_cdf_[g]);
}

// Inverse of the number CDF on [floor, max_ratio]: u uniform on [cdf(floor), 1).
double FragmentSizeSampler::draw_one(double floor_cdf, Rng& rng) const {
  const double u = floor_cdf + (1.0 - floor_cdf) * uniform01(rng);
  const auto it = std::upper_bound(number_cdf_.begin(), number_cdf_.end(), u);
  const std::size_t hi =
      std::clamp<std::size_t>(std::size_t(it - number_cdf_.begin()), 1, number_cdf_.size() - 1);
  const std::size_t lo = hi - 1;
  const double span = number_cdf_[hi] - number_cdf_[lo];
  const double t = span > 0.0 ? (u - number_cdf_[lo]) / span : 0.0;
  return std::exp(log_ratio_[lo] + t * (log_ratio_[hi] - log_ratio_[lo]));
}

FragmentDraw FragmentSizeSampler::draw(double parent_diameter_m, double floor_ratio,
                                       FragmentPool& pool_state, Rng& rng) const {
  std::vector<double>& pool = pool_state.volumes;
  FragmentDraw out;
  if (config_.model == FragmentModel::Equal) {
    out.ratios.assign(std::size_t(config_.count), std::cbrt(1.0 / config_.count));
    return out;
  }
  const double floor = std::clamp(floor_ratio, std::exp(log_ratio_.front()), config_.max_ratio);
  const double floor_volume = floor * floor * floor;
  const double share = broken_share(parent_diameter_m);
  double free_volume = 1.0;
  // Vogel–Peukert: the unbroken share stays as one fragment (if it is tracked at all).
  if (share < 1.0 && 1.0 - share >= floor_volume) {
    out.ratios.push_back(std::cbrt(1.0 - share));
    free_volume = share;
  }
  out.below_floor_volume = free_volume * drawn_cumulative(floor);
  // A credit (more went below the floor before) lowers this breakage's share; a debt (a large
  // fragment took some of an earlier share, below) raises it, within what is free.
  const double credit = std::clamp(pool_state.below_floor_credit,
                                   out.below_floor_volume - free_volume, out.below_floor_volume);
  out.below_floor_volume -= credit;
  pool_state.below_floor_credit -= credit;
  free_volume -= out.below_floor_volume;
  const auto fits = [&](double v) {
    return v <= free_volume && v >= floor_volume &&
           int(out.ratios.size()) + 1 < config_.max_fragments;
  };
  const auto place = [&](double v) {
    out.ratios.push_back(std::cbrt(v));
    free_volume -= v;
  };
  // The pool first, largest first; what does not fit waits for the next breakage. A draw near
  // the parent's size fits only beside less than the share below the floor (a chip off a parent
  // that stays nearly whole): it takes the room from that share, and later breakages give the
  // share back (the pool's debt), so over many breakages the share is B(floor) and B holds up
  // to r = 1.
  std::sort(pool.begin(), pool.end(), std::greater<>());
  std::size_t kept = 0;
  for (double v : pool) {
    const double short_by = v - free_volume;
    if (short_by > 0.0 && short_by <= out.below_floor_volume && v >= floor_volume &&
        int(out.ratios.size()) + 1 < config_.max_fragments) {
      out.below_floor_volume -= short_by;
      free_volume += short_by;
      pool_state.below_floor_credit -= short_by;
    }
    if (fits(v))
      place(v);
    else
      pool[kept++] = v;
  }
  pool.resize(kept);
  const double floor_cdf = number_cdf_at(floor);
  for (int misses = 0; free_volume >= floor_volume && misses < kMissesToStop &&
                       int(out.ratios.size()) + 1 < config_.max_fragments;) {
    const double r = draw_one(floor_cdf, rng);
    const double v = r * r * r;
    if (v <= free_volume) {
      place(v);
      misses = 0;
    } else {
      pool.push_back(v);
      ++misses;
    }
  }
  if (pool.size() > kMaxPool) {
    std::sort(pool.begin(), pool.end(), std::greater<>());
    pool.resize(kMaxPool);
  }
  // The volume still free: one last fragment, or, if it lies below a floor under which B has
  // mass, more of the share below the floor, repaid by later breakages. (Below min_ratio B has
  // none: there the last fragment is what it is, smaller than the model allows.)
  const bool spreadable = drawn_cumulative(floor) > 0.0;
  if (free_volume >= floor_volume || (free_volume > 0.0 && !spreadable)) {
    out.ratios.push_back(std::cbrt(free_volume));
  } else if (free_volume > 0.0) {
    out.below_floor_volume += free_volume;
    pool_state.below_floor_credit += free_volume;
  }
  std::sort(out.ratios.begin(), out.ratios.end(), std::greater<>());
  return out;
}

}  // namespace millsim
