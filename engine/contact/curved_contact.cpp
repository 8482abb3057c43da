#include "contact/curved_contact.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace millsim {
namespace {

// B/A of the ellipse of eccentricity e (Johnson Eq. 4.39): [E/(1−e²) − K] / (K − E).
double curvature_ratio_of(double e) {
  const double k = std::comp_ellint_1(e), ee = std::comp_ellint_2(e);
  return (ee / (1.0 - e * e) - k) / (k - ee);
}

// G(e) = (π²/2) (K − E) / (e² K³): from δ = (p0 b/E*) K, A = (p0 b/E*)(K − E)/(e² a²) and
// P = (2/3) π a b p0, so that P = (4/3) E* √(G/(2A)) δ^{3/2}.
double radius_factor_of(double e) {
  const double k = std::comp_ellint_1(e), ee = std::comp_ellint_2(e);
  const double pi = std::numbers::pi;
  return 0.5 * pi * pi * (k - ee) / (e * e * k * k * k);
}

// The table's variable t = 1 − A/B in [0, kTableEnd].
constexpr int kTableIntervals = 4096;
constexpr double kTableEnd = 0.999;

struct RadiusFactorTable {
  std::array<double, kTableIntervals + 1> factor;
  RadiusFactorTable() {
    factor[0] = 1.0;
    for (int k = 1; k <= kTableIntervals; ++k) {
      const double t = kTableEnd * k / kTableIntervals;
      factor[k] = elliptic_hertz_contact(1.0 / (1.0 - t)).radius_factor;
    }
  }
};

}  // namespace

EllipticContact elliptic_hertz_contact(double curvature_ratio) {
  if (!(curvature_ratio > 1.0)) return {};
  // Near a circle K − E loses its digits; there B/A = 1 + (3/4) e² and G = 1 − (3/8) e², to
  // O(e⁴) = 1e-12 below B/A − 1 = 1e-6.
  const double excess = curvature_ratio - 1.0;
  if (excess < 1e-6) return {std::sqrt(excess / 0.75), 1.0 - 0.5 * excess};
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 200 && hi - lo > 1e-15; ++it) {
    const double mid = 0.5 * (lo + hi);
    (curvature_ratio_of(mid) < curvature_ratio ? lo : hi) = mid;
  }
  const double e = 0.5 * (lo + hi);
  return {e, radius_factor_of(e)};
}

double equivalent_contact_radius_m(double r, double curvature_per_m) {
  if (curvature_per_m == 0.0) return r;
  // Relative curvatures 1/r + κ and 1/r; A is half the smaller one.
  const double c1 = 1.0 / r + curvature_per_m, c2 = 1.0 / r;
  const double c_min = std::min(c1, c2), c_max = std::max(c1, c2);
  // A sphere as large as the concave cylinder (c_min ≤ 0) would conform to it: held at the
  // table's end, B/A = 1000.
  if (!(c_min > 0.0)) {
    const double c_held = c_max * (1.0 - kTableEnd);
    return elliptic_hertz_contact(c_max / c_held).radius_factor / c_held;
  }
  const double t = 1.0 - c_min / c_max;
  if (t >= kTableEnd) return elliptic_hertz_contact(c_max / c_min).radius_factor / c_min;
  static const RadiusFactorTable table;
  const double u = t * (kTableIntervals / kTableEnd);
  const int k = int(u);
  const double w = u - k;
  return ((1.0 - w) * table.factor[k] + w * table.factor[k + 1]) / c_min;
}

}  // namespace millsim
