// DustLedger: the mass below the dust threshold as a dilute phase on the gas grid (issue 31),
// in place of a global table. Each breakage puts its sub-threshold mass, by size class, into the
// gas cell where it broke; each class rides the gas with the equilibrium-Eulerian velocity of a
// small-Stokes-number particle (Ferry & Balachandar, Int. J. Multiphase Flow 27 (2001) 1199), in
// its locally implicit form (Ferry, Rani & Balachandar, Int. J. Multiphase Flow 29 (2003) 869):
//
//   u_dust = u_gas + w,   (I + τ_k ∇u_gas) w = τ_k (g − Du_gas/Dt),   τ_k = ρ_p d_k² C / (18 μ)
//
// (C: Cunningham's factor, 1 unless given), so a vortex drives dust outwards at τ_k u_t²/r
// while τ_k Ω ≪ 1. Where τ_k |∇u| is not small the expansion fails and neither form is bounded
// (the plain τ_k (g − Du/Dt) grows with τ_k; the implicit one too where I + τ_k ∇u is near
// singular or the flow shears): the mill's 45 µm dust was given 130 km/s. So the slip is held
// to |w| <= |u_gas| + U_max + τ_k |g|, U_max the fastest gas in a fluid cell at the advance: a
// particle under Stokes drag never moves faster than U_max + τ_k |g| (its velocity is a weighted
// mean of the gas velocities it met, plus what gravity added), so its slip from the gas where it
// is never exceeds that bound. A longer w keeps its direction. Finite volumes, upwind with van
// Leer's limited slope and Heun's method (SSP-RK2), sub-stepped at an outgoing Courant sum of 0.5:
// every flux is taken from one cell and given to its neighbour, so the mass is conserved to
// rounding, and no cell gives more than it holds. Walls, inlets and solid cells pass no dust; an
// outflow face passes what the face flux carries out (never in), into the class's outflow tally.
// The ledger only carries the dust; the compressible gas takes its mass per volume
// (density_kg_per_m3) as inertia it must accelerate, when the scene couples them two ways
// (gas/compressible/compressible_solver.h, "dust"; docs/dust.md). The classes are carried on the
// engine's threads, each by one thread into its own arrays, so the result is the same on any thread
// count.
//
// Valid while τ_k |∇u| is small (the expansion is in the Stokes number): the run records the
// largest slip speed it gave each class, to set against the gas speeds, and how often the
// bound acted on it.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/vec3.h"
#include "gas/gas_config.h"
#include "gas/gas_grid.h"
#include "gas/gas_view.h"

namespace millsim {

struct DustClass {
  double diameter_m = 0.0;
  double relaxation_time_s = 0.0;  // τ_k
};

// The ledger's classes from the run's PSD edges (those of the dust table): class 0 holds what
// lies below the first edge (represented one bin width below it), class k ≥ 1 the bin
// [edges[k−1], edges[k]) up to the one holding the threshold, at its geometric centre (capped at
// the threshold). τ = ρ_p d² C / (18 μ), C Cunningham's factor at the mean free path given (1
// when it is 0).
std::vector<DustClass> dust_classes(const std::vector<double>& edges_m, double threshold_m,
                                    double particle_density_kg_per_m3, double viscosity_pa_s,
                                    double mean_free_path_m);
// The mean free path the classes' Cunningham factor is taken at: the compressible chamber's
// initial state when the gas has `slip_correction` on, else 0 (no correction).
double dust_mean_free_path_m(const GasConfig& gas);
// The class of a dust diameter (the last class for anything at or above its lower edge).
int dust_class_of(const std::vector<double>& edges_m, int class_count, double diameter_m);

struct DustLedgerStats {
  std::uint64_t advances = 0, substeps = 0;
  std::uint64_t deposits = 0, displaced_deposits = 0;  // displaced: put in the nearest fluid cell
  std::vector<double> max_slip_m_per_s;  // per class: the largest slip w in a fluid cell
  // Per class: the (fluid cell, advance) pairs where the bound shortened the slip.
  std::vector<std::uint64_t> speed_bounded_cells;
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, advances, substeps, deposits, displaced_deposits, max_slip_m_per_s,
           speed_bounded_cells);
  }
};

// How the flux passes walk the faces: an axis without periodic wrap as rows of the padded grid
// (the passes' own layout), or every face from a list (what the rows replaced: kept as the
// reference they are tested against, bit for bit).
enum class DustFaceLayout { Rows, Listed };

class DustLedger {
 public:
  DustLedger(const GasGrid& grid, std::vector<DustClass> classes, const Vec3& gravity_m_per_s2,
             DustFaceLayout layout = DustFaceLayout::Rows);

