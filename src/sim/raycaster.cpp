// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/raycaster.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#if defined(__SSE2__) || defined(_M_X64)
#include <emmintrin.h>
#define PLUMB_RAYCASTER_SSE2 1
#endif

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
constexpr int kMaxSahLeaf = 16;      // a node this small may stay a leaf when no split pays off
// The 4-wide tree is at most as deep as the binary one (<= kMaxDepth + 32 median levels + the
// chunking of a leaf into groups of four) and a node pushes at most three children.
constexpr int kMaxTreeDepth = kMaxDepth + 48;
constexpr int kStackSize = 3 * kMaxTreeDepth + 4;

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

/// A node of the binary SAH tree the 4-wide tree is collapsed from.
struct BinaryNode {
  Aabb box;
  std::uint32_t left = ~0u, right = ~0u;  // children; ~0u for a leaf
  std::size_t begin = 0, end = 0;         // triangles index[begin, end) of a leaf
  bool leaf() const { return left == ~0u; }
};

struct Builder {
  const RayCasterSettings& settings;
  std::vector<Aabb> tri_box;
  std::vector<Vector3d> centroid;
  std::vector<std::uint32_t> index;
  std::vector<BinaryNode> bnodes;

  std::uint32_t make_leaf(std::uint32_t node, std::size_t begin, std::size_t end) {
    bnodes[node].begin = begin;
    bnodes[node].end = end;
    return node;
  }

  /// Binary SAH build of index[begin, end) into bnodes[node].
  std::uint32_t build(std::uint32_t node, std::size_t begin, std::size_t end, int depth) {
    Aabb box, cbox;
    for (std::size_t i = begin; i < end; ++i) {
      box.grow(tri_box[index[i]]);
      cbox.grow(centroid[index[i]]);
    }
    bnodes[node].box = box;
    const std::size_t count = end - begin;
    if (count <= static_cast<std::size_t>(settings.leaf_size)) return make_leaf(node, begin, end);
    const Vector3d extent = cbox.hi - cbox.lo;
    int axis = 0;
    extent.maxCoeff(&axis);
    std::size_t mid = begin;
    if (!(extent[axis] > 0.0)) {
      // Every centroid coincides: no spatial split separates them.
      if (count <= 255) return make_leaf(node, begin, end);
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
          return make_leaf(node, begin, end);
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
    const auto left = static_cast<std::uint32_t>(bnodes.size());
    bnodes.emplace_back();
    build(left, begin, mid, depth + 1);
    const auto right = static_cast<std::uint32_t>(bnodes.size());
    bnodes.emplace_back();
    build(right, mid, end, depth + 1);
    bnodes[node].left = left;
    bnodes[node].right = right;
    return node;
  }
};

/// Collapses the binary tree into 4-wide nodes whose slots hold nodes or single triangles.
struct Collapser {
  Builder& b;
  std::vector<RayCaster::Node>& nodes;
  std::vector<std::uint32_t>& leaf_triangle;  // triangle of each leaf slot, in slot order
  int max_depth = 0;

  /// A child slot in the making: a binary node or one triangle.
  struct Item {
    bool is_triangle = false;
    std::uint32_t id = 0;  // binary node or triangle
  };

  const Aabb& box_of(const Item& it) const { return it.is_triangle ? b.tri_box[it.id] : b.bnodes[it.id].box; }

  std::uint32_t new_node() {
    nodes.emplace_back();
    RayCaster::Node& nd = nodes.back();
    for (int s = 0; s < 4; ++s) {
      for (int k = 0; k < 3; ++k) {
        nd.bounds[2 * k][s] = std::numeric_limits<float>::infinity();
        nd.bounds[2 * k + 1][s] = -std::numeric_limits<float>::infinity();
      }
      nd.child[s] = ~0u;
    }
    nd.num_children = 0;
    nd.triangle_mask = 0;
    nd.unused[0] = nd.unused[1] = 0;
    return static_cast<std::uint32_t>(nodes.size() - 1);
  }

