#include "process/mass_flows.h"

#include <algorithm>

namespace millsim {

MassFlows make_mass_flows(const std::vector<double>& edges_m) {
  MassFlows f;
  f.slots = int(edges_m.size()) + 1;  // B = edges − 1 classes, plus under- and overflow
  const std::size_t n = std::size_t(f.compartments());
  f.fed_kg.assign(n, 0.0);
  f.left_kg.assign(n, 0.0);
  f.left_count.assign(n, 0.0);
  f.held_kg_s.assign(n, 0.0);
  f.events.assign(n, 0.0);
  f.wall_events.assign(n, 0.0);
  f.moved_kg.assign(n * n, 0.0);
  f.area_m2_s.assign(std::size_t(f.slots), 0.0);
  f.exposure_kg_m2_s.assign(n, 0.0);
  f.tracked_now_kg.assign(std::size_t(f.slots), 0.0);
  f.tracked_area_now_m2.assign(std::size_t(f.slots), 0.0);
  return f;
}

int psd_slot(const std::vector<double>& edges, double d) {
  if (edges.empty() || d < edges.front()) return 0;
  if (d >= edges.back()) return int(edges.size());
  return int(std::upper_bound(edges.begin(), edges.end(), d) - edges.begin());
}

void integrate_tracked(MassFlows& f, double time_s) {
  const double dt = time_s - f.integrated_to_s;
  if (!(dt > 0.0)) return;
  const double area = tracked_area_m2(f);
  for (std::size_t s = 0; s < std::size_t(f.slots); ++s) {
    f.held_kg_s[s] += f.tracked_now_kg[s] * dt;
    f.area_m2_s[s] += f.tracked_area_now_m2[s] * dt;
    f.exposure_kg_m2_s[s] += f.tracked_now_kg[s] * area * dt;
  }
  f.integrated_to_s = time_s;
}

double tracked_area_m2(const MassFlows& f) {
  double area = 0.0;
  for (double a : f.tracked_area_now_m2) area += a;
  return area;
}

MassFlows flows_between(const MassFlows& earlier, const MassFlows& later) {
  MassFlows d = later;
  const auto subtract = [](std::vector<double>& a, const std::vector<double>& b) {
    for (std::size_t k = 0; k < a.size() && k < b.size(); ++k) a[k] -= b[k];
  };
  subtract(d.fed_kg, earlier.fed_kg);
  subtract(d.left_kg, earlier.left_kg);
  subtract(d.left_count, earlier.left_count);
  subtract(d.held_kg_s, earlier.held_kg_s);
  subtract(d.events, earlier.events);
  subtract(d.wall_events, earlier.wall_events);
  subtract(d.moved_kg, earlier.moved_kg);
  subtract(d.area_m2_s, earlier.area_m2_s);
  subtract(d.exposure_kg_m2_s, earlier.exposure_kg_m2_s);
  return d;
}

}  // namespace millsim
