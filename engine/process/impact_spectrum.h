// The impact-energy spectrum: how many impacts (contact onsets) the particles meet, binned by
// specific impact energy (J/kg) of the normal and of the tangential relative speed at the contact
// point, e = v²/2 (Vogel & Peukert's mass-specific impact energy W_m,kin), per size class of the
// particle that meets the impact, per material pair and per contact kind (particle–particle,
// particle–wall, by wall). A pair impact counts once for each of its two particles. Population
// balance models of mills take it as their input; counts per second are counts / simulated time.
// Kept over the run and per output interval (closed at each snapshot).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "checkpoint/archive.h"

namespace millsim {

// Who meets whom: a particle of `material` and a partner particle of `partner` (a material
// index), or a wall (`partner` the wall's index).
struct ImpactGroup {
  std::int32_t with_wall = 0;
  std::int32_t material = 0;
  std::int32_t partner = 0;
  bool operator==(const ImpactGroup&) const = default;
};

class ImpactSpectrum {
 public:
  ImpactSpectrum() = default;
  // Size classes by `size_edges_m` (a particle outside them counts in the first or last class),
  // energy bins log-spaced from `min_j_per_kg` to `max_j_per_kg`, `bins_per_decade` of them
  // (an energy outside counts in the first or last bin; an energy of 0 in the first).
  ImpactSpectrum(std::vector<double> size_edges_m, double min_j_per_kg, double max_j_per_kg,
                 int bins_per_decade);

  // One impact met by a particle of diameter `diameter_m`.
  void add(const ImpactGroup& group, double diameter_m, double normal_speed_m_per_s,
           double tangential_speed_m_per_s);
  // Ends the output interval at `time_s`: the counts since the last call become one interval.
  void close_interval(double time_s);

  const std::vector<double>& size_edges_m() const { return size_edges_m_; }
  const std::vector<double>& energy_edges_j_per_kg() const { return energy_edges_; }
  const std::vector<ImpactGroup>& groups() const { return groups_; }
  std::size_t size_classes() const { return size_edges_m_.size() - 1; }
  std::size_t energy_bins() const { return energy_edges_.size() - 1; }
  // Counts over the run of group g: [size class][energy bin], row-major.
  const std::vector<std::uint64_t>& normal_counts(std::size_t g) const { return normal_[g]; }
  const std::vector<std::uint64_t>& tangential_counts(std::size_t g) const {
    return tangential_[g];
  }
  std::uint64_t impacts() const { return impacts_; }  // particle-impacts counted
  // The closed intervals: their end times, and the run's counts at each end (per group, as
  // above; a group that appeared later has no counts in the intervals before).
  const std::vector<double>& interval_end_s() const { return interval_end_s_; }
  // Normal counts of group g in interval k (the counts at its end less those at its start).
  std::vector<std::uint64_t> interval_normal_counts(std::size_t k, std::size_t g) const;
  std::vector<std::uint64_t> interval_tangential_counts(std::size_t k, std::size_t g) const;

  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, size_edges_m_, energy_edges_, log_min_, bins_per_decade_, groups_, normal_,
           tangential_, impacts_, interval_end_s_, marks_normal_, marks_tangential_);
  }

 private:
  std::size_t size_class(double diameter_m) const;
  std::size_t energy_bin(double j_per_kg) const;
  std::size_t group_index(const ImpactGroup& group);
  std::vector<std::uint64_t> interval_counts(
      const std::vector<std::vector<std::vector<std::uint64_t>>>& marks, std::size_t k,
      std::size_t g) const;

  std::vector<double> size_edges_m_;
  std::vector<double> energy_edges_;
  double log_min_ = 0.0;
  double bins_per_decade_ = 1.0;
  std::vector<ImpactGroup> groups_;
  std::vector<std::vector<std::uint64_t>> normal_, tangential_;  // per group
  std::uint64_t impacts_ = 0;
  std::vector<double> interval_end_s_;
  // The run's counts at each interval's end: [interval][group][size × bin].
  std::vector<std::vector<std::vector<std::uint64_t>>> marks_normal_, marks_tangential_;
};

}  // namespace millsim
