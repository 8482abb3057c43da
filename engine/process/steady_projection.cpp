#include "process/steady_projection.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <utility>

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

#include "process/psd.h"

namespace millsim {

namespace {

// Time steps of the projected course over its horizon: the time to steady is resolved to this
// share of the horizon.
constexpr int kCourseSteps = 4000;
// The horizon: this many times the sum of the compartments' residence times 1 / out.
constexpr double kHorizonResidences = 20.0;

// Coarsest slot first, each slot's particles before its dust: breakage and grinding move mass
// only forwards in this order.
std::vector<int> balance_order(int slots) {
  std::vector<int> order;
  for (int s = slots - 1; s >= 0; --s) order.push_back(s), order.push_back(slots + s);
  return order;
}

PsdTally product_tally(const std::vector<double>& product_by_slot,
                       const std::vector<double>& edges_m) {
  PsdTally t(edges_m);
  const std::size_t last = product_by_slot.size() - 1;
  t.under_mass_kg = product_by_slot[0];
  for (std::size_t b = 0; b < t.mass_kg.size(); ++b) t.mass_kg[b] = product_by_slot[b + 1];
  t.over_mass_kg = product_by_slot[last];
  return t;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double x = q * double(v.size() - 1);
  const std::size_t k = std::size_t(x);
  if (k + 1 >= v.size()) return v.back();
  return v[k] + (x - double(k)) * (v[k + 1] - v[k]);
}

}  // namespace

double CompartmentRates::out_per_s(int c, double area) const {
  double out = leave_per_s[std::size_t(c)];
  for (int to = 0; to < compartments(); ++to) out += move_at(c, to, area);
  return out;
}

double CompartmentRates::area_m2(const std::vector<double>& held_kg) const {
  double area = 0.0;
  for (std::size_t s = 0; s < area_per_kg.size(); ++s) area += area_per_kg[s] * held_kg[s];
  return area;
}

bool CompartmentRates::grinds() const {
  for (double g : grind_per_m2_s)
    if (g > 0.0) return true;
  return false;
}

CompartmentRates fit_rates(const MassFlows& w, double window_s) {
  CompartmentRates r;
  r.slots = w.slots;
  r.window_s = window_s;
  const int n = w.compartments();
  const std::size_t nn = std::size_t(n) * std::size_t(n);
  r.feed_kg_per_s.assign(std::size_t(n), 0.0);
  r.leave_per_s.assign(std::size_t(n), 0.0);
  r.move_per_s.assign(nn, 0.0);
  r.grind_per_m2_s.assign(nn, 0.0);
  r.area_per_kg.assign(std::size_t(w.slots), 0.0);
  r.mean_held_kg.assign(std::size_t(n), 0.0);
  r.pass_through.assign(std::size_t(n), 0);
  r.events = w.events;
  r.wall_events = w.wall_events;
  r.left_count = w.left_count;
  for (int s = 0; s < w.slots; ++s) {
    const std::size_t k = std::size_t(s);
    if (w.held_kg_s[k] > 0.0) r.area_per_kg[k] = w.area_m2_s[k] / w.held_kg_s[k];
    r.mean_area_m2 += w.area_m2_s[k] / window_s;
  }
  for (int c = 0; c < n; ++c) {
    const std::size_t k = std::size_t(c);
    const double held = w.held_kg_s[k], exposure = w.exposure_kg_m2_s[k];
    const bool dust = c >= w.slots;
    r.feed_kg_per_s[k] = w.fed_kg[k] / window_s;
    r.mean_held_kg[k] = held / window_s;
    double received = w.fed_kg[k];
    for (int from = 0; from < n; ++from)
      if (from != c) received += w.moved(from, c);
    if (!(held > 0.0)) {
      r.pass_through[k] = received > 0.0;
      continue;
    }
    r.leave_per_s[k] = w.left_kg[k] / held;
    // The share of the moves that grows with the particles' cross-section: dust moved to dust
    // was ground by the particles; particles broken by meeting another particle (or crushed
    // against one) met it at a rate that grows with their number. Wall impacts do not.
    double collided = 0.0;
    if (exposure > 0.0)
      collided = dust                ? 1.0
                 : w.events[k] > 0.0 ? (w.events[k] - w.wall_events[k]) / w.events[k]
                                     : 0.0;
    for (int to = 0; to < n; ++to) {
      if (to == c) continue;
      const std::size_t entry = k * std::size_t(n) + std::size_t(to);
      const double moved = w.moved(c, to);
      r.grind_per_m2_s[entry] = collided * moved / (exposure > 0.0 ? exposure : 1.0);
      r.move_per_s[entry] = (1.0 - collided) * moved / held;
    }
  }
  return r;
}

void take_particle_rates(CompartmentRates& r, const CompartmentRates& pooled) {
  if (pooled.slots != r.slots)
    throw std::logic_error("take_particle_rates: rates over different compartments");
  const std::size_t n = std::size_t(r.compartments());
  for (std::size_t c = 0; c < std::size_t(r.slots); ++c) {
    // A class the span held but r's window did not (a feed size no particle of which arrived
    // in it) takes the span's rates too; one the span never held has none.
    if (!(pooled.mean_held_kg[c] > 0.0)) continue;
    r.pass_through[c] = 0;
    r.leave_per_s[c] = pooled.leave_per_s[c];
    r.events[c] = pooled.events[c];
    r.wall_events[c] = pooled.wall_events[c];
    r.left_count[c] = pooled.left_count[c];
    std::copy_n(pooled.move_per_s.begin() + std::ptrdiff_t(c * n), n,
                r.move_per_s.begin() + std::ptrdiff_t(c * n));
    std::copy_n(pooled.grind_per_m2_s.begin() + std::ptrdiff_t(c * n), n,
                r.grind_per_m2_s.begin() + std::ptrdiff_t(c * n));
  }
}

namespace {

// The steady state of one group of compartments (the particles', then the dust's) in the
// balance's order, at a cross-section A; false when a move goes backwards in it.
bool solve_group(const CompartmentRates& r, const std::vector<int>& group, double area,
                 std::vector<double>& inflow, std::vector<char>& done, SteadyProjection& p) {
  const int n = r.compartments();
  const std::size_t slots = std::size_t(r.slots);
  bool forwards = true;
  for (int c : group) {
    const std::size_t k = std::size_t(c);
    done[k] = 1;
    double held = 0.0;
    const bool fixed = !r.fixed_held_kg.empty() && r.fixed_held_kg[k] >= 0.0;
    if (r.pass_through[k]) {
      p.product_kg_per_s[k % slots] += inflow[k];
    } else if (fixed && (inflow[k] > 0.0 || r.fixed_held_kg[k] > 0.0)) {
      held = r.fixed_held_kg[k], p.fixed.push_back(c);
      p.product_kg_per_s[k % slots] += r.leave_per_s[k] * held;
    } else if (const double out = r.out_per_s(c, area); out > 0.0) {
      held = inflow[k] / out;
      p.product_kg_per_s[k % slots] += r.leave_per_s[k] * held;
    } else if (inflow[k] > 0.0) {
      p.accumulating.push_back(c);
    }
    p.held_kg[k] = held;
    for (int to = 0; to < n; ++to) {
      const double rate = r.move_at(c, to, area);
      if (rate <= 0.0) continue;
      if (done[std::size_t(to)]) forwards = false;  // not the order breakage keeps
      inflow[std::size_t(to)] += rate * held;
    }
  }
  return forwards;
}

// The balance d/dt [M; 1] = X [M; 1] over the compartments that hold mass (`active`), at a
// cross-section A; `output` · [M; 1] is the outflow (what enters a pass-through compartment
// leaves at once).
void balance_matrix(const CompartmentRates& r, const std::vector<int>& active,
                    const std::vector<int>& index, double area, Eigen::MatrixXd& x,
                    Eigen::VectorXd& output) {
  const int n = r.compartments(), m = int(active.size());
  x.setZero(m + 1, m + 1);
  output.setZero(m + 1);
  for (int a = 0; a < m; ++a) {
    const int c = active[std::size_t(a)];
    x(a, a) = -r.out_per_s(c, area);
    x(a, m) = r.feed_kg_per_s[std::size_t(c)];
    output(a) = r.leave_per_s[std::size_t(c)];
    for (int to = 0; to < n; ++to) {
      const double rate = r.move_at(c, to, area);
      if (rate <= 0.0) continue;
      if (index[std::size_t(to)] >= 0)
        x(index[std::size_t(to)], a) += rate;
      else
        output(a) += rate;
    }
  }
  for (int c = 0; c < n; ++c)
    if (r.pass_through[std::size_t(c)]) output(m) += r.feed_kg_per_s[std::size_t(c)];
}

// The particles' steady cross-section A*: their steady hold-up at a cross-section A has the
// cross-section f(A), which falls as A grows (collisions break more), so A* = f(A*) is the one
// root of f(A) − A, found by doubling then bisection. Without collisions f is constant.
double steady_area_m2(const CompartmentRates& r, const std::vector<int>& particles) {
  const int n = r.compartments();
  const auto area_at = [&](double area) {
    SteadyProjection p;
    p.held_kg.assign(std::size_t(n), 0.0);
    p.product_kg_per_s.assign(std::size_t(r.slots), 0.0);
    std::vector<double> inflow(r.feed_kg_per_s);
    std::vector<char> done(std::size_t(n), 0);
    solve_group(r, particles, area, inflow, done, p);
    return p.accumulating.empty() ? r.area_m2(p.held_kg) : 1e300;
  };
  double lo = 0.0, hi = std::max(r.mean_area_m2, 1e-30);
  for (int i = 0; i < 200 && area_at(hi) > hi; ++i) lo = hi, hi *= 2.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (area_at(mid) > mid ? lo : hi) = mid;
  }
  return hi;
}

// The course renews its propagator when A has moved by this share since the last renewal.
constexpr double kCourseAreaChange = 0.05;

}  // namespace

