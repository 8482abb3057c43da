// GasGrid: the geometry of the structured Cartesian gas grid (a staggered MAC grid over the
// domain box) and what every cell and face is: fluid or solid cell, unknown / fixed / outflow
// face, and the boundary condition of each boundary cell. Built once from the GasConfig; the
// fields themselves live in gas/gas_solver.h.
//
// Layout: every field is a padded (nx+2)(ny+2)(nz+2) array; interior cells have indices 1..n
// along each axis, index 0 and n+1 are ghost cells that hold boundary values. Velocity
// component a at index c is the face on the + side of cell c along a, so the boundary faces
// are index 0 and n along a.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/vec3.h"
#include "gas/gas_config.h"

namespace millsim {

enum class FaceKind : std::uint8_t {
  None,      // not a face of the grid (in the ghost band)
  Unknown,   // solved for: predictor + projection
  Fixed,     // held at its stored value (walls, inlets, faces touching a solid cell)
  Outflow,   // outlet: zero-gradient predictor, corrected by the outlet pressure
  Solid,     // both sides solid: zero, and mirrored as a no-slip neighbour
  Periodic,  // face 0 of a periodic axis: a copy of face n
};

// The boundary condition of one ghost cell (one per boundary cell of a non-periodic face).
struct GhostBoundary {
  GasBoundaryKind kind = GasBoundaryKind::Wall;
  Vec3 velocity_m_per_s;  // wall velocity or inlet superficial velocity
  double pressure_pa = 0.0;
  int patch = -1;  // the config's boundary patch that set it (-1: the default wall)
};

// A face value that scales with a scheduled inflow's speed: a velocity (per m/s of speed) or a
// jet's body force (N/m³ per (m/s)²).
struct ScaledFaceValue {
  int axis = 0;
  std::size_t face = 0;
  double per_unit = 0.0;
};

// An inlet patch or a jet whose speed follows a schedule: what it sets at unit speed, so the
// solver can set any speed during a run (GasSolver::apply_inflow_schedules).
struct ScheduledInflow {
  InflowSchedule schedule;
  int patch = -1, jet = -1;  // which boundary patch or jet of the config
  double area_m2 = 0.0;      // flow per unit speed, m³/s per m/s (turns a mass flow into a speed)
  std::vector<ScaledFaceValue> velocity;
  std::vector<ScaledFaceValue> force;  // jets only: the momentum deficit's body force
  Vec3 momentum_deficit_per_unit;      // jets only, N per (m/s)²
};

// One face a jet blows through: the fluid cell behind it and the share of the jet's flow it
// carries (the face's area times the jet direction's component along it, over the jet's sum).
struct JetFace {
  int axis = 0;
  std::size_t face = 0, cell = 0;
  double flow_share = 0.0;
};

struct GasGrid {
  std::array<int, 3> n{1, 1, 1};
  Vec3 origin_m;  // the domain's min corner
  Vec3 h_m;       // cell edge per axis
  std::array<bool, 3> periodic{false, false, false};
  std::array<std::size_t, 3> stride{1, 1, 1};  // index offset of one step along each axis
  std::size_t padded_size = 0;

  std::vector<std::uint8_t> fluid;                 // per padded cell: 1 = interior fluid cell
  std::array<std::vector<FaceKind>, 3> face;       // per component
  std::array<std::vector<double>, 3> fixed_value;  // the held value of Fixed faces
  // Per padded cell of each ghost layer of non-periodic faces: that boundary's condition.
  std::vector<GhostBoundary> ghost;  // indexed like the fields; meaningful in ghost cells only
  std::size_t fluid_cells = 0;
  bool has_outflow = false;
  // Per boundary patch of the config: how many boundary faces in front of fluid cells it ended
  // up owning (a patch smaller than a cell, or over solid cells only, may own none) and their
  // area: the area the gas crosses.
  std::vector<std::size_t> patch_faces;
  std::vector<double> patch_area_m2;
  // Per jet of the config: the solid–fluid faces it blows through and the volume flow they carry
  // (the jet's set flow, unless it found no face).
  std::vector<std::size_t> jet_faces;
  std::vector<double> jet_flow_m3_per_s;
  std::vector<std::vector<JetFace>> jet_face_list;  // per jet: its faces (the compressible model)
  // A jet narrower than its faces enters slower than it should (same flow, more area): the
  // momentum flux it lacks, ρ Q (speed · direction) − Σ ρ A u_f u_f e_a, is added as a body
  // force (N/m³) on the faces of the fluid cells it blows into. Empty when there are no jets.
  std::array<std::vector<double>, 3> jet_force_n_per_m3;
  std::vector<Vec3> jet_momentum_deficit_n;  // per jet, what that force adds
  // Inflows that follow a schedule: their faces hold 0 until the solver applies a speed.
  std::vector<ScheduledInflow> scheduled_inflows;

