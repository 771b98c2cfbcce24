// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// FUZZ_REQUIRE(cond): what a fuzz target checks on the result of an input its parser accepted.
// When `cond` does not hold, the target prints its name (the constant kFuzzTarget, which a target
// using the macro defines) and the failed condition on stderr and aborts, so libFuzzer reports the
// input as a crash.

#include <cstdio>
#include <cstdlib>

#define FUZZ_REQUIRE(cond)                                                 \
  do {                                                                     \
    if (!(cond)) {                                                         \
      std::fprintf(stderr, "%s: inconsistent: %s\n", kFuzzTarget, #cond); \
      std::abort();                                                        \
    }                                                                      \
  } while (false)
