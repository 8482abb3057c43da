#include "gas/gas_grid.h"

#include <algorithm>
#include <cmath>

namespace millsim {

bool inside_gas_solid(const GasSolidConfig& s, const Vec3& x) {
  switch (s.shape) {
    case GasSolidShape::Box:
      for (int a = 0; a < 3; ++a)
        if (x[a] < s.min_m[a] || x[a] > s.max_m[a]) return false;
      return true;
    case GasSolidShape::Cylinder: {
      const Vec3 d = x - s.center_m;
      const Vec3 radial = d - s.axis * dot(d, s.axis);
      const bool inside = norm2(radial) < s.radius_m * s.radius_m;
      return inside == s.solid_inside;
    }
    case GasSolidShape::HalfSpace:
      return dot(x - s.point_m, s.normal) < 0.0;
    case GasSolidShape::TubeShell: {
      const Vec3 d = x - s.center_m;
      const double axial = dot(d, s.axis);
      if (axial < s.axial_min_m || axial > s.axial_max_m) return false;
      return std::abs(norm(d - s.axis * axial) - s.radius_m) < s.half_thickness_m;
    }
  }
  return false;
}

bool patch_covers(const GasBoundaryPatch& p, const Vec3& x) {
  const int normal_axis = p.face / 2;
  switch (p.shape) {
    case PatchShape::WholeFace:
      return true;
    case PatchShape::Rectangle:
      for (int a = 0; a < 3; ++a)
        if (a != normal_axis && (x[a] < p.min_m[a] || x[a] > p.max_m[a])) return false;
      return true;
    case PatchShape::Circle: {
      double r2 = 0.0;
      for (int a = 0; a < 3; ++a)
        if (a != normal_axis) r2 += (x[a] - p.center_m[a]) * (x[a] - p.center_m[a]);
      return r2 <= p.radius_m * p.radius_m;
    }
  }
  return false;
}

GridCorner lower_corner(const GasGrid& g, const Vec3& x, int face_axis) {
  GridCorner c;
  for (int b = 0; b < 3; ++b) {
    const std::size_t bu = std::size_t(b);
    const bool on_faces = b == face_axis;
    double t = (x[b] - g.origin_m[b]) / g.h_m[b] + (on_faces ? 0.0 : 0.5);
    const double hi = on_faces ? double(g.n[bu]) : double(g.n[bu] + 1);
    t = std::clamp(t, 0.0, hi);
    const int i = std::min(int(t), int(hi) - 1);
    c.index[bu] = i;
    c.weight[bu] = t - i;
  }
  return c;
}

std::size_t GasGrid::wrap_cell(std::size_t c, int axis) const {
  if (!periodic[axis]) return c;
  const int i = coords(c)[std::size_t(axis)];
  if (i == 0) return c + std::size_t(n[axis]) * stride[axis];
  if (i == n[axis] + 1) return c - std::size_t(n[axis]) * stride[axis];
  return c;
}

namespace {

// Marks fluid cells: interior and outside every solid.
void voxelise(GasGrid& g, const GasConfig& config) {
  for (int k = 1; k <= g.n[2]; ++k)
    for (int j = 1; j <= g.n[1]; ++j)
      for (int i = 1; i <= g.n[0]; ++i) {
        const Vec3 x = g.cell_center(i, j, k);
        bool solid = false;
        for (const GasSolidConfig& s : config.solids) solid = solid || inside_gas_solid(s, x);
        g.fluid[g.index(i, j, k)] = solid ? 0 : 1;
        g.fluid_cells += solid ? 0 : 1;
      }
}

// Gives each ghost cell of a non-periodic face its boundary condition (last patch wins).
void assign_boundaries(GasGrid& g, const GasConfig& config) {
  for (int axis = 0; axis < 3; ++axis) {
    if (g.periodic[std::size_t(axis)]) continue;
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      const int face = 2 * axis + side;
      const int layer = side == 0 ? 0 : g.n[std::size_t(axis)] + 1;
      for (int jb = 0; jb <= g.n[std::size_t(b)] + 1; ++jb)
        for (int jc = 0; jc <= g.n[std::size_t(c)] + 1; ++jc) {
          std::array<int, 3> ijk{};
          ijk[std::size_t(axis)] = layer;
          ijk[std::size_t(b)] = jb;
          ijk[std::size_t(c)] = jc;
          Vec3 x = g.cell_center(ijk[0], ijk[1], ijk[2]);
          x[axis] = side == 0 ? g.origin_m[axis]
                              : g.origin_m[axis] + g.n[std::size_t(axis)] * g.h_m[axis];
          GhostBoundary bc;
          int owner = -1;
          for (std::size_t k = 0; k < config.boundaries.size(); ++k) {
            const GasBoundaryPatch& p = config.boundaries[k];
            if (p.face == face && patch_covers(p, x))
              bc = {p.kind, p.velocity_m_per_s, p.pressure_pa, int(k)}, owner = int(k);
          }
          g.ghost[g.index(ijk[0], ijk[1], ijk[2])] = bc;
          const bool on_face =
              jb >= 1 && jb <= g.n[std::size_t(b)] && jc >= 1 && jc <= g.n[std::size_t(c)];
          // A patch's faces and area are those in front of fluid cells: the gas crosses only
          // those (a patch over a mill's floor blows through the chamber's footprint alone).
          std::array<int, 3> inside = ijk;
          inside[std::size_t(axis)] = side == 0 ? 1 : g.n[std::size_t(axis)];
          const bool open = g.fluid[g.index(inside[0], inside[1], inside[2])] != 0;
          if (owner >= 0 && on_face && open) {
            ++g.patch_faces[std::size_t(owner)];
            g.patch_area_m2[std::size_t(owner)] += g.face_area_m2(axis);
          }
        }
    }
  }
}

// Classifies face f of component a (the + face of cell f).
void classify_face(GasGrid& g, int a, std::size_t f) {
  const std::size_t au = std::size_t(a);
  const std::array<int, 3> ijk = g.coords(f);
  for (int b = 0; b < 3; ++b)
    if (b != a && (ijk[std::size_t(b)] < 1 || ijk[std::size_t(b)] > g.n[std::size_t(b)])) return;
  if (ijk[au] > g.n[au]) return;
  const bool low_boundary = ijk[au] == 0, high_boundary = ijk[au] == g.n[au];
  if (g.periodic[au] && low_boundary) {
    g.face[au][f] = FaceKind::Periodic;
    return;
  }
  const std::size_t c0 = g.wrap_cell(f, a), c1 = g.wrap_cell(f + g.stride[au], a);
  if (!g.periodic[au] && (low_boundary || high_boundary)) {
    const std::size_t inner = low_boundary ? c1 : c0, ghost = low_boundary ? f : f + g.stride[au];
    const GhostBoundary& bc = g.ghost[ghost];
    if (!g.fluid[inner]) {
      g.face[au][f] = FaceKind::Solid;
    } else if (bc.kind == GasBoundaryKind::Outlet) {
      g.face[au][f] = FaceKind::Outflow;
      g.has_outflow = true;
    } else {
      g.face[au][f] = FaceKind::Fixed;
      g.fixed_value[au][f] = bc.kind == GasBoundaryKind::Inlet ? bc.velocity_m_per_s[a] : 0.0;
    }
    return;
  }
  const bool s0 = !g.fluid[c0], s1 = !g.fluid[c1];
  g.face[au][f] = s0 && s1 ? FaceKind::Solid : (s0 || s1 ? FaceKind::Fixed : FaceKind::Unknown);
}

// The solid–fluid faces (or walled domain faces) a jet blows through: within the jet's radius of
// its axis (at least 0.6 of the largest cell edge, so a nozzle narrower than a cell still finds
// the staircase), no more than two cells behind its exit point or one in front of it along the
// jet, and with the jet pointing from the face's solid side into its fluid side. Returns the
// faces as (axis, index) and adds up the flow they would carry at the jet's own speed.
std::vector<std::pair<int, std::size_t>> jet_faces(const GasGrid& g, const GasJetConfig& jet,
                                                   double& flow_m3_per_s) {
  const double h_max = std::max({g.h_m.x, g.h_m.y, g.h_m.z});
  const double reach = std::max(jet.radius_m, 0.6 * h_max);
  std::vector<std::pair<int, std::size_t>> faces;
  flow_m3_per_s = 0.0;
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      if (g.face[au][f] != FaceKind::Fixed) continue;
      const std::array<int, 3> ijk = g.coords(f);
      const std::size_t c0 = f, c1 = f + g.stride[au];
      const bool low = ijk[au] == 0, high = ijk[au] == g.n[au];
      const double into_fluid = low || (!high && g.fluid[c1] && !g.fluid[c0]) ? 1.0 : -1.0;
      if ((low || high) && g.ghost[low ? c0 : c1].kind != GasBoundaryKind::Wall) continue;
      if (jet.direction[a] * into_fluid <= 0.0) continue;
      Vec3 centre = g.cell_center(ijk[0], ijk[1], ijk[2]);
      centre[a] += 0.5 * g.h_m[a];
      const Vec3 d = centre - jet.exit_point_m;
      const double along = dot(d, jet.direction);
      if (along < -2.0 * h_max || along > h_max) continue;
      if (norm2(d - jet.direction * along) > reach * reach) continue;
      faces.push_back({a, f});
      flow_m3_per_s += g.face_area_m2(a) * std::abs(jet.direction[a]) * jet.speed_m_per_s;
    }
  }
  return faces;
}