  void set_slot(std::uint32_t node, int slot, const Aabb& box, std::uint32_t child, bool is_triangle) {
    RayCaster::Node& nd = nodes[node];
    // Outward float rounding plus a pad that covers the float rounding of the ray origin and of
    // the slab distances (so a box never culls what the exact triangle test would hit).
    for (int k = 0; k < 3; ++k) {
      const double pad = 1e-4 + 1e-6 * std::max(std::abs(box.lo[k]), std::abs(box.hi[k]));
      nd.bounds[2 * k][slot] = round_down(box.lo[k] - pad);
      nd.bounds[2 * k + 1][slot] = round_up(box.hi[k] + pad);
    }
    nd.child[slot] = child;
    if (is_triangle) nd.triangle_mask |= 1u << slot;
    nd.num_children = std::max(nd.num_children, static_cast<std::uint32_t>(slot + 1));
  }

  std::uint32_t triangle_slot(std::uint32_t triangle) {
    leaf_triangle.push_back(triangle);
    return RayCaster::kTriangleBit | static_cast<std::uint32_t>(leaf_triangle.size() - 1);
  }

  /// Fill `node` with the triangles index[begin, end): four groups along the longest centroid axis.
  void emit_triangles(std::uint32_t node, std::size_t begin, std::size_t end, int depth) {
    max_depth = std::max(max_depth, depth);
    const std::size_t count = end - begin;
    if (count <= 4) {
      for (std::size_t i = begin; i < end; ++i) {
        const std::uint32_t t = b.index[i];
        set_slot(node, static_cast<int>(i - begin), b.tri_box[t], triangle_slot(t), true);
      }
      return;
    }
    Aabb cbox;
    for (std::size_t i = begin; i < end; ++i) cbox.grow(b.centroid[b.index[i]]);
    int axis = 0;
    (cbox.hi - cbox.lo).maxCoeff(&axis);
    std::sort(b.index.begin() + static_cast<std::ptrdiff_t>(begin), b.index.begin() + static_cast<std::ptrdiff_t>(end),
              [&](std::uint32_t x, std::uint32_t y) { return b.centroid[x][axis] < b.centroid[y][axis]; });
    std::uint32_t child[4] = {~0u, ~0u, ~0u, ~0u};
    std::size_t lo[4], hi[4];
    for (int s = 0; s < 4; ++s) {  // the child nodes first, side by side in memory
      lo[s] = begin + count * static_cast<std::size_t>(s) / 4;
      hi[s] = begin + count * static_cast<std::size_t>(s + 1) / 4;
      Aabb box;
      for (std::size_t i = lo[s]; i < hi[s]; ++i) box.grow(b.tri_box[b.index[i]]);
      if (hi[s] - lo[s] == 1) {
        set_slot(node, s, box, triangle_slot(b.index[lo[s]]), true);
      } else {
        child[s] = new_node();
        set_slot(node, s, box, child[s], false);
      }
    }
    for (int s = 0; s < 4; ++s) {
      if (child[s] != ~0u) emit_triangles(child[s], lo[s], hi[s], depth + 1);
    }
  }

