// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/raycaster.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"

// The watertight test relies on the edge functions of two triangles sharing an edge being exact
// negatives of each other; a fused multiply-add would round one product and not the other.
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace plumb::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxDepth = 56;        // the build switches to median splits below this depth
constexpr int kStackSize = 128;      // traversal stack: depth <= kMaxDepth + 32 median levels
constexpr int kMaxSahLeaf = 16;      // a node this small may stay a leaf when no split pays off

struct Aabb {
  Vector3d lo = Vector3d::Constant(kInf);
  Vector3d hi = Vector3d::Constant(-kInf);
  void grow(const Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  bool valid() const { return lo.x() <= hi.x(); }
  double half_area() const {
    if (!valid()) return 0.0;
    const Vector3d e = hi - lo;
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  }
};

float round_down(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
float round_up(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

struct Builder {
  const RayCasterSettings& settings;
  std::vector<Aabb> tri_box;
  std::vector<Vector3d> centroid;
  std::vector<std::uint32_t> index;
  std::vector<RayCaster::Node>& nodes;

  void set_bounds(std::uint32_t node, const Aabb& b) {
    // Outward float rounding plus a pad that covers the float rounding of the ray origin.
    for (int k = 0; k < 3; ++k) {
      const double pad = 1e-4 + 1e-6 * std::max(std::abs(b.lo[k]), std::abs(b.hi[k]));
      nodes[node].lo[k] = round_down(b.lo[k] - pad);
      nodes[node].hi[k] = round_up(b.hi[k] + pad);
    }
  }

  void make_leaf(std::uint32_t node, std::size_t begin, std::size_t end) {
    nodes[node].offset = static_cast<std::uint32_t>(begin);
    nodes[node].count = static_cast<std::uint32_t>(end - begin);
  }

  void build(std::uint32_t node, std::size_t begin, std::size_t end, int depth) {
    Aabb box, cbox;
    for (std::size_t i = begin; i < end; ++i) {
      box.grow(tri_box[index[i]]);
      cbox.grow(centroid[index[i]]);
    }
    set_bounds(node, box);
    const std::size_t count = end - begin;
    if (count <= static_cast<std::size_t>(settings.leaf_size)) {
      make_leaf(node, begin, end);
      return;
    }
    const Vector3d extent = cbox.hi - cbox.lo;
    int axis = 0;
    extent.maxCoeff(&axis);
    std::size_t mid = begin;
    if (!(extent[axis] > 0.0)) {
      // Every centroid coincides: no spatial split separates them.
      if (count <= 255) {
        make_leaf(node, begin, end);
        return;
      }
      mid = begin + count / 2;
    } else if (depth >= kMaxDepth) {
      mid = begin + count / 2;
      std::nth_element(index.begin() + static_cast<std::ptrdiff_t>(begin),
                       index.begin() + static_cast<std::ptrdiff_t>(mid),
                       index.begin() + static_cast<std::ptrdiff_t>(end),
                       [&](std::uint32_t a, std::uint32_t b) { return centroid[a][axis] < centroid[b][axis]; });
    } else {
      // Binned SAH (Wald 2007): bins along each axis, cost of every split plane between bins.
      const int nb = settings.sah_bins;
      double best_cost = kInf;
      int best_axis = -1, best_split = -1;
      std::vector<Aabb> bin_box(static_cast<std::size_t>(nb));
      std::vector<std::size_t> bin_count(static_cast<std::size_t>(nb));
      std::vector<double> right_area(static_cast<std::size_t>(nb));
      std::vector<std::size_t> right_count(static_cast<std::size_t>(nb));
      for (int a = 0; a < 3; ++a) {
        if (!(extent[a] > 0.0)) continue;
        std::fill(bin_box.begin(), bin_box.end(), Aabb{});
        std::fill(bin_count.begin(), bin_count.end(), 0);
        const double scale = nb / extent[a];
        for (std::size_t i = begin; i < end; ++i) {
          const std::uint32_t t = index[i];
          const int b = std::min(nb - 1, static_cast<int>((centroid[t][a] - cbox.lo[a]) * scale));
          bin_box[static_cast<std::size_t>(b)].grow(tri_box[t]);
          ++bin_count[static_cast<std::size_t>(b)];
        }
        Aabb acc;
        std::size_t n = 0;
        for (int b = nb - 1; b > 0; --b) {
          acc.grow(bin_box[static_cast<std::size_t>(b)]);
          n += bin_count[static_cast<std::size_t>(b)];
          right_area[static_cast<std::size_t>(b)] = acc.half_area();
          right_count[static_cast<std::size_t>(b)] = n;
        }
        acc = Aabb{};
        n = 0;
        for (int b = 0; b < nb - 1; ++b) {  // split between bin b and b + 1
          acc.grow(bin_box[static_cast<std::size_t>(b)]);
          n += bin_count[static_cast<std::size_t>(b)];
          const std::size_t nr = right_count[static_cast<std::size_t>(b + 1)];
          if (n == 0 || nr == 0) continue;
          const double cost = acc.half_area() * static_cast<double>(n) +
                              right_area[static_cast<std::size_t>(b + 1)] * static_cast<double>(nr);
          if (cost < best_cost) {
            best_cost = cost;
            best_axis = a;
            best_split = b;
          }
        }
      }
      // Leaf cost n * A versus traversal (~1 triangle test) * A + split cost.
      const double leaf_cost = static_cast<double>(count) * box.half_area();
      if (best_axis < 0 || (count <= static_cast<std::size_t>(kMaxSahLeaf) &&
                            best_cost + box.half_area() >= leaf_cost)) {
        if (best_axis < 0 && count > 255) {
          mid = begin + count / 2;
        } else {
          make_leaf(node, begin, end);
          return;
        }
      } else {
        const double scale = nb / extent[best_axis];
        const double lo = cbox.lo[best_axis];
        auto it = std::partition(index.begin() + static_cast<std::ptrdiff_t>(begin),
                                 index.begin() + static_cast<std::ptrdiff_t>(end), [&](std::uint32_t t) {
                                   const int b = std::min(nb - 1, static_cast<int>((centroid[t][best_axis] - lo) * scale));
                                   return b <= best_split;
                                 });
        mid = static_cast<std::size_t>(it - index.begin());
        if (mid == begin || mid == end) mid = begin + count / 2;  // cannot happen; stay safe
      }
    }
    const auto left = static_cast<std::uint32_t>(nodes.size());
    nodes.emplace_back();
    build(left, begin, mid, depth + 1);
    const auto right = static_cast<std::uint32_t>(nodes.size());
    nodes.emplace_back();
    build(right, mid, end, depth + 1);
    nodes[node].offset = right;
    nodes[node].count = 0;
  }
};

}  // namespace

RayCaster::RayCaster(std::vector<Vector3d> vertices, std::vector<std::array<std::uint32_t, 3>> triangles,
                     std::vector<std::int32_t> triangle_element, const RayCasterSettings& settings)
    : vertices_(std::move(vertices)), triangles_(std::move(triangles)), triangle_element_(std::move(triangle_element)) {
  PLUMB_CHECK(settings.leaf_size >= 1 && settings.leaf_size <= 255,
              "RayCaster: settings.leaf_size " << settings.leaf_size << " outside [1, 255]");
  PLUMB_CHECK(settings.sah_bins >= 2 && settings.sah_bins <= 1024,
              "RayCaster: settings.sah_bins " << settings.sah_bins << " outside [2, 1024]");
  PLUMB_CHECK(triangles_.size() < std::numeric_limits<std::uint32_t>::max(),
              "RayCaster: " << triangles_.size() << " triangles exceed the 32-bit index");
  if (triangle_element_.empty()) triangle_element_.assign(triangles_.size(), -1);
  PLUMB_CHECK(triangle_element_.size() == triangles_.size(),
              "RayCaster: triangle_element has " << triangle_element_.size() << " entries for "
                                                 << triangles_.size() << " triangles");
  for (std::size_t v = 0; v < vertices_.size(); ++v) {
    PLUMB_CHECK(vertices_[v].allFinite(), "RayCaster: vertex " << v << " is not finite");
  }
  for (std::size_t t = 0; t < triangles_.size(); ++t) {
    for (std::uint32_t v : triangles_[t]) {
      PLUMB_CHECK(v < vertices_.size(), "RayCaster: triangle " << t << " uses vertex " << v << " of "
                                                               << vertices_.size());
    }
  }
  build(settings);
}

RayCaster::RayCaster(const bim::BimMesh& mesh, const RayCasterSettings& settings)
    : RayCaster(mesh.vertices, mesh.triangles, mesh.triangle_element, settings) {}

void RayCaster::build(const RayCasterSettings& settings) {
  const std::size_t n = triangles_.size();
  nodes_.clear();
  leaf_vertices_.clear();
  leaf_triangle_.clear();
  if (n == 0) return;
  Builder b{settings, {}, {}, {}, nodes_};
  b.tri_box.resize(n);
  b.centroid.resize(n);
  b.index.resize(n);
  for (std::size_t t = 0; t < n; ++t) {
    Aabb box;
    for (std::uint32_t v : triangles_[t]) box.grow(vertices_[v]);
    b.tri_box[t] = box;
    b.centroid[t] = 0.5 * (box.lo + box.hi);
    b.index[t] = static_cast<std::uint32_t>(t);
  }
  nodes_.reserve(2 * n / static_cast<std::size_t>(settings.leaf_size) + 2);
  nodes_.emplace_back();
  b.build(0, 0, n, 0);
  leaf_triangle_ = std::move(b.index);
  leaf_vertices_.resize(9 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& tri = triangles_[leaf_triangle_[i]];
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c) leaf_vertices_[9 * i + 3 * static_cast<std::size_t>(k) + static_cast<std::size_t>(c)] = vertices_[tri[static_cast<std::size_t>(k)]][c];
    }
  }
}

