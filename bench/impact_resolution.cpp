// How well one impact is resolved at N steps per Hertz contact time (/time/steps_per_contact,
// issue 29 item 3): the shipped mill's smallest contacts (10 µm salt on salt and on its steel
// walls, restitution 0.5, friction 0.5), head-on and at 45°, at 60 m/s (the mill's impact speed
// bound, which sets the automatic step) and 6 m/s. Each is stepped with dt = t_c / N, t_c its own
// Hertz contact time; the errors are against the same impact at 2 000 steps per contact, whose
// elastic twin is checked against Hertz's contact time first.
//   ./build/bench/impact_resolution [RESTITUTION]      (default 0.5, the mill's)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "dem/time_step.h"
#include "sim/simulation.h"

namespace {

using namespace millsim;

constexpr double kDiameter = 10e-6, kRadius = 0.5 * kDiameter;

MaterialConfig salt(double restitution) {
  return {"salt", 1e9, 0.25, 2160.0, restitution, 0.5, 0.0, false, {}};
}
MaterialConfig steel(double restitution) {
  return {"steel", 2e11, 0.3, 7800.0, restitution, 0.5, 0.0, false, {}};
}

struct ImpactCase {
  bool wall = false;         // salt on a steel wall, or two salt spheres
  double angle_rad = 0.0;    // from the normal
  double speed_m_per_s = 0;  // relative, at onset
};

struct Measured {
  double max_overlap_m = 0.0;
  double contact_time_s = 0.0;
  double normal_rebound = 0.0;      // rebound / impact normal relative speed
  double tangential_rebound = 0.0;  // rebound tangential contact-point speed / impact's
};

// Hertz's contact time (dem/time_step.h) at the normal approach speed, k = (4/3) E* √R*.
double contact_time_s(const ImpactCase& c) {
  const MaterialConfig a = salt(1.0), b = c.wall ? steel(1.0) : salt(1.0);
  const double e_star = 1.0 / ((1 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus_pa +
                               (1 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus_pa);
  const double r_star = c.wall ? kRadius : 0.5 * kRadius;
  const double mass = a.density_kg_per_m3 * std::numbers::pi / 6.0 * std::pow(kDiameter, 3);
  const double m_star = c.wall ? mass : 0.5 * mass;
  const double k = 4.0 / 3.0 * e_star * std::sqrt(r_star);
  return hertz_contact_time_s(m_star, k, c.speed_m_per_s * std::cos(c.angle_rad));
}

// The gap at the start is 2 % of the radius plus `phase` of one step's approach, so that phases in
// [0, 1) put the onset anywhere within a step.
SceneConfig scene(const ImpactCase& c, double restitution, double dt, double phase) {
  SceneConfig s;
  s.name = "impact";
  s.domain.min_m = {-1e-3, -1e-3, 0.0};
  s.domain.max_m = {1e-3, 1e-3, 2e-3};
  s.materials = {salt(restitution), steel(restitution)};
  s.domain.wall_material = 1;
  s.time.end_s = 1e-5;
  s.time.step_s = dt;
  s.output.write_h5 = false;
  s.contact.max_impact_speed_m_per_s = c.speed_m_per_s;
  const Vec3 toward = {std::sin(c.angle_rad), 0.0, -std::cos(c.angle_rad)};
  SourceConfig source;
  source.kind = SourceKind::List;
  const double start_gap = 0.02 * kRadius + phase * c.speed_m_per_s * std::cos(c.angle_rad) * dt;
  if (c.wall) {
    source.particles.push_back(
        {{0, 0, kRadius + start_gap}, toward * c.speed_m_per_s, {}, kDiameter});
  } else {
    const Vec3 centre = {0, 0, 1e-3};
    source.particles.push_back({centre + Vec3{0, 0, kRadius + 0.5 * start_gap},
                                toward * (0.5 * c.speed_m_per_s),
                                {},
                                kDiameter});
    source.particles.push_back({centre - Vec3{0, 0, kRadius + 0.5 * start_gap},
                                toward * (-0.5 * c.speed_m_per_s),
                                {},
                                kDiameter});
  }
  s.sources.push_back(source);
  return s;
}

// The relative normal and tangential speeds at the contact point (normal +z: the upper sphere's
// side), and the overlap.
struct Relative {
  double overlap_m, normal, tangential;
};
Relative relative(const Simulation& sim, bool wall) {
  const ParticleStore& p = sim.particles();
  const Motion& a = p.motion[0];
  if (wall) {
    const Vec3 v = a.velocity_m_per_s + cross(a.angular_velocity_rad_per_s, Vec3{0, 0, -kRadius});
    return {kRadius - p.position_m[0].z, v.z, v.x};
  }
  const Motion& b = p.motion[1];
  const Vec3 n =
      (p.position_m[0] - p.position_m[1]) * (1.0 / norm(p.position_m[0] - p.position_m[1]));
  const Vec3 v = a.velocity_m_per_s - b.velocity_m_per_s -
                 cross(a.angular_velocity_rad_per_s, n * kRadius) -
                 cross(b.angular_velocity_rad_per_s, n * kRadius);
  const Vec3 vt = v - n * dot(v, n);
  return {2.0 * kRadius - norm(p.position_m[0] - p.position_m[1]), dot(v, n), vt.x};
}

Measured measure(const ImpactCase& c, double restitution, double steps_per_contact,
                 double phase = 0.0) {
  const double dt = contact_time_s(c) / steps_per_contact;
  Simulation sim(scene(c, restitution, dt, phase));
  Measured m;
  const Relative before = relative(sim, c.wall);
  double previous = before.overlap_m, t_start = -1.0;
  for (long step = 0; step < 10'000'000; ++step) {
    if (const auto failure = sim.step()) {
      std::fprintf(stderr, "failed: %s\n", failure->detail.c_str());
      return m;
    }
    const Relative now = relative(sim, c.wall);
    if (previous <= 0.0 && now.overlap_m > 0.0)
      t_start = sim.time_s() - dt * now.overlap_m / (now.overlap_m - previous);
    m.max_overlap_m = std::max(m.max_overlap_m, now.overlap_m);
    if (previous > 0.0 && now.overlap_m <= 0.0 && t_start >= 0.0) {
      m.contact_time_s =
          sim.time_s() - dt * (-now.overlap_m) / (previous - now.overlap_m) - t_start;
      m.normal_rebound = -now.normal / before.normal;
      m.tangential_rebound = before.tangential != 0.0 ? now.tangential / before.tangential : 0.0;
      return m;
    }
    previous = now.overlap_m;
  }
  std::fprintf(stderr, "the contact never ended\n");
  return m;
}

double percent(double value, double reference) {
  return reference != 0.0 ? 100.0 * (value - reference) / std::abs(reference) : 0.0;
}

// Mean and largest magnitude of a set of errors, printed "mean (largest)".
struct Spread {
  double sum = 0.0, largest = 0.0;
  int count = 0;
  void add(double x) {
    sum += x, ++count;
    if (std::abs(x) > std::abs(largest)) largest = x;
  }
  std::string text() const {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%+.2f (%+.2f)", sum / count, largest);
    return buffer;
  }
};

}  // namespace

int main(int argc, char** argv) {
  const double restitution = argc > 1 ? std::atof(argv[1]) : 0.5;
  if (!(restitution > 0.0 && restitution <= 1.0)) {
    std::fprintf(stderr, "restitution %s: expected a number in (0, 1]\n", argv[1]);
    return 2;
  }
  const double reference_steps = 2000.0;
  const std::vector<ImpactCase> impacts = {
      {false, 0.0, 60.0}, {true, 0.0, 60.0}, {true, std::numbers::pi / 4, 60.0},
      {false, 0.0, 6.0},  {true, 0.0, 6.0},  {true, std::numbers::pi / 4, 6.0}};
  // The reference's elastic twin against Hertz's closed form.
  for (const ImpactCase& c : impacts) {
    if (c.angle_rad != 0.0) continue;
    const Measured elastic = measure(c, 1.0, reference_steps);
    const double t_c = contact_time_s(c);
    std::printf(
        "elastic %s %4.0f m/s at %g steps: contact time %+.4f %% from Hertz's, rebound %.5f\n",
        c.wall ? "wall" : "pair", c.speed_m_per_s, reference_steps,
        percent(elastic.contact_time_s, t_c), elastic.normal_rebound);
  }
  // Each error over 16 onset phases within a step: the mean and the largest in magnitude. Overlap,
  // contact time and normal rebound in % of the reference; the tangential rebound (the contact
  // point's tangential speed after the impact over before, near 0 at 45°: the contact sticks and
  // the sphere leaves rolling) in percentage points.
  constexpr int kPhases = 16;
  std::printf(
      "\n| impact | speed m/s | steps per contact | max overlap %% | contact time %% "
      "| normal rebound %% | tangential rebound, points |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- |\n");
  for (const ImpactCase& c : impacts) {
    const Measured ref = measure(c, restitution, reference_steps);
    const char* name = !c.wall              ? "pair, head-on"
                       : c.angle_rad == 0.0 ? "wall, head-on"
                                            : "wall, 45°";
    std::printf("| %s | %g | %g (reference) | %.4g µm | %.4g ns | e = %.4f | %.4f |\n", name,
                c.speed_m_per_s, reference_steps, ref.max_overlap_m * 1e6, ref.contact_time_s * 1e9,
                ref.normal_rebound, ref.tangential_rebound);
    for (double n : {8.0, 10.0, 12.0, 16.0, 20.0, 40.0}) {
      Spread overlap, time, normal, tangential;
      for (int k = 0; k < kPhases; ++k) {
        const Measured m = measure(c, restitution, n, (k + 0.5) / kPhases);
        overlap.add(percent(m.max_overlap_m, ref.max_overlap_m));
        time.add(percent(m.contact_time_s, ref.contact_time_s));
        normal.add(percent(m.normal_rebound, ref.normal_rebound));
        tangential.add(100.0 * (m.tangential_rebound - ref.tangential_rebound));
      }
      std::printf("| %s | %g | %g | %s | %s | %s | %s |\n", name, c.speed_m_per_s, n,
                  overlap.text().c_str(), time.text().c_str(), normal.text().c_str(),
                  c.angle_rad != 0.0 ? tangential.text().c_str() : "");
    }
  }
  return 0;
}