  /// Fill `node` from the binary subtree `bnode`: open the largest binary children until four
  /// slots are filled (a leaf opens into its triangles when they fit).
  void emit(std::uint32_t node, std::uint32_t bnode, int depth) {
    const BinaryNode& root = b.bnodes[bnode];
    if (root.leaf()) {
      emit_triangles(node, root.begin, root.end, depth);
      return;
    }
    max_depth = std::max(max_depth, depth);
    auto as_item = [&](std::uint32_t id) {
      const BinaryNode& n = b.bnodes[id];
      if (n.leaf() && n.end - n.begin == 1) return Item{true, b.index[n.begin]};
      return Item{false, id};
    };
    Item items[4];
    int num = 0;
    items[num++] = as_item(root.left);
    items[num++] = as_item(root.right);
    while (num < 4) {
      int best = -1;
      double best_area = -1.0;
      for (int i = 0; i < num; ++i) {
        if (items[i].is_triangle) continue;
        const BinaryNode& n = b.bnodes[items[i].id];
        const std::size_t grows = n.leaf() ? n.end - n.begin - 1 : 1;
        if (static_cast<std::size_t>(num) + grows > 4) continue;
        const double area = n.box.half_area();
        if (area > best_area) {
          best_area = area;
          best = i;
        }
      }
      if (best < 0) break;
      const BinaryNode& n = b.bnodes[items[best].id];
      if (n.leaf()) {
        items[best] = Item{true, b.index[n.begin]};
        for (std::size_t i = n.begin + 1; i < n.end; ++i) items[num++] = Item{true, b.index[i]};
      } else {
        const std::uint32_t r = n.right;
        items[best] = as_item(n.left);
        items[num++] = as_item(r);
      }
    }
    std::uint32_t child[4] = {~0u, ~0u, ~0u, ~0u};
    for (int s = 0; s < num; ++s) {  // the child nodes first, side by side in memory
      const Aabb box = box_of(items[s]);
      if (items[s].is_triangle) {
        set_slot(node, s, box, triangle_slot(items[s].id), true);
      } else {
        child[s] = new_node();
        set_slot(node, s, box, child[s], false);
      }
    }
    for (int s = 0; s < num; ++s) {
      if (child[s] != ~0u) emit(child[s], items[s].id, depth + 1);
    }
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
  PLUMB_CHECK(triangles_.size() < kTriangleBit,
              "RayCaster: " << triangles_.size() << " triangles exceed the 31-bit index");
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
  depth_ = 0;
  if (n == 0) return;
  Builder b{settings, {}, {}, {}, {}};
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
  b.bnodes.reserve(2 * n / static_cast<std::size_t>(settings.leaf_size) + 2);
  b.bnodes.emplace_back();
  b.build(0, 0, n, 0);

  nodes_.reserve(b.bnodes.size() / 2 + 2);
  leaf_triangle_.reserve(n);
  Collapser c{b, nodes_, leaf_triangle_};
  c.emit(c.new_node(), 0, 1);
  depth_ = c.max_depth;
  // Cannot fail (see kMaxTreeDepth); the traversal stack relies on it.
  PLUMB_CHECK(depth_ <= kMaxTreeDepth, "RayCaster: BVH depth " << depth_ << " exceeds " << kMaxTreeDepth);
  leaf_vertices_.resize(9 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& tri = triangles_[leaf_triangle_[i]];
    for (std::size_t k = 0; k < 3; ++k) {
      for (std::size_t c3 = 0; c3 < 3; ++c3) {
        leaf_vertices_[9 * i + 3 * k + c3] = vertices_[tri[k]][static_cast<Eigen::Index>(c3)];
      }
    }
  }
}

namespace {

/// The ray as the box test needs it: float origin and inverse direction, and the rows of the near
/// and far planes of each axis chosen by the sign of the direction.
struct BoxRay {
#if defined(PLUMB_RAYCASTER_SSE2)
  __m128 org[3];
  __m128 inv[3];
#else
  float org[3];
  float inv[3];
#endif
  int near_row[3];
  int far_row[3];
};

/// Slab test of a ray against the four child boxes of a node (Kay-Kajiya). Returns a 4-bit mask
/// of the slots hit before `t_far_limit` and writes their entry distances.
inline unsigned test_boxes(const RayCaster::Node& nd, const BoxRay& r, float t_far_limit, float t_near_out[4]) {
  // Ize 2013: scale the far distance so float rounding cannot drop a box the ray touches.
  constexpr float kFarScale = 1.0f + 4.0f * std::numeric_limits<float>::epsilon();
#if defined(PLUMB_RAYCASTER_SSE2)
  const __m128 tx0 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(nd.bounds[r.near_row[0]]), r.org[0]), r.inv[0]);
  const __m128 tx1 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(nd.bounds[r.far_row[0]]), r.org[0]), r.inv[0]);
  const __m128 ty0 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(nd.bounds[r.near_row[1]]), r.org[1]), r.inv[1]);
  const __m128 ty1 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(nd.bounds[r.far_row[1]]), r.org[1]), r.inv[1]);
  const __m128 tz0 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(nd.bounds[r.near_row[2]]), r.org[2]), r.inv[2]);
  const __m128 tz1 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(nd.bounds[r.far_row[2]]), r.org[2]), r.inv[2]);
  const __m128 t0 = _mm_max_ps(_mm_max_ps(tx0, ty0), _mm_max_ps(tz0, _mm_setzero_ps()));
  const __m128 t1 = _mm_mul_ps(_mm_min_ps(_mm_min_ps(tx1, ty1), _mm_min_ps(tz1, _mm_set1_ps(t_far_limit))),
                               _mm_set1_ps(kFarScale));
  _mm_store_ps(t_near_out, t0);
  return static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(t0, t1)));