  int class_count() const { return int(classes_.size()); }
  const std::vector<DustClass>& classes() const { return classes_; }

  // Adds `mass_kg` of class k to the fluid cell containing x (the nearest fluid cell by centre
  // distance when x lies in a solid one; a point outside the grid is clamped into it).
  void deposit(const Vec3& x, int k, double mass_kg);

  // Carries every class over dt_s with the gas as it is now. Du/Dt is the gas velocity's
  // change since the last call over the time between, plus (u·∇)u by central differences.
  void advance(const GasView& gas, double dt_s);

  // Mass of class k held in the grid, and what left through outflow faces so far.
  double held_kg(int k) const;
  double held_kg() const;
  double outflow_kg(int k) const { return outflow_kg_[std::size_t(k)]; }
  double outflow_kg() const;
  // Class k's mass per padded gas cell (kg).
  const std::vector<double>& cell_mass_kg(int k) const { return mass_[std::size_t(k)]; }
  // All classes' mass per unit volume, kg/m³ per padded cell (0 where there is none), summed in
  // class order: the dust the compressible gas carries as its own inertia when two-way coupled.
  void density_kg_per_m3(std::vector<double>& out) const;
  const GasGrid& grid() const { return *grid_; }
  const DustLedgerStats& stats() const { return stats_; }
  // The slip w of a class of relaxation time τ in fluid cell c, from the gas as of the last
  // advance, speed bound included.
  Vec3 slip_m_per_s(std::size_t c, double tau) const;
  // The fastest gas speed in a fluid cell as of the last advance (U_max of the slip bound).
  double max_gas_speed_m_per_s() const { return max_gas_speed_m_per_s_; }
  // The time the ledger may go before its next carry: `courant` over the largest outgoing rate
  // (1/s: Σ over a cell's faces of the speed out of it over the cell's size) any class had in any
  // fluid cell at the last advance, so that over it no class's Courant sum passes `courant` while
  // the gas stays as it was then. 0 before the first advance and where nothing moved.
  double carry_interval_s(double courant) const {
    return fastest_rate_per_s_ > 0.0 ? courant / fastest_rate_per_s_ : 0.0;
  }
  // The fluid cells the last advance saw (the denominator of speed_bounded_cells per advance).
  std::size_t fluid_cell_count() const { return fluid_cells_.size(); }
  // The padded cell x lies in (clamped into the grid; it may be a solid one).
  std::size_t cell_of(const Vec3& x) const { return containing_cell(x); }
  // The gas velocity in fluid cell c as of the last advance.
  const Vec3& gas_velocity_m_per_s(std::size_t c) const { return velocity_[c]; }
  // Moves `kg` of class k's mass in cell c to the classes j by shares[j] (Σ = 1): grinding.
  void move_between_classes(std::size_t c, int k, double kg, const std::vector<double>& shares);
  // Multiplies class k's mass in every cell by `factor` >= 1 (a hold-up fill, process/
  // holdup_fill.h): the class keeps where it is, only more of it. Returns the mass added, which
  // filled_kg() keeps, so that held + out = made + filled stays exact.
  double scale_class(int k, double factor);
  double filled_kg() const { return filled_kg_; }

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, mass_, outflow_kg_, unplaced_kg_, previous_velocity_, previous_time_s_,
           have_previous_, stats_, filled_kg_, fastest_rate_per_s_);
  }

 private:
  struct Face {
    std::size_t face;          // its index in the grid's component `axis`
    std::size_t low, high;     // the cells on either side (canonical; ghost when not fluid)
    std::size_t below, above;  // the fluid cells beyond low and high (padded_size: none)
    int axis;
    bool outflow_low, outflow_high;  // an outflow face with only that side fluid
  };
  void build_faces(DustFaceLayout layout);
  std::size_t containing_cell(const Vec3& x) const;  // the interior cell x lies in (clamped)
  std::size_t nearest_fluid_cell(const Vec3& x) const;
  // Per fluid cell, the gas's acceleration term a = g − Du/Dt and its velocity gradient G = ∇u
  // reduced to what the slip of any class needs (slip_of).
  struct SlipTerms {
    Vec3 a, ga, gga;                                          // a, G a, G² a
    double trace = 0.0, minors = 0.0, det = 0.0, norm = 0.0;  // of G (norm: Frobenius)
    double slip_bound = 0.0;  // |u| + U_max: the slip's bound less τ|g|
  };
  static SlipTerms slip_terms(const Vec3& acceleration, const std::array<Vec3, 3>& gradient);
  static Vec3 slip_of(const SlipTerms& terms, double tau);
  // Cell slot's slip for τ, shortened to |u| + U_max + τ|g| when it is longer (its direction
  // kept; `bounded` set): what carry_class and slip_m_per_s use.
  Vec3 bounded_slip(std::size_t slot, double tau, bool& bounded) const;
  void update_acceleration(const GasView& gas, double now_s);
  // A face as the flux passes read it: its cells and those beyond (padded_size: none).
  struct PassFace {
    std::uint32_t low, high, below, above;
  };
  // The faces normal to an axis without periodic wrap, as rows of the padded grid: face c joins
  // cells c and c + stride, and the limited slope reads c − stride or c + 2 stride, so the passes
  // run over contiguous arrays with no index per face and no branch on the flow's direction. A
  // row face that is not interior carries nothing (its rate is 0). Periodic axes keep their faces
  // listed (a face across the wrap joins cells that are not a stride apart).
  struct RowAxis {
    bool on = false;
    std::size_t stride = 0, begin = 0, end = 0;  // its faces c lie in [begin, end)
    std::vector<std::uint8_t> interior;          // per padded cell c: face c joins two fluid cells
    // Per padded cell c: the cell beyond face c's upwind side is fluid, for flow along + (c −
    // stride) and along − (c + 2 stride): where it is not, the face takes its upwind cell's mass.
    std::vector<std::uint8_t> slope_plus, slope_minus;
    std::vector<double>
        gas_speed;  // per padded cell c: the gas's speed through face c, this advance
  };
  // A class's work arrays while it is carried: each thread's own, overwritten before read.
  struct ClassScratch {
    std::array<std::vector<double>, 3> slip;  // per component, per padded cell (fluid ones written)
    std::vector<double> face_rate;      // per listed face: (the gas's speed + the class's slip) / h
    std::vector<double> outgoing_rate;  // per padded cell
    std::vector<double> start, stage;   // the mass at the step's start and after its first stage
    std::vector<double> transfer;       // per listed face: the mass a pass moves from low to high
    std::array<std::vector<double>, 3> row_rate, row_transfer;  // per row axis, per padded cell
  };
  void carry_class(std::size_t k, double dt_s, ClassScratch& scratch);
  // One forward-Euler pass of the class's rates over dt_s from `from` into `to` (which holds
  // `from` on entry); returns the mass that left through outflow faces.
  double flux_pass(ClassScratch& scratch, const std::vector<double>& from, std::vector<double>& to,
                   double dt_s) const;
  void row_transfers(const RowAxis& row, const std::vector<double>& rate,
                     std::vector<double>& transfer, const std::vector<double>& from,
                     double dt_s) const;
  static void mean_into(const std::vector<double>& start, std::vector<double>& m);
  void apply_row(const RowAxis& row, const std::vector<double>& transfer,
                 std::vector<double>& to) const;
  void listed_transfers(std::size_t begin, std::size_t end, const std::vector<double>& face_rate,
                        std::vector<double>& transfer, const std::vector<double>& from,
                        double dt_s) const;
  static constexpr std::uint32_t kNoSlot = 0xffffffffu;

  const GasGrid* grid_;
  std::vector<DustClass> classes_;
  Vec3 gravity_m_per_s2_;
  // The listed faces: the interior faces of periodic axes, axis by axis, then the outflow faces.
  std::vector<Face> faces_;
  std::vector<PassFace> pass_faces_;  // faces_ as the passes read them
  std::size_t interior_faces_ = 0;    // faces_ and pass_faces_: these first, then outflow faces
  std::array<std::size_t, 3> listed_begin_{}, listed_end_{};  // per axis: its interior faces_
  std::array<RowAxis, 3> rows_;                               // the axes without periodic wrap
  std::vector<std::vector<double>> mass_;                     // per class, per padded cell
  std::vector<double> outflow_kg_;
  std::vector<Vec3> velocity_, previous_velocity_;  // per padded cell
  std::vector<SlipTerms> slip_terms_;               // per fluid cell, as of the last advance
  std::vector<std::uint32_t> fluid_slot_;           // per padded cell: its fluid cell's (kNoSlot)
  double previous_time_s_ = 0.0;
  double max_gas_speed_m_per_s_ = 0.0;  // over the fluid cells, as of the last advance
  bool have_previous_ = false;
  double filled_kg_ = 0.0;    // added by scale_class
  double unplaced_kg_ = 0.0;  // deposits on a grid without fluid cells (held, never moved)
  std::vector<std::size_t> fluid_cells_;       // the padded indices of the fluid cells, ascending
  std::vector<double> gas_face_speed_;         // per face, this advance
  std::vector<std::uint64_t> class_substeps_;  // per class, this advance
  std::vector<double> class_fastest_rate_;     // per class, this advance: its largest outgoing rate
  double fastest_rate_per_s_ = 0.0;            // over the classes, as of the last advance
  DustLedgerStats stats_;
};

}  // namespace millsim
