#include "process/dust_exit_load.h"

#include <cmath>
#include <stdexcept>

namespace millsim {

DustExitWindow dust_exit_window(const CompartmentRates& r) {
  DustExitWindow w;
  for (int s = 0; s < r.slots; ++s) {
    const std::size_t c = std::size_t(r.slots + s);
    w.dust_kg += r.mean_held_kg[c];
    w.leave_per_s.push_back(r.leave_per_s[c]);
  }
  return w;
}

DustExitLoad fit_dust_exit_load(const DustExitWindow& earlier, const DustExitWindow& later) {
  if (earlier.leave_per_s.size() != later.leave_per_s.size())
    throw std::logic_error("fit_dust_exit_load: windows over different classes");
  DustExitLoad load;
  load.earlier_dust_kg = earlier.dust_kg;
  load.reference_dust_kg = later.dust_kg;
  load.exponent.assign(later.leave_per_s.size(), 0.0);
  if (!(earlier.dust_kg > 0.0 && later.dust_kg > 0.0)) return load;
  const double log_change = std::log(later.dust_kg / earlier.dust_kg);
  if (!(std::abs(log_change) >= kMinLoadLogChange)) return load;
  load.fitted = true;
  for (std::size_t s = 0; s < load.exponent.size(); ++s) {
    const double e0 = earlier.leave_per_s[s], e1 = later.leave_per_s[s];
    if (!(e0 > 0.0 && e1 > 0.0)) continue;  // a class that left in one window only: no fit
    const double beta = std::log(e1 / e0) / log_change;
    if (beta < 0.0)
      load.taken_as_zero.push_back(int(s));
    else
      load.exponent[s] = beta;
  }
  return load;
}

CompartmentRates rates_at_dust_kg(const CompartmentRates& r, const DustExitLoad& load,
                                  double dust_kg) {
  CompartmentRates at = r;
  if (!load.fitted) return at;
  if (int(load.exponent.size()) != r.slots)
    throw std::logic_error("rates_at_dust_kg: exponents over other classes than the rates");
  const double ratio = dust_kg / load.reference_dust_kg;
  for (int s = 0; s < r.slots; ++s) {
    const double beta = load.exponent[std::size_t(s)];
    if (beta > 0.0) at.leave_per_s[std::size_t(r.slots + s)] *= std::pow(ratio, beta);
  }
  return at;
}

LoadedProjection project_steady_at_own_load(const CompartmentRates& r, const DustExitLoad& load,
                                            const std::vector<double>& start_held_kg,
                                            int course_points) {
  const auto dust_kg = [&](const SteadyProjection& p) {
    return held_by_phase_kg(p, r.slots).second;
  };
  const auto at_own_rates = [&] {
    LoadedProjection out{project_steady(r, start_held_kg, course_points), 0.0};
    out.dust_kg = dust_kg(out.projection);
    return out;
  };
  bool loads = false;
  for (double beta : load.exponent) loads = loads || beta > 0.0;
  if (!load.fitted || !loads || !(load.reference_dust_kg > 0.0)) return at_own_rates();
  const SteadyProjection at_d1 = project_steady(r, start_held_kg, 0);
  // No steady state at any D: the caller names what accumulates.
  if (!at_d1.exists) return at_own_rates();
  // Σ_s M_s(D) − D falls as D grows (every E_s rises with D); a balance without a steady state
  // at D is one that holds too much for it.
  const auto excess = [&](double d) {
    const SteadyProjection p = project_steady(rates_at_dust_kg(r, load, d), start_held_kg, 0);
    return p.exists ? dust_kg(p) - d : 1e300;
  };
  const double d1 = load.reference_dust_kg;
  double lo = d1, hi = d1;
  if (dust_kg(at_d1) > d1) {
    hi = 2.0 * d1;
    for (int i = 0; i < 200 && excess(hi) > 0.0; ++i) lo = hi, hi *= 2.0;
  } else {
    lo = 0.5 * d1;
    for (int i = 0; i < 200 && excess(lo) < 0.0; ++i) hi = lo, lo *= 0.5;
  }
  for (int i = 0; i < 60 && hi > lo * (1.0 + 1e-13); ++i) {
    const double mid = std::sqrt(lo * hi);
    (excess(mid) > 0.0 ? lo : hi) = mid;
  }
  LoadedProjection out;
  out.dust_kg = std::sqrt(lo * hi);
  out.projection =
      project_steady(rates_at_dust_kg(r, load, out.dust_kg), start_held_kg, course_points);
  return out;
}

nlohmann::ordered_json dust_exit_load_json(const DustExitLoad& load, double projected_dust_kg) {
  nlohmann::ordered_json j;
  j["fitted"] = load.fitted;
  j["earlier_window_dust_kg"] = load.earlier_dust_kg;
  j["window_dust_kg"] = load.reference_dust_kg;
  j["exponent_by_slot"] = load.exponent;
  j["slots_taken_as_zero"] = load.taken_as_zero;
  j["projected_dust_kg"] = projected_dust_kg;
  return j;
}

}  // namespace millsim
