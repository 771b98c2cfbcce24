// SPDX-License-Identifier: BSD-3-Clause
// The one explicit instantiation of the kd-trees every module uses (declared extern in kdtree.hpp):
// compiled here once instead of in every source and test that includes the header; and the
// non-template helpers of its build and its queries.
#include "plumb/search/kdtree.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>

#include "plumb/core/parallel.hpp"

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

void kd_record_box(const float* records, std::uint32_t begin, std::uint32_t end, float* lo, float* hi, float* sum) {
  constexpr int kLanes = kKdRecord - 1;
#if defined(__SSE2__)
  // One record per register; the index lane is zeroed before it meets arithmetic (its bits read as
  // a float are often subnormal, which some CPUs add slowly).
  const __m128 coords = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
  // Two records per step into two sets of accumulators, so that the min, max and add chains of
  // consecutive records overlap; combined at the end in a fixed order.
  const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
  __m128 vl = inf, vl2 = inf;
  __m128 vh = _mm_sub_ps(_mm_setzero_ps(), inf), vh2 = vh;
  __m128 vs = _mm_setzero_ps(), vs2 = vs;
  const float* r = records + static_cast<std::size_t>(kKdRecord) * begin;
  std::uint32_t i = begin;
  for (; i + 2 <= end; i += 2, r += 2 * kKdRecord) {
    const __m128 v = _mm_and_ps(_mm_loadu_ps(r), coords);
    const __m128 v2 = _mm_and_ps(_mm_loadu_ps(r + kKdRecord), coords);
    vl = _mm_min_ps(v, vl);
    vh = _mm_max_ps(v, vh);
    vs = _mm_add_ps(vs, v);
    vl2 = _mm_min_ps(v2, vl2);
    vh2 = _mm_max_ps(v2, vh2);
    vs2 = _mm_add_ps(vs2, v2);
  }
  if (i < end) {
    const __m128 v = _mm_and_ps(_mm_loadu_ps(r), coords);
    vl = _mm_min_ps(v, vl);
    vh = _mm_max_ps(v, vh);
    vs = _mm_add_ps(vs, v);
  }
  vl = _mm_min_ps(vl, vl2);
  vh = _mm_max_ps(vh, vh2);
  vs = _mm_add_ps(vs, vs2);
  alignas(16) float l[4], h[4], s[4];
  _mm_store_ps(l, vl);
  _mm_store_ps(h, vh);
  _mm_store_ps(s, vs);
  for (int k = 0; k < kLanes; ++k) {
    lo[k] = l[k];
    hi[k] = h[k];
    sum[k] = s[k];
  }
#else
  for (int k = 0; k < kLanes; ++k) {
    lo[k] = std::numeric_limits<float>::infinity();
    hi[k] = -std::numeric_limits<float>::infinity();
    sum[k] = 0.0f;
  }
  const float* r = records + static_cast<std::size_t>(kKdRecord) * begin;
  for (std::uint32_t i = begin; i < end; ++i, r += kKdRecord) {
    for (int k = 0; k < kLanes; ++k) {
      lo[k] = r[k] < lo[k] ? r[k] : lo[k];
      hi[k] = r[k] > hi[k] ? r[k] : hi[k];
      sum[k] += r[k];
    }
  }
#endif
}

std::uint32_t kd_partition_records(float* records, int dim, float split, std::uint32_t begin, std::uint32_t end) {
  // Lomuto's scheme without its branch: [begin, front) is left, [front, src) right. Record src is
  // swapped with record front whatever its side, and front moves on only when it is left; a right
  // record so swapped lands at front, which stays the first right slot (or src itself when
  // front == src).
  std::uint32_t front = begin;
  float* r = records + static_cast<std::size_t>(kKdRecord) * begin;
  for (std::uint32_t src = begin; src < end; ++src, r += kKdRecord) {
    const std::uint32_t is_left = r[dim] < split ? 1u : 0u;
    float* f = records + static_cast<std::size_t>(kKdRecord) * front;
#if defined(__SSE2__)
    const __m128 v = _mm_loadu_ps(r);
    const __m128 w = _mm_loadu_ps(f);
    _mm_storeu_ps(r, w);
    _mm_storeu_ps(f, v);
#else
    float v[kKdRecord];
    std::memcpy(v, r, sizeof v);
    std::memmove(r, f, sizeof v);
    std::memcpy(f, v, sizeof v);
#endif
    front += is_left;
  }
  return front;
}

void kd_parallel_chunks(int threads, std::size_t chunks, void (*body)(void*, std::size_t), void* context) {
  parallel_chunks(threads, chunks, [body, context](std::size_t c) { body(context, c); });
}

}  // namespace detail

template class KdTree<2>;
template class KdTree<3>;
}  // namespace plumb
