// Physics checks that take minutes under AddressSanitizer + UndefinedBehaviorSanitizer (5-6x
// their Release time) while shorter tests run the same code under them: such a check runs in
// the Release run of the suite only (CI runs both), and its skip says which test covers its code
// under the sanitizers. MILLSIM_SANITIZED is defined by the sanitized and fuzzing builds
// (CMakeLists.txt; clang 14 does not define g++'s __SANITIZE_ADDRESS__).
#pragma once

#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#if defined(MILLSIM_SANITIZED)
#define MILLSIM_RELEASE_ONLY(covered_by)                                                     \
  GTEST_SKIP() << "a physics check run by the Release suite; under the sanitizers its code " \
                  "runs in "                                                                 \
               << covered_by
#else
#define MILLSIM_RELEASE_ONLY(covered_by) static_cast<void>(0)
#endif

namespace millsim::test {

// The window of a shipped case in the long bit-for-bit tests (checkpoint, determinism, threads).
// Under the sanitizers the attrition target stops at 2.5e-4 s, soon after its first breakages
// (146 events, 2 568 particles, 36 689 steps): its 4e-4 and 6e-4 s windows (4 758 and 5 255
// particles over 58 702 and 88 053 steps) were three quarters of those tests' time there, 80 to
// 140 s a case under ASan. Elsewhere the window as given.
inline double bit_for_bit_window_s(const std::string& file, double end_s) {
#if defined(MILLSIM_SANITIZED)
  if (file == "attrition_target.json") return std::min(end_s, 2.5e-4);
#else
  static_cast<void>(file);
#endif
  return end_s;
}

}  // namespace millsim::test