#else
  unsigned mask = 0;
  for (int s = 0; s < 4; ++s) {
    float t0 = 0.0f;
    float t1 = t_far_limit;
    for (int k = 0; k < 3; ++k) {
      t0 = std::max(t0, (nd.bounds[r.near_row[k]][s] - r.org[k]) * r.inv[k]);
      t1 = std::min(t1, (nd.bounds[r.far_row[k]][s] - r.org[k]) * r.inv[k]);
    }
    t_near_out[s] = t0;
    if (t0 <= t1 * kFarScale) mask |= 1u << s;
  }
  return mask;
#endif
}

/// A float at least as large as a positive double (infinity beyond the float range).
inline float float_above(double x) {
  if (!(x < 3e38)) return std::numeric_limits<float>::infinity();
  return static_cast<float>(x) * (1.0f + 2.0f * std::numeric_limits<float>::epsilon());
}

/// Box test set-up in float: rows of the near and far planes by the sign of each component.
inline BoxRay box_ray_of(const Vector3d& origin, const Vector3d& dir) {
  BoxRay box_ray;
  for (int k = 0; k < 3; ++k) {
    const float o = static_cast<float>(origin[k]);
    const float d = static_cast<float>(dir[k]);
    const float inv = 1.0f / (d != 0.0f ? d : std::copysign(1e-30f, d));
#if defined(PLUMB_RAYCASTER_SSE2)
    box_ray.org[k] = _mm_set1_ps(o);
    box_ray.inv[k] = _mm_set1_ps(inv);
#else
    box_ray.org[k] = o;
    box_ray.inv[k] = inv;
#endif
    box_ray.near_row[k] = 2 * k + (inv >= 0.0f ? 0 : 1);
    box_ray.far_row[k] = 2 * k + (inv >= 0.0f ? 1 : 0);
  }
  return box_ray;
}

/// A ray as the watertight triangle test sees it: axes kx, ky, kz, the shear and the origin.
struct ShearedRay {
  int kx, ky, kz;
  double sx, sy, sz;
  double ox, oy, oz;
};

/// False for a zero direction.
inline bool shear_ray(const Vector3d& origin, const Vector3d& dir, ShearedRay& r) {
  // Watertight test set-up (Woop et al. 2013, sec. 3): the dominant axis becomes z, shear so the
  // ray is the z axis.
  int kz = 0;
  dir.cwiseAbs().maxCoeff(&kz);
  if (dir[kz] == 0.0) return false;
  int kx = (kz + 1) % 3;
  int ky = (kx + 1) % 3;
  if (dir[kz] < 0.0) std::swap(kx, ky);
  r.kx = kx;
  r.ky = ky;
  r.kz = kz;
  r.sx = dir[kx] / dir[kz];
  r.sy = dir[ky] / dir[kz];
  r.sz = 1.0 / dir[kz];
  r.ox = origin[kx];
  r.oy = origin[ky];
  r.oz = origin[kz];
  return true;
}

/// Distance along the ray to the triangle of the 9 coordinates `v` by the exact test (Woop et al.
/// 2013, sec. 3) in double; 0 when the ray misses it.
inline double watertight_distance(const double* v, const ShearedRay& r) {
  const int kx = r.kx, ky = r.ky, kz = r.kz;
  const double ax = v[kx] - r.ox, ay = v[ky] - r.oy, az = v[kz] - r.oz;
  const double bx = v[3 + kx] - r.ox, by = v[3 + ky] - r.oy, bz = v[3 + kz] - r.oz;
  const double cx = v[6 + kx] - r.ox, cy = v[6 + ky] - r.oy, cz = v[6 + kz] - r.oz;
  const double Ax = ax - r.sx * az, Ay = ay - r.sy * az;
  const double Bx = bx - r.sx * bz, By = by - r.sy * bz;
  const double Cx = cx - r.sx * cz, Cy = cy - r.sy * cz;
  const double U = Cx * By - Cy * Bx;
  const double V = Ax * Cy - Ay * Cx;
  const double W = Bx * Ay - By * Ax;
  if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return 0.0;
  const double det = U + V + W;
  if (det == 0.0) return 0.0;
  const double T = U * (r.sz * az) + V * (r.sz * bz) + W * (r.sz * cz);
  return T / det;
}

}  // namespace

