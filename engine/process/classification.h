// Classification in a mill: which sizes left through the outlet and which stayed, and the cut
// size a spiral jet mill's vortex should give.
//
//   Grade efficiency T(x): for each size class, the share of the mass that left through the
//   outlet among the mass that left plus the hold-up still in the mill at the end (dust is left
//   out: it leaves at once by assumption, §5, and is not classified). The simulated cut size is
//   where T falls through 1/2, interpolated in log x between class centres.
//
//   Force balance (MacDonald et al., Powder Technol. 299 (2016) 26, after Rumpf): at the outlet
//   radius r a particle of size x circles with the gas's tangential speed u_t and is held where
//   the centrifugal force balances Stokes drag of the inward radial flow u_r:
//       (ρ_p − ρ_g) (π/6) x³ u_t² / r = 3π μ x |u_r|   →   x_c = √(18 μ |u_r| r / ((ρ_p − ρ_g)
//       u_t²))
//   u_t and u_r are the simulated gas's, averaged round the cylinder r over the height from the
//   floor to the outlet tube's mouth (sample_vortex).
#pragma once

#include <optional>
#include <vector>

#include "gas/gas_view.h"
#include "geometry/mill_config.h"
#include "process/psd.h"

namespace millsim {

struct VortexSample {
  double radius_m = 0.0;
  double tangential_m_per_s = 0.0;  // mean, positive counter-clockwise about +z
  double radial_m_per_s = 0.0;      // mean, negative inwards
  std::size_t points = 0;
};

// The gas velocity averaged over `azimuths` × `heights` points of the cylinder of radius
// `radius_m` about the mill's axis, between heights z_lo and z_hi above the floor.
VortexSample sample_vortex(const GasView& gas, const MillConfig& mill, double radius_m,
                           double z_lo_m, double z_hi_m, int azimuths = 128, int heights = 16);

// x_c of the force balance above; 0 when there is no tangential flow.
double force_balance_cut_size_m(double viscosity_pa_s, double particle_density_kg_per_m3,
                                double gas_density_kg_per_m3, const VortexSample& vortex);

// The vortex's exponent n in u_t r^n = const (n = 1: a free vortex, n = −1: solid-body
// rotation; a spiral jet mill's vortex is free-type, n > 0, outside its core): the
// least-squares slope of ln u_t against ln r, negated, over samples[first .. last] with u_t > 0.
struct VortexExponent {
  double n = 0.0;
  double from_radius_m = 0.0, to_radius_m = 0.0;
  std::size_t points = 0;  // fewer than 2: no fit (n = 0)
};
VortexExponent vortex_exponent(const std::vector<VortexSample>& samples, std::size_t first,
                               std::size_t last);

struct GradeEfficiency {
  std::vector<double> size_m;  // class centres (geometric means of the edges), classes with mass
  std::vector<double> outlet_kg, retained_kg, share_to_outlet;
  std::optional<double> cut_size_m;  // where the share falls through 1/2
  // Where the share falls through half its largest value (the reduced grade efficiency T/T_max):
  // in a window shorter than the fines' residence time, T never reaches 1/2 for any size,
  // since fines still on their way to the outlet count as held up.
  std::optional<double> reduced_cut_size_m;
  double max_share = 0.0;
};

// `outlet` and `retained` share their edges.
GradeEfficiency grade_efficiency(const PsdTally& outlet, const PsdTally& retained);

}  // namespace millsim
