// Statistical tests over minutes of simulated data take seconds in the
// Release build and many minutes built for AddressSanitizer (Debug, Eigen
// unoptimised), where they would only time the sanitizer. CI runs them in
// its Release pass (make test); the sanitizer pass covers the same code
// through the shorter tests beside them.
#pragma once

#include <gtest/gtest.h>

// MOA_SANITIZED: built for AddressSanitizer. GCC says so with
// __SANITIZE_ADDRESS__, clang (14) only through __has_feature.
#if defined(__SANITIZE_ADDRESS__)
#define MOA_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MOA_SANITIZED 1
#endif
#endif

#if defined(MOA_SANITIZED)
#define MOA_SKIP_UNDER_SANITIZER(why) \
  GTEST_SKIP() << why << ": run in the Release build, minutes under ASan"
#else
#define MOA_SKIP_UNDER_SANITIZER(why) static_cast<void>(0)
#endif
