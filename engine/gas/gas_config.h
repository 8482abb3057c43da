// GasConfig: the scene's `gas` section as plain data (SI units). A scene without it builds no
// gas solver and no fluid fields. Parsed and validated by scene/gas_json.cpp; every key is
// documented in docs/gas.md and docs/scene-format.md.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/schedule.h"
#include "core/vec3.h"
#include "gas/compressible/ideal_gas.h"
#include "gas/pressure_solver.h"

namespace millsim {

// What a boundary face of the gas grid does (periodic axes come from the domain).
enum class GasBoundaryKind {
  Wall,    // no slip; the wall may move tangentially (`velocity_m_per_s`, e.g. a lid)
  Slip,    // zero normal velocity, zero shear
  Inlet,   // prescribed superficial velocity (nozzles, feed air, a distributor)
  Outlet,  // fixed pressure; the velocity leaves with zero gradient
};

// An inflow that changes during a run: the table gives the speed along the inflow's direction
// (m/s), or its mass flow (kg/s) through the faces it owns, turned into a speed at the grid's
// own area (so the discrete inflow carries exactly that mass).
struct InflowSchedule {
  Schedule table;
  bool mass_flow = false;
};

// Where on a domain face a boundary condition applies.
enum class PatchShape { WholeFace, Rectangle, Circle };

struct GasBoundaryPatch {
  std::string name;
  int face = 0;  // 0..5 = x-, x+, y-, y+, z-, z+
  GasBoundaryKind kind = GasBoundaryKind::Wall;
  PatchShape shape = PatchShape::WholeFace;
  Vec3 min_m, max_m;  // rectangle (the coordinate along the face normal is ignored)
  Vec3 center_m;      // circle
  double radius_m = 0.0;
  Vec3 velocity_m_per_s;     // inlet: superficial gas velocity; wall: wall velocity
  double pressure_pa = 0.0;  // outlet
  // Inlet only: the velocity along the inward normal follows this table instead (and
  // velocity_m_per_s is zero).
  std::optional<InflowSchedule> schedule;
  // Inlet of the compressible model only: fed from a reservoir at this stagnation pressure and
  // temperature instead of at a set velocity (the inflow speed follows from the pressure inside,
  // isentropically, up to Mach 1). Absent: a velocity inlet.
  std::optional<double> supply_pressure_pa;
  double supply_temperature_k = 293.15;
};

// Solid regions voxelised into the gas grid: a cell whose centre is inside is solid.
enum class GasSolidShape {
  Box,        // solid inside [min_m, max_m]
  Cylinder,   // axis through center_m along `axis`; solid outside the radius (a chamber) or inside
  HalfSpace,  // solid behind the plane through point_m (against the normal)
  TubeShell,  // a cylindrical shell: |distance from the axis − radius| < half_thickness_m over
              // the axial range [axial_min_m, axial_max_m] from center_m (an outlet tube)
};

struct GasSolidConfig {
  std::string name;
  GasSolidShape shape = GasSolidShape::Box;
  Vec3 min_m, max_m;              // box
  Vec3 center_m, axis;            // cylinder (axis normalised on load)
  double radius_m = 0.0;          // cylinder
  bool solid_inside = false;      // cylinder: true = a solid rod, false = a fluid chamber
  Vec3 point_m, normal;           // half-space (normal normalised on load)
  double half_thickness_m = 0.0;  // tube shell
  double axial_min_m = 0.0, axial_max_m = 0.0;  // tube shell, along the axis from center_m
};

// A gas jet entering through a voxelised solid wall (a mill's nozzle): the solid–fluid faces the
// jet's cross-section covers near its exit carry the jet velocity's component along them, scaled
// so that the faces together carry exactly π r² · speed (gas/gas_grid.cpp).
struct GasJetConfig {
  std::string name;
  Vec3 exit_point_m;  // on the wall
  Vec3 direction;     // unit, into the fluid
  double radius_m = 0.0;
  double speed_m_per_s = 0.0;
  std::optional<InflowSchedule> schedule;  // the speed follows this table instead
  // The compressible model: the stagnation temperature of the gas the jet brings (both kinds of
  // jet), and, instead of a speed, the nozzle's supply (stagnation) pressure, absolute. A
  // pressure-set jet delivers the isentropic mass flow of a throat of radius_m (choked when the
  // chamber is below the critical pressure ratio) as a notional nozzle: gas/compressible/jet.h.
  std::optional<double> supply_pressure_pa;
  double supply_temperature_k = 293.15;
  double volume_flow_m3_per_s() const {
    return 3.141592653589793 * radius_m * radius_m * speed_m_per_s;
  }
};

// A pressure difference written as a time series (result.json, run.h5): the mean pressure of
// one plane minus that of another. An end is a boundary patch (its faces' pressure: gas/
// pressure_probe.h) or a plane normal to an axis between the first and last cell centres.
struct PressurePlane {
  int patch = -1;  // index into GasConfig::boundaries, or -1 for a plane
  int axis = 2;
  double at_m = 0.0;
};
struct PressureDropConfig {
  std::string name;
  PressurePlane from, to;  // drop = p(from) − p(to)
};

// Drag laws (gas/drag.h gives each formula and its source).
enum class DragLaw { SchillerNaumann, DiFelice, Gidaspow, KochHill, Beetstra };

// What a particle keeps between drag evaluations (§3.1, Fig. 5).
enum class DragCacheStore {
  Coefficient,  // β = |F| / |u − v|: the force follows the current slip (default)
  Force,        // the force itself, as in the paper's Fig. 5
};

enum class AdvectionScheme {
  Central,  // second order; stable only while the cell Péclet number |u| h / ν < 2
  Upwind,   // first order, always stable under the CFL limit
  Hybrid,   // central where the cell Péclet number < 2, upwind elsewhere (default)
  Tvd,      // central where the cell Péclet number < 2, elsewhere upwind-biased second order
            // with van Leer's limiter (TVD under the explicit step's CFL limit): far less
            // numerical viscosity than first-order upwind, e.g. in a jet mill's vortex
};

// Which equations the gas solves (docs/gas.md).
enum class GasModel {
  Incompressible,  // constant density, Chorin projection on the staggered grid (gas_solver.h)
  Compressible,    // ideal gas with an energy equation, finite volumes with a central-upwind
                   // flux (gas/compressible/compressible_solver.h)
};

// The compressible model's thermodynamics and initial state.
struct CompressibleGasConfig {
  IdealGas gas;
  double initial_pressure_pa = 101325.0;
  double initial_temperature_k = 293.15;
};

struct GasConfig {
  GasModel model = GasModel::Incompressible;
  CompressibleGasConfig compressible;  // read only by the compressible model
  double density_kg_per_m3 = 1.2;
  double viscosity_pa_s = 1.8e-5;
  std::array<int, 3> cells{1, 1, 1};  // grid cells along x, y, z over the domain box
  Vec3 initial_velocity_m_per_s;
  // The gas alone is solved this long before the particles start (time 0), so a run begins from
  // the developed flow, as CFD–DEM studies of jet mills do (a spiral jet mill's vortex takes
  // milliseconds to spin up).
  double spin_up_s = 0.0;
  // An imposed mean pressure gradient along periodic axes (drives a periodic channel or pipe).
  // Along a periodic axis gravity is balanced by its hydrostatic gradient on top of this.
  Vec3 mean_pressure_gradient_pa_per_m;
  std::optional<double> step_s;  // fixed CFD step (rounded to whole DEM steps); absent = CFL
  double courant = 0.5;          // CFD step <= courant / (Σ|u|/h + 2ν Σ 1/h²)
  double drag_courant = 20.0;  // CFD step <= drag_courant · ε ρ / B (B: particle drag per volume)
  AdvectionScheme advection = AdvectionScheme::Hybrid;
  // Smagorinsky eddy viscosity ν_t = (C_s Δ)² |S| added to ν; 0 = off (typical C_s 0.1–0.2).
  double smagorinsky_constant = 0.0;
  std::vector<GasBoundaryPatch> boundaries;  // applied in order over the default (wall)
  std::vector<GasSolidConfig> solids;
  std::vector<GasJetConfig> jets;  // inflow through solid walls (a mill's nozzles)
  std::vector<PressureDropConfig> pressure_drops;
  // coupling
  bool two_way = true;  // particles push on the gas; false = the gas ignores them
  DragLaw drag = DragLaw::SchillerNaumann;
  double cache_threshold = 0.05;  // recompute drag when the slip changed more (0 = always)
  DragCacheStore cache_store = DragCacheStore::Coefficient;
  bool pressure_gradient_force = true;  // −V_p ∇p (gives buoyancy in a hydrostatic gas)
  bool saffman_lift = false;
  // Cunningham's slip correction of the drag (gas/drag.h) from the local mean free path: the
  // compressible model only (the incompressible one has no absolute pressure); its default there.
  bool slip_correction = false;
  // Loth's (2008) Mach correction of the drag (gas/mach_drag.h) from the slip Mach number: the
  // compressible model only (the incompressible one has no sound speed); its default there.
  bool mach_correction = false;
  double min_volume_fraction = 0.2;  // gas volume fraction floor (a random packing is ≈ 0.36–0.45)
  // pressure solve
  double pressure_tolerance = 1e-6;  // relative residual of the conjugate-gradient solve
  int max_pressure_iterations = 5000;
  PressurePreconditioner pressure_preconditioner = PressurePreconditioner::Multigrid;
};

}  // namespace millsim