template <bool kAnyHit>
RayHit RayCaster::traverse(const Vector3d& origin, const Vector3d& dir, double t_max) const {
  RayHit result;
  if (nodes_.empty()) return result;
  if (!origin.allFinite() || !dir.allFinite() || !(t_max > 0.0)) return result;
  ShearedRay sheared;
  if (!shear_ray(origin, dir, sheared)) return result;
  const BoxRay box_ray = box_ray_of(origin, dir);
  double best = t_max;
  float best_f = float_above(best);
  std::uint32_t best_slot = ~0u;

  std::uint32_t stack_node[kStackSize];
  float stack_t[kStackSize];
  int sp = 0;
  std::uint32_t ni = 0;
  for (;;) {
    const Node& nd = nodes_[ni];
    alignas(16) float t_near[4];
    const unsigned mask = test_boxes(nd, box_ray, best_f, t_near);
    // Triangles first: the exact test (Woop et al. 2013, sec. 3) in double.
    unsigned tri = mask & nd.triangle_mask;
    // Nearest box first, so a hit culls the triangles behind it.
    int order[4];
    int num_tri = 0;
    while (tri != 0) {
      const int s = __builtin_ctz(tri);
      tri &= tri - 1;
      int j = num_tri++;
      while (j > 0 && t_near[order[j - 1]] > t_near[s]) {
        order[j] = order[j - 1];
        --j;
      }
      order[j] = s;
    }
    for (int i = 0; i < num_tri; ++i) {
      const int s = order[i];
      if (t_near[s] > best_f) break;  // behind a hit found in this node
      const std::uint32_t slot = nd.child[s] & ~kTriangleBit;
      const double t = watertight_distance(leaf_vertices_.data() + 9 * static_cast<std::size_t>(slot), sheared);
      if (!(t > 0.0) || !(t < best)) continue;
      best = t;
      best_f = float_above(best);
      best_slot = slot;
      if (kAnyHit) break;
    }
    if (kAnyHit && best_slot != ~0u) break;
    // Then the child nodes, nearest first; the others wait on the stack with their entry distance.
    unsigned inner = mask & ~nd.triangle_mask;
    if (inner != 0) {
      const int s0 = __builtin_ctz(inner);
      inner &= inner - 1;
      if (inner == 0) {  // one child: the common case
        if (t_near[s0] <= best_f) {
          ni = nd.child[s0];
          continue;
        }
      } else {
        int num = 0;
        std::uint32_t child[4];
        float entry[4];
        for (int s = s0;;) {
          if (t_near[s] <= best_f) {
            // Insertion into `child` sorted by decreasing entry distance.
            int j = num++;
            while (j > 0 && entry[j - 1] < t_near[s]) {
              entry[j] = entry[j - 1];
              child[j] = child[j - 1];
              --j;
            }
            entry[j] = t_near[s];
            child[j] = nd.child[s];
          }
          if (inner == 0) break;
          s = __builtin_ctz(inner);
          inner &= inner - 1;
        }
        if (num > 0) {
          for (int i = 0; i + 1 < num; ++i) {
            stack_node[sp] = child[i];
            stack_t[sp] = entry[i];
            ++sp;
          }
          ni = child[num - 1];
          continue;
        }
      }
    }
    // Pop the next node still closer than the best hit.
    bool found = false;
    while (sp > 0) {
      --sp;
      if (stack_t[sp] <= best_f) {
        ni = stack_node[sp];
        found = true;
        break;
      }
    }
    if (!found) break;
  }
  if (best_slot == ~0u) return result;
  return hit_of(best_slot, best, dir);
}

RayHit RayCaster::hit_of(std::uint32_t slot, double range, const Vector3d& dir) const {
  RayHit result;
  const double* v = leaf_vertices_.data() + 9 * static_cast<std::size_t>(slot);
  const Vector3d p0(v[0], v[1], v[2]), p1(v[3], v[4], v[5]), p2(v[6], v[7], v[8]);
  Vector3d n = (p1 - p0).cross(p2 - p0);
  const double len = n.norm();
  n = len > 0.0 ? Vector3d(n / len) : Vector3d(-dir);
  if (n.dot(dir) > 0.0) n = -n;
  result.range = range;
  result.triangle = leaf_triangle_[slot];
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
