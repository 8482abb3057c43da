// Physics checks that take minutes under AddressSanitizer + UndefinedBehaviorSanitizer (5-6x
// their Release time) while shorter tests run the same code under them: such a check runs in
// the Release run of the suite only (CI runs both), and its skip says which test covers its code
// under the sanitizers. MILLSIM_SANITIZED is defined by the sanitized and fuzzing builds
// (CMakeLists.txt; clang 14 does not define g++'s __SANITIZE_ADDRESS__).
#pragma once

#include <gtest/gtest.h>

#if defined(MILLSIM_SANITIZED)
#define MILLSIM_RELEASE_ONLY(covered_by)                                                     \
  GTEST_SKIP() << "a physics check run by the Release suite; under the sanitizers its code " \
                  "runs in "                                                                 \
               << covered_by
#else
#define MILLSIM_RELEASE_ONLY(covered_by) static_cast<void>(0)
#endif
