// Where this binary came from: the git commit of its source tree (with "-dirty" for local
// changes) and the compiler, written at build time by cmake/write_build_info.cmake. Baselines and
// regression records carry them, so an `exact` comparison is only made against the same build.
#pragma once

#include <nlohmann/json.hpp>

namespace millsim {

extern const char* const kGitCommit;
extern const char* const kCompiler;

// {millsim_version, git_commit, compiler, machine {host, arch, cpu}}.
nlohmann::ordered_json build_description();

// The fields of build_description() that decide bit-identical results: commit, compiler, machine.
std::string build_fingerprint(const nlohmann::json& build);

}  // namespace millsim