template <bool kAnyHit>
RayHit RayCaster::traverse(const Vector3d& origin, const Vector3d& dir, double t_max) const {
  RayHit result;
  if (nodes_.empty()) return result;
  if (!origin.allFinite() || !dir.allFinite() || !(t_max > 0.0)) return result;
  // Watertight test set-up (Woop et al. 2013, sec. 3): the dominant axis becomes z, shear so the
  // ray is the z axis.
  int kz = 0;
  dir.cwiseAbs().maxCoeff(&kz);
  if (dir[kz] == 0.0) return result;
  int kx = (kz + 1) % 3;
  int ky = (kx + 1) % 3;
  if (dir[kz] < 0.0) std::swap(kx, ky);
  const double sx = dir[kx] / dir[kz];
  const double sy = dir[ky] / dir[kz];
  const double sz = 1.0 / dir[kz];
  const double ox = origin[kx], oy = origin[ky], oz = origin[kz];

  // Box test set-up in float.
  float org[3], inv[3];
  int near_idx[3];
  for (int k = 0; k < 3; ++k) {
    org[k] = static_cast<float>(origin[k]);
    const float d = static_cast<float>(dir[k]);
    inv[k] = 1.0f / (d != 0.0f ? d : std::copysign(1e-30f, d));
    near_idx[k] = inv[k] >= 0.0f ? 0 : 1;
  }
  // Ize 2013: scale the far distance so float rounding cannot drop a box the ray touches.
  constexpr float kFarScale = 1.0f + 4.0f * std::numeric_limits<float>::epsilon();
  double best = t_max;
  auto box_entry = [&](const Node& nd, float t_far_limit) -> float {
    const float* lo = nd.lo;
    const float* hi = nd.hi;
    const float* bx[2] = {lo, hi};
    const float tx0 = (bx[near_idx[0]][0] - org[0]) * inv[0];
    const float tx1 = (bx[1 - near_idx[0]][0] - org[0]) * inv[0];
    const float ty0 = (bx[near_idx[1]][1] - org[1]) * inv[1];
    const float ty1 = (bx[1 - near_idx[1]][1] - org[1]) * inv[1];
    const float tz0 = (bx[near_idx[2]][2] - org[2]) * inv[2];
    const float tz1 = (bx[1 - near_idx[2]][2] - org[2]) * inv[2];
    const float t0 = std::max(std::max(tx0, ty0), std::max(tz0, 0.0f));
    const float t1 = std::min(std::min(tx1, ty1), std::min(tz1, t_far_limit)) * kFarScale;
    return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
  };
  auto far_limit = [&]() {
    return best < 3e38 ? round_up(best) : std::numeric_limits<float>::infinity();
  };

  std::uint32_t best_leaf = ~0u;
  if (box_entry(nodes_[0], far_limit()) == std::numeric_limits<float>::infinity()) return result;
  std::uint32_t stack_node[kStackSize];
  float stack_t[kStackSize];
  int sp = 0;
  std::uint32_t ni = 0;
  for (;;) {
    const Node& nd = nodes_[ni];
    if (nd.count > 0) {
      const double* v = leaf_vertices_.data() + 9 * static_cast<std::size_t>(nd.offset);
      for (std::uint32_t i = 0; i < nd.count; ++i, v += 9) {
        const double ax = v[kx] - ox, ay = v[ky] - oy, az = v[kz] - oz;
        const double bx = v[3 + kx] - ox, by = v[3 + ky] - oy, bz = v[3 + kz] - oz;
        const double cx = v[6 + kx] - ox, cy = v[6 + ky] - oy, cz = v[6 + kz] - oz;
        const double Ax = ax - sx * az, Ay = ay - sy * az;
        const double Bx = bx - sx * bz, By = by - sy * bz;
        const double Cx = cx - sx * cz, Cy = cy - sy * cz;
        const double U = Cx * By - Cy * Bx;
        const double V = Ax * Cy - Ay * Cx;
        const double W = Bx * Ay - By * Ax;
        if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) continue;
        const double det = U + V + W;
        if (det == 0.0) continue;
        const double T = U * (sz * az) + V * (sz * bz) + W * (sz * cz);
        const double t = T / det;
        if (!(t > 0.0) || !(t < best)) continue;
        best = t;
        best_leaf = nd.offset + i;
        if (kAnyHit) break;
      }
      if (kAnyHit && best_leaf != ~0u) break;
    } else {
      const float lim = far_limit();
      const std::uint32_t l = ni + 1, r = nd.offset;
      const float tl = box_entry(nodes_[l], lim);
      const float tr = box_entry(nodes_[r], lim);
      constexpr float kMiss = std::numeric_limits<float>::infinity();
      if (tl != kMiss && tr != kMiss) {
        const bool left_first = tl <= tr;
        stack_node[sp] = left_first ? r : l;
        stack_t[sp] = left_first ? tr : tl;
        ++sp;
        ni = left_first ? l : r;
        continue;
      }
      if (tl != kMiss) { ni = l; continue; }
      if (tr != kMiss) { ni = r; continue; }
    }
    // Pop the next node still closer than the best hit.
    bool found = false;
    while (sp > 0) {
      --sp;
      if (static_cast<double>(stack_t[sp]) <= best) {
        ni = stack_node[sp];
        found = true;
        break;
      }
    }
    if (!found) break;
  }
  if (best_leaf == ~0u) return result;
  const double* v = leaf_vertices_.data() + 9 * static_cast<std::size_t>(best_leaf);
  const Vector3d p0(v[0], v[1], v[2]), p1(v[3], v[4], v[5]), p2(v[6], v[7], v[8]);
  Vector3d n = (p1 - p0).cross(p2 - p0);
  const double len = n.norm();
  n = len > 0.0 ? Vector3d(n / len) : Vector3d(-dir);
  if (n.dot(dir) > 0.0) n = -n;
  result.range = best;
  result.triangle = leaf_triangle_[best_leaf];
  result.element = triangle_element_[result.triangle];
  result.normal = n;
  return result;
}

RayHit RayCaster::cast(const Vector3d& origin, const Vector3d& unit_dir, double t_max) const {
  return traverse<false>(origin, unit_dir, t_max);
}

bool RayCaster::occluded(const Vector3d& origin, const Vector3d& unit_dir, double t_max) const {
  return traverse<true>(origin, unit_dir, t_max).hit();
}

}  // namespace plumb::sim