std::pair<double, double> held_by_phase_kg(const SteadyProjection& p, int slots) {
  double particles = 0.0, dust = 0.0;
  for (std::size_t c = 0; c < p.held_kg.size(); ++c)
    (int(c) < slots ? particles : dust) += p.held_kg[c];
  return {particles, dust};
}

SteadyProjection project_steady(const CompartmentRates& r, const std::vector<double>& start_held_kg,
                                int course_points) {
  SteadyProjection p;
  const int n = r.compartments(), slots = r.slots;
  p.held_kg.assign(std::size_t(n), 0.0);
  p.product_kg_per_s.assign(std::size_t(slots), 0.0);
  for (double f : r.feed_kg_per_s) p.feed_kg_per_s += f;
  // The steady state: the particles compartment by compartment, then their cross-section, then
  // the dust.
  std::vector<int> particles, dust;
  for (int c : balance_order(slots)) (c < slots ? particles : dust).push_back(c);
  const double area = steady_area_m2(r, particles);
  std::vector<double> inflow(r.feed_kg_per_s);
  std::vector<char> done(std::size_t(n), 0);
  bool forwards = solve_group(r, particles, area, inflow, done, p);
  p.area_m2 = r.area_m2(p.held_kg);
  forwards = solve_group(r, dust, p.area_m2, inflow, done, p) && forwards;
  p.exists = forwards && p.accumulating.empty() && p.feed_kg_per_s > 0.0;
  if (!forwards || course_points <= 0) return p;

  // The compartments that can ever hold mass: those that start with some, are fed, or receive
  // from one of them (moves go forwards in the particles-then-dust order).
  std::vector<char> reachable(std::size_t(n), 0);
  std::vector<int> order = particles;
  order.insert(order.end(), dust.begin(), dust.end());
  for (int c : order) {
    const std::size_t k = std::size_t(c);
    if (start_held_kg[k] > 0.0 || r.feed_kg_per_s[k] > 0.0) reachable[k] = 1;
    if (!reachable[k]) continue;
    for (int to = 0; to < n; ++to)
      if (r.move(c, to) > 0.0 || r.grind(c, to) > 0.0) reachable[std::size_t(to)] = 1;
  }
  std::vector<int> active;
  std::vector<int> index(std::size_t(n), -1);
  for (int c = 0; c < n; ++c)
    if (reachable[std::size_t(c)] && !r.pass_through[std::size_t(c)])
      index[std::size_t(c)] = int(active.size()), active.push_back(c);
  const int m = int(active.size());
  double residences = 0.0;
  for (int c : active) {
    const double out = r.out_per_s(c, p.area_m2);
    if (out > 0.0 && (p.held_kg[std::size_t(c)] > 0.0 || start_held_kg[std::size_t(c)] > 0.0))
      residences += 1.0 / out;
  }
  if (!(residences > 0.0) || !(p.feed_kg_per_s > 0.0)) return p;
  p.horizon_s = kHorizonResidences * residences;
  const double dt = p.horizon_s / kCourseSteps;
  Eigen::VectorXd y(m + 1);
  for (int a = 0; a < m; ++a) y(a) = start_held_kg[std::size_t(active[std::size_t(a)])];
  y(m) = 1.0;
  const auto area_now = [&] {
    std::vector<double> held(std::size_t(n), 0.0);
    for (int a = 0; a < m; ++a) held[std::size_t(active[std::size_t(a)])] = y(a);
    return r.area_m2(held);
  };
  const bool renew = r.grinds();
  Eigen::MatrixXd x, step;
  Eigen::VectorXd output;
  int last_outside = -1;
  // The kept points, spaced evenly in log time (the course's first steps hold its fast part).
  std::vector<char> keep(std::size_t(kCourseSteps) + 1, 0);
  keep[0] = 1;
  for (int k = 0; k < course_points; ++k)
    keep[std::size_t(std::lround(
        std::pow(double(kCourseSteps), double(k) / std::max(course_points - 1, 1))))] = 1;
  double renewed_area = -1.0;
  for (int s = 0; s <= kCourseSteps; ++s) {
    // The course from the start by the exact propagator exp(X Δt) of the balance at the
    // cross-section now, renewed whenever that has moved since the last renewal.
    const double area = renew || s == 0 ? area_now() : renewed_area;
    if (s == 0 || std::abs(area - renewed_area) > kCourseAreaChange * renewed_area) {
      balance_matrix(r, active, index, area, x, output);
      step = (x * dt).exp();
      renewed_area = area;
    }
    if (s > 0) y = step * y;
    const double ratio = output.dot(y) / p.feed_kg_per_s;
    if (!(std::abs(ratio - 1.0) <= kProjectionSteadyTolerance)) last_outside = s;
    if (keep[std::size_t(s)]) {
      p.course_time_s.push_back(s * dt);
      p.course_held_kg.push_back(y.head(m).sum());
      p.course_outflow_to_feed.push_back(ratio);
    }
  }
  if (p.exists && last_outside < kCourseSteps) p.time_to_steady_s = (last_outside + 1) * dt;
  return p;
}

