// Comparing two runs of one scene byte for byte: every per-particle column, the tallies, the dust
// ledger and the gas fields (checkpoint restarts, thread counts).
#pragma once

#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "scene/scene_config.h"
#include "sim/simulation.h"

namespace millsim::test {

template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// A shipped case from cases/, ending at end_s; `edit` changes its JSON before it is read.
SceneConfig shipped_case(const std::string& file, double end_s,
                         const std::function<void(nlohmann::json&)>& edit = {});

// Gtest expectations that a and b are at the same step with the same state, bit for bit.
void expect_identical(Simulation& a, Simulation& b);

}  // namespace millsim::test