  std::size_t index(int i, int j, int k) const {
    return std::size_t(i) + stride[1] * std::size_t(j) + stride[2] * std::size_t(k);
  }
  std::array<int, 3> coords(std::size_t c) const {
    return {int(c % stride[1]), int((c / stride[1]) % std::size_t(n[1] + 2)), int(c / stride[2])};
  }
  double cell_volume_m3() const { return h_m.x * h_m.y * h_m.z; }
  double face_area_m2(int axis) const { return cell_volume_m3() / h_m[axis]; }
  Vec3 cell_center(int i, int j, int k) const {
    return {origin_m.x + (i - 0.5) * h_m.x, origin_m.y + (j - 0.5) * h_m.y,
            origin_m.z + (k - 0.5) * h_m.z};
  }
  // The canonical index of a cell reached by stepping from an interior cell: on a periodic
  // axis a ghost index wraps to the interior cell it stands for.
  std::size_t wrap_cell(std::size_t c, int axis) const;
  // Calls fn(ghost, inner, high) for every cell of the two ghost layers of `axis` (over the full
  // padded range of the other axes, corners included); `inner` is the interior cell next to it
  // (its periodic image on a periodic axis), `high` is true on the + side.
  template <class Fn>
  void for_each_ghost(int axis, Fn&& fn) const {
    const std::size_t au = std::size_t(axis), s = stride[au];
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    const std::size_t sb = stride[std::size_t(b)], sc = stride[std::size_t(c)];
    const std::size_t na = std::size_t(n[au]);
    for (int jc = 0; jc <= n[std::size_t(c)] + 1; ++jc)
      for (int jb = 0; jb <= n[std::size_t(b)] + 1; ++jb) {
        const std::size_t low = std::size_t(jb) * sb + std::size_t(jc) * sc;
        const std::size_t high = low + (na + 1) * s;
        fn(low, periodic[au] ? low + na * s : low + s, false);
        fn(high, periodic[au] ? high - na * s : high - s, true);
      }
  }
  // The face that holds the value of face f of component a (Periodic faces point at face n).
  std::size_t canonical_face(std::size_t f, int axis) const {
    return face[axis][f] == FaceKind::Periodic ? f + std::size_t(n[axis]) * stride[axis] : f;
  }
};

// The grid node below x along each axis and x's fractional distance from it, for a
// cell-centred field (face_axis = −1) or component face_axis (nodes on its faces along that
// axis, at cell centres along the others); clamped so the node and the next one exist.
// Trilinear interpolation and deposition both start here.
struct GridCorner {
  std::array<int, 3> index{};
  std::array<double, 3> weight{};  // of the upper node, in [0, 1]
};
GridCorner lower_corner(const GasGrid& g, const Vec3& x, int face_axis);

// Builds the grid over the domain box: voxelises the solids, applies the boundary patches in
// order over the default wall, and classifies every face.
GasGrid build_gas_grid(const GasConfig& config, const Vec3& domain_min_m, const Vec3& domain_max_m,
                       const std::array<bool, 3>& periodic);

// True when x lies inside a solid of the config (used for voxelisation and by tests).
bool inside_gas_solid(const GasSolidConfig& solid, const Vec3& x);

// True when the boundary point x (on face `face`) is covered by the patch.
bool patch_covers(const GasBoundaryPatch& patch, const Vec3& x);

}  // namespace millsim