ProjectionSpread projection_spread(const CompartmentRates& r,
                                   const std::vector<double>& start_held_kg,
                                   const std::vector<double>& edges_m, int draws,
                                   std::uint64_t seed) {
  ProjectionSpread spread;
  spread.draws = draws;
  std::mt19937_64 rng(seed);
  std::vector<double> d10, d50, d90, times, held_particles, held_dust, area;
  const int n = r.compartments();
  // A count's rate scale: Gamma(n + ½, 1) / n, whose mean is 1 + 1/(2n).
  const auto redraw = [&rng](double count) {
    std::gamma_distribution<double> g(count + 0.5, 1.0);
    return g(rng) / count;
  };
  for (int d = 0; d < draws; ++d) {
    CompartmentRates drawn = r;
    for (int c = 0; c < r.slots; ++c) {  // the particles' compartments
      const std::size_t k = std::size_t(c);
      if (r.events[k] > 0.0) {
        const double scale = redraw(r.events[k]);
        for (int to = 0; to < n; ++to) {
          drawn.move_per_s[k * std::size_t(n) + std::size_t(to)] *= scale;
          drawn.grind_per_m2_s[k * std::size_t(n) + std::size_t(to)] *= scale;
        }
      }
      if (r.left_count[k] > 0.0) drawn.leave_per_s[k] *= redraw(r.left_count[k]);
    }
    const SteadyProjection p = project_steady(drawn, start_held_kg, 0);
    if (!p.exists) continue;
    ++spread.draws_steady;
    const PsdSummary s = summarize(product_tally(p.product_kg_per_s, edges_m));
    d10.push_back(s.d10_m), d50.push_back(s.d50_m), d90.push_back(s.d90_m);
    if (p.time_to_steady_s >= 0.0) times.push_back(p.time_to_steady_s);
    const auto [particles, dust] = held_by_phase_kg(p, r.slots);
    held_particles.push_back(particles), held_dust.push_back(dust), area.push_back(p.area_m2);
  }
  const auto band = [](const std::vector<double>& v) {
    return v.empty() ? std::vector<double>{}
                     : std::vector<double>{quantile(v, 0.05), quantile(v, 0.5), quantile(v, 0.95)};
  };
  spread.d10_m = band(d10), spread.d50_m = band(d50), spread.d90_m = band(d90);
  spread.time_to_steady_s = band(times);
  spread.held_particles_kg = band(held_particles), spread.held_dust_kg = band(held_dust);
  spread.cross_section_m2 = band(area);
  return spread;
}

