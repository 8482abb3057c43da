// Where this binary came from: the git commit of its source tree (with "-dirty" for local
// changes) and the compiler, written at build time by cmake/write_build_info.cmake. run.h5's /meta,
// regression baselines and records carry them.
#pragma once

namespace millsim {

extern const char* const kGitCommit;
extern const char* const kCompiler;

}  // namespace millsim
