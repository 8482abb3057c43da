// The build and the machine a result came from (core/build_info.h plus the host): baselines and
// regression records carry it, so an `exact` comparison is only made against the same build.
#pragma once

#include <nlohmann/json.hpp>

#include "core/build_info.h"

namespace millsim {

// {millsim_version, git_commit, compiler, machine {host, arch, cpu}}.
nlohmann::ordered_json build_description();

// The fields of build_description() that decide bit-identical results: commit, compiler, machine.
std::string build_fingerprint(const nlohmann::json& build);

}  // namespace millsim