nlohmann::ordered_json steady_projection_json(const CompartmentRates& r, const SteadyProjection& p,
                                              const ProjectionSpread& spread,
                                              const std::vector<double>& edges_m) {
  const int slots = r.slots;
  std::vector<double> lower_edge{0.0};
  lower_edge.insert(lower_edge.end(), edges_m.begin(), edges_m.end());
  nlohmann::ordered_json accumulating = nlohmann::ordered_json::array();
  for (int c : p.accumulating) {
    const int s = c % slots;
    accumulating.push_back(
        {{"phase", c < slots ? "particles" : "dust"},
         {"lower_edge_m", lower_edge[std::size_t(s)]},
         {"upper_edge_m", std::size_t(s) < edges_m.size() ? edges_m[std::size_t(s)] : 1e300}});
  }
  const auto part = [&](const std::vector<double>& v, bool dust) {
    return std::vector<double>(v.begin() + (dust ? slots : 0),
                               v.begin() + (dust ? 2 * slots : slots));
  };
  // The rates of breakage and grinding as measured (at the window's mean cross-section) and at
  // steady state.
  std::vector<double> breakage_per_s, steady_breakage_per_s;
  double events = 0.0, wall_events = 0.0;
  for (int c = 0; c < 2 * slots; ++c) {
    const double leave = r.leave_per_s[std::size_t(c)];
    breakage_per_s.push_back(r.out_per_s(c, r.mean_area_m2) - leave);
    steady_breakage_per_s.push_back(r.out_per_s(c, p.area_m2) - leave);
    events += r.events[std::size_t(c)], wall_events += r.wall_events[std::size_t(c)];
  }
  const auto [held_particles, held_dust] = held_by_phase_kg(p, slots);
  double product = 0.0;
  for (double x : p.product_kg_per_s) product += x;
  const PsdSummary s = summarize(product_tally(p.product_kg_per_s, edges_m));
  nlohmann::ordered_json j;
  j["steady_state_exists"] = p.exists;
  j["accumulating"] = accumulating;
  j["feed_kg_per_s"] = p.feed_kg_per_s;
  j["holdup_kg"] = {{"particles", held_particles}, {"dust", held_dust}};
  j["cross_section_m2"] = {{"window_mean", r.mean_area_m2}, {"steady", p.area_m2}};
  j["breakage_events"] = {{"all", events}, {"by_wall_impact", wall_events}};
  j["time_to_steady_s"] = p.time_to_steady_s >= 0.0 ? nlohmann::ordered_json(p.time_to_steady_s)
                                                    : nlohmann::ordered_json(nullptr);
  j["horizon_s"] = p.horizon_s;
  std::vector<double> fractions;
  for (double x : p.product_kg_per_s)
    if (s.total_mass_kg > 0.0) fractions.push_back(x / s.total_mass_kg);
  j["product"] = {{"kg_per_s", product},
                  {"d10_m", s.d10_m},
                  {"d50_m", s.d50_m},
                  {"d90_m", s.d90_m},
                  {"mass_fraction_by_slot", fractions}};
  j["spread"] = {{"draws", spread.draws},
                 {"draws_steady", spread.draws_steady},
                 {"d10_m", spread.d10_m},
                 {"d50_m", spread.d50_m},
                 {"d90_m", spread.d90_m},
                 {"time_to_steady_s", spread.time_to_steady_s},
                 {"holdup_particles_kg", spread.held_particles_kg},
                 {"holdup_dust_kg", spread.held_dust_kg},
                 {"cross_section_m2", spread.cross_section_m2}};
  j["slots"] = {{"lower_edge_m", lower_edge}};
  for (bool dust : {false, true}) {
    j["slots"][dust ? "dust" : "particles"] = {
        {"mean_held_kg", part(r.mean_held_kg, dust)},
        {dust ? "ground_per_s" : "breakage_per_s", part(breakage_per_s, dust)},
        {"leave_per_s", part(r.leave_per_s, dust)},
        {dust ? "steady_ground_per_s" : "steady_breakage_per_s", part(steady_breakage_per_s, dust)},
        {"feed_kg_per_s", part(r.feed_kg_per_s, dust)},
        {"steady_held_kg", part(p.held_kg, dust)}};
    if (!dust) {
      j["slots"]["particles"]["events"] = part(r.events, false);
      j["slots"]["particles"]["wall_events"] = part(r.wall_events, false);
      j["slots"]["particles"]["cross_section_m2_per_kg"] = r.area_per_kg;
      j["slots"]["particles"]["left_count"] = part(r.left_count, false);
    }
  }
  j["course"] = {{"time_s", p.course_time_s},
                 {"held_kg", p.course_held_kg},
                 {"outflow_to_feed", p.course_outflow_to_feed}};
  return j;
}

}  // namespace millsim