// Spreads a jet's missing momentum flux (N) as a body force over the solved faces of the fluid
// cells it blows into; each face's control volume is one cell, so together they add exactly
// `deficit`. Returns the force density per face.
std::vector<ScaledFaceValue> jet_force(const GasGrid& g, std::vector<std::size_t> cells,
                                       const Vec3& deficit) {
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  std::vector<ScaledFaceValue> out;
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    std::vector<std::size_t> pushed;  // the solved a-faces of those cells, each once
    for (std::size_t c : cells)
      for (std::size_t f : {c - g.stride[au], c})
        if (g.face[au][f] == FaceKind::Unknown) pushed.push_back(f);
    std::sort(pushed.begin(), pushed.end());
    pushed.erase(std::unique(pushed.begin(), pushed.end()), pushed.end());
    if (pushed.empty()) continue;
    const double density = deficit[a] / (double(pushed.size()) * g.cell_volume_m3());
    for (std::size_t f : pushed) out.push_back({a, f, density});
  }
  return out;
}

// Turns each jet's faces into inflow faces: each holds the jet velocity's component along its
// axis, all scaled so together they carry exactly the jet's volume flow; the momentum flux the
// wider, slower inflow lacks becomes a body force (gas_grid.h). A scheduled jet is laid out at
// unit speed and its faces hold 0 until the solver applies its schedule.
void apply_jets(GasGrid& g, const GasConfig& config) {
  for (std::size_t j = 0; j < config.jets.size(); ++j) {
    GasJetConfig jet = config.jets[j];
    if (jet.schedule || jet.supply_pressure_pa) jet.speed_m_per_s = 1.0;
    double flow = 0.0;
    const std::vector<std::pair<int, std::size_t>> faces = jet_faces(g, jet, flow);
    g.jet_faces[j] = faces.size();
    if (faces.empty()) continue;
    const double scale = jet.volume_flow_m3_per_s() / flow;
    for (const auto& [a, f] : faces) {
      const bool into_high = jet.direction[a] > 0.0;
      g.jet_face_list[j].push_back(
          {a, f, into_high ? f + g.stride[std::size_t(a)] : f,
           g.face_area_m2(a) * std::abs(jet.direction[a]) * jet.speed_m_per_s / flow});
    }
    Vec3 entering;                   // momentum flux the faces carry in, per unit density
    std::vector<std::size_t> cells;  // the fluid cells the jet blows into
    ScheduledInflow scheduled;
    for (const auto& [a, f] : faces) {
      const double u = jet.speed_m_per_s * jet.direction[a] * scale;
      if (jet.schedule)
        scheduled.velocity.push_back({a, f, u});
      else
        g.fixed_value[std::size_t(a)][f] = u;
      entering[a] += g.face_area_m2(a) * std::abs(u) * u;
      cells.push_back(u > 0.0 ? f + g.stride[std::size_t(a)] : f);
    }
    const Vec3 deficit =
        (jet.direction * (jet.volume_flow_m3_per_s() * jet.speed_m_per_s) - entering) *
        config.density_kg_per_m3;
    std::vector<ScaledFaceValue> force = jet_force(g, std::move(cells), deficit);
    if (jet.schedule) {
      scheduled.schedule = *jet.schedule;
      scheduled.jet = int(j);
      scheduled.area_m2 = jet.volume_flow_m3_per_s();
      scheduled.force = std::move(force);
      scheduled.momentum_deficit_per_unit = deficit;
      g.scheduled_inflows.push_back(std::move(scheduled));
      continue;
    }
    g.jet_flow_m3_per_s[j] = flow * scale;
    g.jet_momentum_deficit_n[j] = deficit;
    for (const ScaledFaceValue& v : force)
      g.jet_force_n_per_m3[std::size_t(v.axis)][v.face] += v.per_unit;
  }
}

