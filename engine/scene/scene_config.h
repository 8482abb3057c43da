// SceneConfig: everything a run needs, as plain structs with SI units and defaults.
// Filled from scene JSON by load_scene() (scene_json.cpp), which also validates every field;
// docs/scene-format.md documents each key. Optional modules are std::optional: an absent
// section builds nothing (DESIGN.md, "leave out what a scene does not need").
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "gas/gas_config.h"
#include "geometry/mill_config.h"

namespace millsim {

// Comminution functions of a breakable material (docs/comminution.md cites each source).
enum class StrengthModel {
  VogelPeukert,  // P = 1 − exp(−f_mat x k (W − W_min)), x W_min constant (Vogel & Peukert 2003)
  Weibull,       // P = 1 − exp(−ln 2 (W / W50(x))^m), W50 ∝ (x / x_ref)^(−φ)
};

struct StrengthConfig {
  StrengthModel model = StrengthModel::VogelPeukert;
  double f_mat_kg_per_j_m = 0.0;        // Vogel–Peukert f_mat
  double x_w_min_j_m_per_kg = 0.0;      // Vogel–Peukert x·W_m,min
  double median_energy_j_per_kg = 0.0;  // Weibull W50 at the reference diameter
  double reference_diameter_m = 1e-4;   // Weibull x_ref
  double size_exponent = 0.0;           // Weibull φ: W50 = median (x / x_ref)^(−φ)
  double weibull_modulus = 3.0;         // Weibull m
};

// Breakage function: the fragment sizes of one broken particle, as ratios to its diameter.
enum class FragmentModel {
  PowerLaw,           // mass-cumulative B(r) ∝ r^q on [r_min, r_max] (Gates–Gaudin–Schuhmann)
  BroadbentCallcott,  // B(r) ∝ 1 − exp(−r) on [r_min, r_max] (Broadbent & Callcott 1956)
  AustinLuckie,       // B(r) ∝ φ r^γ + (1 − φ) r^β (Austin & Luckie 1972)
  VogelPeukert,       // B(r, y) = ½ r^q [1 + tanh((y − y′)/y′)] (Vogel & Peukert 2003)
  Equal,              // n equal fragments of diameter n^(−1/3)
};

struct FragmentConfig {
  FragmentModel model = FragmentModel::PowerLaw;
  double exponent = 1.0;             // power law, Vogel–Peukert: q
  double fine_fraction = 0.5;        // Austin–Luckie φ
  double fine_exponent = 1.0;        // Austin–Luckie γ
  double coarse_exponent = 3.0;      // Austin–Luckie β
  double chipping_diameter_m = 0.0;  // Vogel–Peukert y′
  double min_ratio = 0.05;           // r_min: smallest fragment / parent diameter (0 allowed)
  double max_ratio = 0.7;            // r_max: largest fragment / parent diameter (< 1)
  int count = 8;                     // equal: fragments per breakage
  int max_fragments = 5000;  // per breakage event; the rest of the volume is one last fragment
};

struct MaterialBreakageConfig {
  StrengthConfig strength;
  bool fatigue = true;          // sub-critical impacts lower the remaining strength
  double fatigue_factor = 1.0;  // damage per J/kg of sub-critical excess energy (1 = Vogel–Peukert)
  FragmentConfig fragments;
};

struct MaterialConfig {
  std::string name;
  double youngs_modulus_pa = 0.0;  // E
  double poisson_ratio = 0.0;      // ν
  double density_kg_per_m3 = 0.0;  // ρ
  double restitution = 1.0;        // e, normal coefficient of restitution, [0, 1]
  double friction = 0.0;           // μ, Coulomb sliding friction
  double rolling_friction = 0.0;   // μ_r, constant-torque rolling resistance; 0 = off
  bool frozen = false;  // its particles never move (a fixed bed, a target); they still collide
  std::optional<MaterialBreakageConfig> breakage;  // absent = unbreakable
};

// An infinite plane; particles live on the side the normal points to.
// An extra wall: an infinite plane (particles on the side its normal points to) or the inside of
// an infinite circular cylinder (a pipe or a column; particles inside).
enum class WallShape { Plane, Cylinder };
struct WallConfig {
  std::string name;
  WallShape shape = WallShape::Plane;
  Vec3 point_m;           // plane: a point on it; cylinder: a point on its axis
  Vec3 normal;            // plane: its normal; cylinder: its axis (normalised on load)
  double radius_m = 0.0;  // cylinder only
  int material = 0;
  std::optional<double> restitution;  // particle–wall e; default: the particle's material
  std::optional<double> friction;     // particle–wall μ; default: the particle's material
};

struct DomainConfig {
  Vec3 min_m, max_m;
  std::array<bool, 3> periodic{false, false, false};
  // Box faces on non-periodic axes are walls made of this material.
  int wall_material = 0;
  std::optional<double> wall_restitution;
  std::optional<double> wall_friction;
};

struct ParticleSpec {
  Vec3 position_m;
  Vec3 velocity_m_per_s;
  Vec3 angular_velocity_rad_per_s;
  double diameter_m = 0.0;
};

enum class SizeDistributionKind { Fixed, Uniform, LogNormal, PowerLaw };

struct SizeDistribution {
  SizeDistributionKind kind = SizeDistributionKind::Fixed;
  double diameter_m = 0.0;     // fixed
  double min_m = 0.0;          // uniform, power_law; lower truncation for log_normal
  double max_m = 0.0;          // uniform, power_law; upper truncation for log_normal
  double median_m = 0.0;       // log_normal
  double geometric_std = 1.0;  // log_normal, σ_g >= 1
  double exponent = -2.5;      // power_law: number density n(d) ∝ d^exponent
};

enum class SourceKind { List, File, Random };

struct SourceConfig {
  SourceKind kind = SourceKind::List;
  int material = 0;
  // list
  std::vector<ParticleSpec> particles;
  // file (shared/bench/FORMAT.md); a relative path is relative to the scene file
  std::filesystem::path file_path;
  // random: non-overlapping random sequential placement inside a region
  std::int64_t count = 0;
  Vec3 region_min_m, region_max_m;
  SizeDistribution sizes;
  Vec3 velocity_m_per_s;
  double velocity_spread_m_per_s = 0.0;  // std. dev. of each component, Gaussian
};

// How many hold-up fills a run may list (time.fill_to_projection_s).
inline constexpr std::size_t kMaxHoldupFills = 16;

struct TimeConfig {
  double end_s = 0.0;
  std::optional<double> step_s;   // fixed step; absent = automatic
  double safety_factor = 0.2;     // automatic step <= factor × smallest Rayleigh time
  double steps_per_contact = 20;  // automatic step <= shortest Hertz contact time / this
  // Particles in free flight (nothing in their neighbour list) take a long step of their own
  // (sim/multi_rate.h) instead of every contact step.
  bool multi_rate = false;
  // With multi_rate: particles whose only candidates are walls step at the step their own size
  // and stiffness allow, in powers of two of the run's step (sim/multi_rate.h).
  bool wall_riders = false;
  // A mill's hold-up filled, at each of these times (increasing), to the steady state the run
  // projects from the last third of the span since the fill before (process/holdup_fill.h,
  // Simulation::fill_holdup); empty: no fill.
  std::vector<double> fill_to_projection_s;
  // How far each fill moves a class towards its projected hold-up: to held^(1−ω) target^ω
  // (geometric, so that a class projected at 50 times its hold-up moves 7 times at ω = ½); 1:
  // all the way. Fills repeated with ω < 1 iterate the hold-up towards the one the mill's own
  // rates reproduce, each projected from a mill nearer to it. One per fill (the scene gives one
  // for all or a list).
  std::vector<double> fill_relaxation;
  // Whether a fill also takes mass from the classes above their target (particles drawn at
  // random from the class, the ledger's dust scaled down); false: it only adds.
  bool fill_removes = false;
  // A particle class whose window saw fewer breakage events and particles leave than this is
  // held at its hold-up (its rates from a handful of counts are not a projection) and passes
  // mass on at its measured rates.
  int fill_min_events = 0;
  // Over how many fills' windows each fill fits the particle classes' rates: K pools the span
  // from the window start of the fill K − 1 before it (or the first fill's) to it; 1: its own
  // window alone. A class's breakage by wall impacts and its outflow are first order whatever the
  // hold-up, so every kilogram-second it was held counts, where a window of a few milliseconds
  // counts a handful of events a class; a class whose rate drifts as the mill fills wants a
  // recent span. The dust's rates, which follow the gas and the particles it meets, stay those of
  // the fill's own window.
  int fill_particle_rate_windows = 1;
  // Fills declared at or after this time move the ledger's dust alone: every particle class is
  // held, in the projection at its mean over the fill's window (passing mass on at its measured
  // rates) and in the fill at its hold-up, so the dust is projected for the particles the mill
  // holds. The particles settle within a few fills while the dust's rates, fitted from one
  // fill's window, can lag the mill the fill made (bench/RESULTS.md, steadyF); a last fill of the
  // dust alone moves it without moving them again. Unset: every fill moves both.
  std::optional<double> fill_dust_only_from_s;
  // In a fill of the dust alone, each dust class's exit rate follows the dust hold-up as a power
  // fitted from the fill's window and the one before it, and the dust is projected at the hold-up
  // its own rates give (process/dust_exit_load.h); false: at the window's rates. Off unless set:
  // on `steadyJ` its per-class fit over two windows 8 % apart in dust read most classes' rates as
  // falling with the dust and projected 7.9 mg where 3.2-3.5 mg was near steady (bench/RESULTS.md).
  bool fill_dust_exit_follows_load = false;
};

enum class ContactModel {
  SeriesSprings,         // per-particle springs, §3.2; tangential in series (contact_law.h)
  PaperSprings,          // per-particle springs exactly as Eq. 2–3: tangential in parallel
  EquivalentProperties,  // Eq. 1
};

// How the damping ratio α follows from the restitution e (particles/materials.h).
enum class DampingModel {
  Restitution,  // α calibrated so a clipped Hertz impact rebounds with exactly e (default)
  Paper,        // α = 2γ(e), γ = −ln e/√(π² + ln² e): the damping Eq. 13 was fitted for
};

// Reduced stiffness for the finest particles (§4, Eq. 6–7).
struct ReducedStiffnessConfig {
  std::optional<double> threshold_diameter_m;  // absent = automatic from the penetration limit
};

struct ContactConfig {
  ContactModel model = ContactModel::SeriesSprings;  // §3.2, Eq. 2–3; or Eq. 1
  DampingModel damping = DampingModel::Restitution;
  // Expected largest normal impact speed; absent = derived from the initial state (time_step.h).
  std::optional<double> max_impact_speed_m_per_s;
  double penetration_limit = 0.15;  // allowed overlap / diameter of the smaller partner (§4)
  bool penetration_limiter = true;  // Eq. 8: reverse the normal velocity (×e) past the limit
  std::optional<ReducedStiffnessConfig> reduced_stiffness;  // absent = off
};

struct SearchConfig {
  bool conventional_nbs = false;         // "nbs": the dense Munjiza–Andrews baseline, no sub-grid
  std::optional<double> skin_m;          // Verlet skin; absent = automatic
  std::optional<double> cell_size_m;     // lower bound on the DEM-cell edge; absent = automatic
  std::optional<int> subcells_per_axis;  // sub-grid division k (§2.2); absent = automatic
  // Grid levels of edge C0/k^l; absent = automatic, or the paper's 2 when k is given.
  std::optional<int> grid_levels;
  // Measure the list's motion in a frame turning with the particles where the walls allow it
  // (search/neighbor_list.h, NeighborSettings::rotating_frame).
  bool rotating_frame = true;
  // The fastest particles get a larger share of the skin (NeighborSettings::skin_by_speed).
  bool skin_by_speed = true;
};

// How a particle–particle impact maps onto the single-particle (wall) impact the strength
// functions were measured with (docs/comminution.md).
enum class ImpactEquivalence {
  Energy,  // each partner's speed in the pair's centre-of-mass frame
  Force,   // the rigid-wall impact speed giving the same peak Hertz force
};

struct BreakageConfig {
  ImpactEquivalence equivalence = ImpactEquivalence::Energy;
  int placement_attempts = 16;  // random positions tried per fragment (least overlap kept)
};

// Fragments smaller than the threshold are never simulated: they go to the dust (§5). The
// table holds it as one global tally, the product at once (the paper's "dust exits the mill
// immediately"); the ledger puts it in the gas cell where it was made and carries it with the gas
// until it leaves through an outlet (dust/dust_ledger.h; needs a gas section).
enum class DustModel { Table, Ledger };
struct DustConfig {
  double threshold_diameter_m = 0.0;
  DustModel model = DustModel::Table;
  bool grinding = false;  // "sweep": the ledger's dust is ground by the particles (dust_grinding.h)
  // The ledger's dust as mass the compressible gas accelerates (gas/compressible/
  // compressible_solver.h, "dust"); false: carried by the gas, never acting on it. Absent from the
  // scene: on with the compressible gas, off with the incompressible one (which has only that).
  std::optional<bool> two_way;
  // The ledger is carried at its own step, not the gas's acoustic one: at the last CFD step before
  // the time since its last carry would pass carry_courant over the largest outgoing rate of any
  // class at that carry (DustLedger::carry_interval_s). 0: at every CFD step.
  double carry_courant = 0.5;
};

// Size classes of the outlet PSD: explicit edges, or `bins` log-spaced edges on [min, max].
struct PsdConfig {
  std::vector<double> edges_m;  // ascending; empty = automatic from the scene's sizes
  // The product counts what leaves in [start, end) s of the run: outlet particles, and the dust
  // that leaves the ledger's gas outlets or (the table) is made then. Absent: the whole run.
  std::optional<std::array<double, 2>> product_window_s;
};

enum class OutletKind { Plane, Box, Cylinder };

// Particles whose centre crosses an outlet leave the run and are binned into the outlet PSD.
struct OutletConfig {
  std::string name;
  OutletKind kind = OutletKind::Plane;
  Vec3 point_m, normal;   // plane: removes centres behind the plane (against the normal)
                          // cylinder: a point of the axis and its unit direction
  Vec3 min_m, max_m;      // box: removes centres inside
  double radius_m = 0.0;  // cylinder: removes centres inside the radius
  double axial_min_m = 0.0, axial_max_m = 0.0;  // cylinder: over this range along the axis
};

// Inserts particles at a mass rate into a region, so a mill runs in steady state.
struct FeedConfig {
  std::string name;
  int material = 0;
  Vec3 region_min_m, region_max_m;
  SizeDistribution sizes;
  double mass_rate_kg_per_s = 0.0;
  Vec3 velocity_m_per_s;
  double velocity_spread_m_per_s = 0.0;
  double start_s = 0.0;
  double end_s = 1e300;
};

struct OutputConfig {
  std::optional<double> snapshot_interval_s;    // absent = end/10
  std::optional<double> timeseries_interval_s;  // absent = end/200
  std::optional<double> checkpoint_interval_s;  // simulated time; absent = by wall clock only
  bool write_h5 = true;
  // The impact-energy spectrum (process/impact_spectrum.h); absent: on when particles break.
  std::optional<bool> impact_spectrum;
};

struct SceneConfig {
  std::string name;
  std::string description;
  std::uint64_t seed = 1;
  DomainConfig domain;
  std::vector<WallConfig> walls;
  std::vector<MaterialConfig> materials;
  std::vector<SourceConfig> sources;
  Vec3 gravity_m_per_s2;
  TimeConfig time;
  ContactConfig contact;
  SearchConfig search;
  OutputConfig output;
  std::optional<BreakageConfig> breakage;  // present when any material is breakable
  std::optional<DustConfig> dust;
  PsdConfig psd;
  std::vector<OutletConfig> outlets;
  std::vector<FeedConfig> feeds;
  std::optional<GasConfig> gas;    // absent = no gas solver, no fluid fields
  std::optional<MillConfig> mill;  // a cylindrical grinding chamber (geometry/mill.h)
  std::filesystem::path base_dir;  // directory of the scene file, for relative paths
  // Where file sources may lead (not a scene key: `millsim run --files-root`, which a service's
  // worker passes); empty: anywhere. Decided when each file is opened (io/input_file.h).
  std::filesystem::path files_root;
};

}  // namespace millsim
