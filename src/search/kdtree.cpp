// SPDX-License-Identifier: BSD-3-Clause
// The one explicit instantiation of the kd-trees every module uses (declared extern in kdtree.hpp):
// compiled here once instead of in every source and test that includes the header; and the
// non-template helpers of its build and its queries.
#include "plumb/search/kdtree.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace plumb {

namespace detail {

float next_float_up(float v) {
  if (!(v < std::numeric_limits<float>::infinity())) return v;
  if (v == 0.0f) return std::numeric_limits<float>::denorm_min();  // also for -0 (sign bit set)
  std::uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  ++bits;
  std::memcpy(&v, &bits, sizeof bits);
  return v;
}

void min_max_sum(const float* x, std::size_t count, float& lo, float& hi, float& sum) {
  float l[4] = {lo, lo, lo, lo};
  float h[4] = {hi, hi, hi, hi};
  float s[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  std::size_t i = 0;
#if defined(__SSE2__)
  // The same four lanes in one register each: minps(x, l) is x < l ? x : l, as below.
  __m128 vl = _mm_set1_ps(lo);
  __m128 vh = _mm_set1_ps(hi);
  __m128 vs = _mm_setzero_ps();
  for (; i + 4 <= count; i += 4) {
    const __m128 v = _mm_loadu_ps(x + i);
    vl = _mm_min_ps(v, vl);
    vh = _mm_max_ps(v, vh);
    vs = _mm_add_ps(vs, v);
  }
  _mm_storeu_ps(l, vl);
  _mm_storeu_ps(h, vh);
  _mm_storeu_ps(s, vs);
#else
  for (; i + 4 <= count; i += 4) {
    for (int j = 0; j < 4; ++j) {
      l[j] = x[i + j] < l[j] ? x[i + j] : l[j];
      h[j] = x[i + j] > h[j] ? x[i + j] : h[j];
      s[j] += x[i + j];
    }
  }
#endif
  for (; i < count; ++i) {
    l[0] = x[i] < l[0] ? x[i] : l[0];
    h[0] = x[i] > h[0] ? x[i] : h[0];
    s[0] += x[i];
  }
  lo = std::min(std::min(l[0], l[1]), std::min(l[2], l[3]));
  hi = std::max(std::max(h[0], h[1]), std::max(h[2], h[3]));
  sum = (s[0] + s[1]) + (s[2] + s[3]);
}

}  // namespace detail

template class KdTree<2>;
template class KdTree<3>;
}  // namespace plumb