// Collects the boundary faces of each scheduled inlet patch (they hold 0 until the solver
// applies the schedule): velocity per unit speed is ±1 along the inward normal.
void collect_scheduled_patches(GasGrid& g, const GasConfig& config) {
  for (std::size_t k = 0; k < config.boundaries.size(); ++k) {
    const GasBoundaryPatch& p = config.boundaries[k];
    if (p.kind != GasBoundaryKind::Inlet || !p.schedule) continue;
    ScheduledInflow scheduled;
    scheduled.schedule = *p.schedule;
    scheduled.patch = int(k);
    const int a = p.face / 2;
    const std::size_t au = std::size_t(a);
    const bool high = p.face % 2 == 1;
    for (std::size_t f = 0; f < g.padded_size; ++f) {
      if (g.face[au][f] != FaceKind::Fixed) continue;
      const int along = g.coords(f)[au];
      if (along != (high ? g.n[au] : 0)) continue;
      if (g.ghost[high ? f + g.stride[au] : f].patch != int(k)) continue;
      scheduled.velocity.push_back({a, f, high ? -1.0 : 1.0});
      scheduled.area_m2 += g.face_area_m2(a);
    }
    g.scheduled_inflows.push_back(std::move(scheduled));
  }
}

}  // namespace

GasGrid build_gas_grid(const GasConfig& config, const Vec3& lo, const Vec3& hi,
                       const std::array<bool, 3>& periodic) {
  GasGrid g;
  g.n = config.cells;
  g.origin_m = lo;
  g.periodic = periodic;
  for (int a = 0; a < 3; ++a) g.h_m[a] = (hi[a] - lo[a]) / g.n[std::size_t(a)];
  g.stride = {1, std::size_t(g.n[0] + 2), std::size_t(g.n[0] + 2) * std::size_t(g.n[1] + 2)};
  g.padded_size = g.stride[2] * std::size_t(g.n[2] + 2);
  g.fluid.assign(g.padded_size, 0);
  g.ghost.assign(g.padded_size, {});
  for (int a = 0; a < 3; ++a) {
    g.face[std::size_t(a)].assign(g.padded_size, FaceKind::None);
    g.fixed_value[std::size_t(a)].assign(g.padded_size, 0.0);
  }
  g.patch_faces.assign(config.boundaries.size(), 0);
  g.patch_area_m2.assign(config.boundaries.size(), 0.0);
  g.jet_faces.assign(config.jets.size(), 0);
  g.jet_flow_m3_per_s.assign(config.jets.size(), 0.0);
  g.jet_face_list.assign(config.jets.size(), {});
  g.jet_momentum_deficit_n.assign(config.jets.size(), Vec3{});
  if (!config.jets.empty())
    for (int a = 0; a < 3; ++a) g.jet_force_n_per_m3[std::size_t(a)].assign(g.padded_size, 0.0);
  voxelise(g, config);
  assign_boundaries(g, config);
  for (int a = 0; a < 3; ++a)
    for (std::size_t f = 0; f < g.padded_size; ++f) classify_face(g, a, f);
  apply_jets(g, config);
  collect_scheduled_patches(g, config);
  return g;
}

}  // namespace millsim
