// What a dust ledger holds and has counted, copied out so that tests can compare two ledgers'
// results bit for bit (layouts, thread counts, what a thread carried before).
#pragma once

#include <cstdint>
#include <vector>

#include "dust/dust_ledger.h"

namespace millsim::test {

struct LedgerState {
  std::vector<std::vector<double>> mass;  // per class, per padded cell
  std::vector<double> outflow_kg, max_slip;
  std::vector<std::uint64_t> speed_bounded_cells;
  std::uint64_t substeps = 0;
  bool operator==(const LedgerState&) const = default;
};

inline LedgerState ledger_state(const DustLedger& ledger) {
  LedgerState state;
  for (int k = 0; k < ledger.class_count(); ++k) {
    state.mass.push_back(ledger.cell_mass_kg(k));
    state.outflow_kg.push_back(ledger.outflow_kg(k));
  }
  state.max_slip = ledger.stats().max_slip_m_per_s;
  state.speed_bounded_cells = ledger.stats().speed_bounded_cells;
  state.substeps = ledger.stats().substeps;
  return state;
}

}  // namespace millsim::test
