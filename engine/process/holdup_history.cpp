// The hold-up history's steady-state window and JSON (process/holdup_history.h).
#include "process/holdup_history.h"

#include <cmath>

namespace millsim {

std::optional<SteadyWindow> steady_window(const std::vector<HoldupRow>& rows, double start_s,
                                          double end_s, bool ledger, double step_s) {
  const double slack = std::max(step_s, 1e-9 * std::max(std::abs(start_s), std::abs(end_s)));
  const HoldupRow* a = nullptr;
  const HoldupRow* b = nullptr;
  for (const HoldupRow& r : rows) {
    if (!a && r.time_s >= start_s - slack) a = &r;
    if (r.time_s <= end_s + slack) b = &r;
  }
  if (!a || !b || b->time_s <= a->time_s) return std::nullopt;
  SteadyWindow w;
  w.start_s = a->time_s;
  w.end_s = b->time_s;
  w.fed_kg = b->fed_kg - a->fed_kg;
  if (!(w.fed_kg > 0.0)) return std::nullopt;
  w.outlet_kg = b->outlet_kg - a->outlet_kg;
  w.dust_made_kg = b->dust_made_kg - a->dust_made_kg;
  w.dust_out_kg = b->dust_out_kg - a->dust_out_kg;
  w.outflow_kg = w.outlet_kg + (ledger ? w.dust_out_kg : w.dust_made_kg);
  w.particles_change_kg = b->particles_kg - a->particles_kg;
  w.dust_held_change_kg = b->dust_held_kg - a->dust_held_kg;
  w.outflow_to_feed = w.outflow_kg / w.fed_kg;
  w.made_to_feed = (w.outlet_kg + w.dust_made_kg) / w.fed_kg;
  w.outflow_steady = std::abs(w.outflow_to_feed - 1.0) <= kSteadyOutflowTolerance;
  const double allowed = kSteadyOutflowTolerance * w.fed_kg;
  w.holdup_steady =
      std::abs(w.particles_change_kg) <= allowed && std::abs(w.dust_held_change_kg) <= allowed;
  w.steady = w.outflow_steady && w.holdup_steady;
  return w;
}

nlohmann::ordered_json holdup_history_json(const std::vector<HoldupRow>& rows) {
  nlohmann::ordered_json time = nlohmann::ordered_json::array(), fed = time, particles = time,
                         outlet = time, made = time, out = time, held = time, events = time,
                         by_class = time, made_by_class = time;
  for (const HoldupRow& r : rows) {
    time.push_back(r.time_s);
    fed.push_back(r.fed_kg);
    particles.push_back(r.particles_kg);
    outlet.push_back(r.outlet_kg);
    made.push_back(r.dust_made_kg);
    out.push_back(r.dust_out_kg);
    held.push_back(r.dust_held_kg);
    events.push_back(r.events_by_generation);
    by_class.push_back(r.holdup_by_class_kg);
    made_by_class.push_back(r.dust_made_by_class_kg);
  }
  return {{"time_s", time},
          {"fed_kg", fed},
          {"particles_kg", particles},
          {"outlet_kg", outlet},
          {"dust_made_kg", made},
          {"dust_out_kg", out},
          {"dust_held_kg", held},
          {"events_by_generation", events},
          {"particles_by_class_kg", by_class},
          {"dust_made_by_class_kg", made_by_class}};
}

nlohmann::ordered_json steady_window_json(const SteadyWindow& w) {
  return {{"window_s", {w.start_s, w.end_s}},
          {"fed_kg", w.fed_kg},
          {"outlet_kg", w.outlet_kg},
          {"dust_made_kg", w.dust_made_kg},
          {"dust_out_kg", w.dust_out_kg},
          {"outflow_kg", w.outflow_kg},
          {"outflow_to_feed", w.outflow_to_feed},
          {"made_to_feed", w.made_to_feed},
          {"particles_change_kg", w.particles_change_kg},
          {"dust_held_change_kg", w.dust_held_change_kg},
          {"tolerance", kSteadyOutflowTolerance},
          {"outflow_steady", w.outflow_steady},
          {"holdup_steady", w.holdup_steady},
          {"steady", w.steady}};
}

}  // namespace millsim
