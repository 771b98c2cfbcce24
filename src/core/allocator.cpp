// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/core/allocator.hpp"

#include <cstdlib>  // defines __GLIBC__ where the C library is glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace plumb {

bool keep_freed_memory() {
#if defined(__GLIBC__)
  // Setting either fixes both (glibc stops adjusting them itself); 32 MiB is the largest mmap
  // threshold glibc accepts on 64-bit systems.
  const bool mmap_set = mallopt(M_MMAP_THRESHOLD, 32 << 20) == 1;
  const bool trim_set = mallopt(M_TRIM_THRESHOLD, 64 << 20) == 1;
  return mmap_set && trim_set;
#else
  return false;
#endif
}

}  // namespace plumb
