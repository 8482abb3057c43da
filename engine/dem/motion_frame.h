// MotionFrame: a frame turning at a constant rate about a fixed axis, in which the neighbour list
// measures how far particles have moved since its last build (search/neighbor_list.h).
//
// Why a frame may turn: a list stays valid while no two particles can have closed the gaps it
// left out, and a rotation about any axis keeps every distance between particles. In a frame
// turning at Ω, the displacement of particle i since the build at time 0 is
// d_i(t) = x_i(t) − c − R(Ω t)(x_i(0) − c), and for any two particles
// |x_i(t) − x_j(t)| ≥ |x_i(0) − x_j(0)| − |d_i| − |d_j|: the usual rule (rebuild once some
// |d_i| may exceed half the skin) holds in the turning frame as in the lab. Against a wall the same
// holds when the wall is a surface of revolution about the frame's axis (or a plane normal to it):
// its gap to a point does not change as the point turns about the axis. In a spiral jet mill the
// particles' strand runs round the mantle at tens of m/s; in a frame turning with it they move
// much less, and a list lasts longer.
//
// What a step adds to d_i (velocity Verlet's drift x ← x + v½ dt, the frame turning by Ω dt):
//   |Δd_i| ≤ dt |v½ − Ω a × (x_i − c)| + |Ω| dt |d_i| + ½ (Ω dt)² ρ_max,
// x_i before the drift, ρ_max the largest distance of a build position from the axis (the frame
// carries each build position round at its own distance); the last two terms come from the
// frame's turn (the first from carrying the displacement itself round, the second the chord of the
// arc). The kick-drift passes report the first term's speed (FrameSpeed below); the list adds the
// other two (NeighborList::note_motion).
#pragma once

#include <cmath>
#include <cstddef>

#include "core/vec3.h"

namespace millsim {

struct MotionFrame {
  Vec3 center_m;                 // a point of the axis
  Vec3 axis{0.0, 0.0, 1.0};      // unit
  double omega_rad_per_s = 0.0;  // 0: the lab frame
  double radius_bound_m = 0.0;   // no build position lies farther from the axis (the chord term)
};

// Velocity relative to the frame of a particle at x moving at v: v − Ω a × (x − c). In the lab
// frame (Ω = 0) exactly v.
inline Vec3 frame_velocity(const MotionFrame& f, const Vec3& x_m, const Vec3& v_m_per_s) {
  return v_m_per_s - cross(f.axis, x_m - f.center_m) * f.omega_rad_per_s;
}
inline double frame_speed2(const MotionFrame& f, const Vec3& x_m, const Vec3& v_m_per_s) {
  return norm2(frame_velocity(f, x_m, v_m_per_s));
}

// What the kick-drift passes report each particle's speed against: the list's frame, and per
// slot the square of the factor its speed counts with, 1/κ_i² (null: 1 for every slot). A
// particle whose share of the skin is κ_i times the others' (NeighborList, "skin by speed")
// reports its speed divided by κ_i, so one bound, in units of the common share, covers all.
struct SpeedReport {
  MotionFrame frame;
  const double* scale2 = nullptr;
};

// The report as a pass reads it, once per pass: the frame's angular velocity vector w = Ω a and
// w × c held by value (read through a reference, the frame's fields were reloaded at every
// particle, since the pass's stores might alias them: the mill's kick-drift took 25 % longer),
// whether it turns at all, and the scales. In the lab frame without scales a pass computes |v|²
// alone, the same bits as frame_speed2.
struct FrameSpeed {
  Vec3 w_rad_per_s, w_cross_center_m_per_s;
  bool turning;
  const double* scale2;
  explicit FrameSpeed(const SpeedReport& r)
      : w_rad_per_s(r.frame.axis * r.frame.omega_rad_per_s),
        w_cross_center_m_per_s(cross(w_rad_per_s, r.frame.center_m)),
        turning(r.frame.omega_rad_per_s != 0.0),
        scale2(r.scale2) {}
  // Slot i at x moving at v: |v − w × (x − c)|² (w × (x − c) taken as w × x − w × c), scaled.
  double speed2(std::size_t i, const Vec3& x_m, const Vec3& v_m_per_s) const {
    const double s2 = turning
                          ? norm2(v_m_per_s - (cross(w_rad_per_s, x_m) - w_cross_center_m_per_s))
                          : norm2(v_m_per_s);
    return scale2 ? s2 * scale2[i] : s2;
  }
};

// The frame's turn over time t, its cosine and sine taken once for every point it carries:
// carried(x0) = c + R(Ω t)(x0 − c) (Rodrigues).
class FrameTurn {
 public:
  FrameTurn(const MotionFrame& f, double t_s)
      : f_(f), angle_(f.omega_rad_per_s * t_s), cos_(std::cos(angle_)), sin_(std::sin(angle_)) {}
  Vec3 carried(const Vec3& x0_m) const {
    if (angle_ == 0.0) return x0_m;
    const Vec3 r = x0_m - f_.center_m;
    return f_.center_m + r * cos_ + cross(f_.axis, r) * sin_ +
           f_.axis * (dot(f_.axis, r) * (1.0 - cos_));
  }

 private:
  MotionFrame f_;
  double angle_, cos_, sin_;
};

// Where the frame has carried the point x0 after time t (one point; FrameTurn for many).
inline Vec3 frame_carried(const MotionFrame& f, const Vec3& x0_m, double t_s) {
  return FrameTurn(f, t_s).carried(x0_m);
}

}  // namespace millsim
