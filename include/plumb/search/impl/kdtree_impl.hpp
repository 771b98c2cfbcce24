// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Template bodies of plumb/search/kdtree.hpp; include that header, not this one. The non-template
// helpers they call are compiled in src/search/kdtree.cpp.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "plumb/search/kdtree.hpp"

namespace plumb {

// ---- result collectors ------------------------------------------------------------------------

namespace detail {

/// The next float above a non-negative v (v itself when infinite): turns "d <= v" into the
/// collectors' strict "d < bound".
float next_float_up(float v);

/// Insert (d, i) into the first `count` entries of dist / idx, kept ascending by distance and at
/// most k >= 1 long: a full array drops its last entry. The caller has checked d against the last.
inline void insert_k_best(float* dist, std::size_t* idx, std::size_t& count, std::size_t k, float d,
                          std::size_t i) {
  std::size_t j = count < k ? count++ : k - 1;
  while (j > 0 && dist[j - 1] > d) {
    dist[j] = dist[j - 1];
    idx[j] = idx[j - 1];
    --j;
  }
  dist[j] = d;
  idx[j] = i;
}

}  // namespace detail

/// Fixed-capacity sorted insertion array (positions, distances) in caller memory: for the small k
/// of typical queries this beats a heap. `worst` is the pruning bound: infinite until k are held.
template <int Dim>
struct KdTree<Dim>::KnnSet {
  std::size_t* idx;
  float* dist;
  std::size_t k;
  std::size_t count = 0;
  float worst = std::numeric_limits<float>::infinity();

  static constexpr bool kFastFirstLeaf = false;
  static constexpr bool kStrictBound = true;  ///< add() takes exactly d < bound()
  float bound() const { return worst; }
  bool visit(float box_dist) const { return box_dist < worst; }
  bool accepts(float d) const { return d < worst; }
  void add(float d, std::uint32_t i) {
    if (!(d < worst)) return;
    detail::insert_k_best(dist, idx, count, k, d, i);
    if (count == k) worst = dist[k - 1];
  }
};

/// The single nearest point with d < best_d (best_d starts at the caller's limit).
template <int Dim>
struct KdTree<Dim>::NnSet {
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  float best_d = std::numeric_limits<float>::infinity();
  std::uint32_t best_i = kNone;

  bool visit(float box_dist) const { return box_dist < best_d; }
  bool accepts(float d) const { return d < best_d; }
  static constexpr bool kFastFirstLeaf = true;
  static constexpr bool kStrictBound = true;  ///< add() takes exactly d < bound()
  float bound() const { return best_d; }
  bool done() const { return !(best_d > 0.0f); }  // distance 0 found: nothing can beat it
  void add(float d, std::uint32_t i) {
    if (d < best_d) {
      best_d = d;
      best_i = i;
    }
  }
};

/// Every point with d <= r^2, appended to the caller's vectors (original indices).
template <int Dim>
struct KdTree<Dim>::RadiusSet {
  std::vector<std::size_t>* idx;
  std::vector<float>* dist;
  float r_sq;

  bool visit(float box_dist) const { return box_dist <= r_sq; }
  bool accepts(float d) const { return d <= r_sq; }
  static constexpr bool kFastFirstLeaf = false;
  static constexpr bool kStrictBound = false;  ///< takes d <= r_sq: scanned one by one
  static bool done() { return false; }
  void add(float d, std::uint32_t i) {
    if (d <= r_sq) {
      idx->push_back(i);
      dist->push_back(d);
    }
  }
};

// ---- construction -----------------------------------------------------------------------------

namespace detail {

/// Floats per point record during construction: up to three coordinates, then the point's
/// original index (its bits) in the last lane.
constexpr int kKdRecord = 4;

inline void kd_set_record_id(float* record, std::uint32_t id) { std::memcpy(record + kKdRecord - 1, &id, sizeof id); }
inline std::uint32_t kd_record_id(const float* record) {
  std::uint32_t id;
  std::memcpy(&id, record + kKdRecord - 1, sizeof id);
  return id;
}

/// Tight [lo, hi] and the sum of the coordinates of records [begin, end) (lanes 0..2; the index
/// lane is left out).
void kd_record_box(const float* records, std::uint32_t begin, std::uint32_t end, float* lo, float* hi, float* sum);

/// Branch-free in-place partition of records [begin, end) on coordinate `dim` < split: the left
/// ones first. Returns the first right slot.
std::uint32_t kd_partition_records(float* records, int dim, float split, std::uint32_t begin, std::uint32_t end);

/// body(context, c) for every c in [0, chunks), on up to `threads` threads (core/parallel.hpp's
/// parallel_chunks, behind a plain function pointer so that this header needs no <functional>).
void kd_parallel_chunks(int threads, std::size_t chunks, void (*body)(void*, std::size_t), void* context);

/// Bounds of a node's points under construction.
template <int Dim>
struct KdBuildBox {
  float lo[kKdRecord - 1];
  float hi[kKdRecord - 1];
  float sum[kKdRecord - 1];  // of the coordinates, for the mean split
};

template <int Dim>
inline KdBuildBox<Dim> kd_box(const float* records, std::uint32_t begin, std::uint32_t end) {
  KdBuildBox<Dim> box;
  kd_record_box(records, begin, end, box.lo, box.hi, box.sum);
  return box;
}

/// Widest dimension of the (tight) bounding box, and its extent.
template <int Dim>
inline int kd_widest_dim(const KdBuildBox<Dim>& box, float& extent) {
  int dim = 0;
  extent = box.hi[0] - box.lo[0];
  for (int k = 1; k < Dim; ++k) {
    const float e = box.hi[k] - box.lo[k];
    if (e > extent) {
      extent = e;
      dim = k;
    }
  }
  return dim;
}

}  // namespace detail

template <int Dim>
KdTree<Dim>::KdTree(const std::vector<Point>& points, const KdTreeSettings& settings) : settings_(settings) {
  rebuild(points);
}

template <int Dim>
void KdTree<Dim>::rebuild(const std::vector<Point>& points) {
  PLUMB_CHECK(settings_.leaf_size >= 1, "KdTree: settings.leaf_size must be >= 1 (got 0)");
  PLUMB_CHECK(points.size() < static_cast<std::size_t>(std::numeric_limits<std::uint32_t>::max()),
              "KdTree: " << points.size() << " points exceed the limit of 2^32 - 1");
  std::size_t n = 0;
  for (const Point& p : points) n += p.allFinite() ? 1 : 0;
  PLUMB_CHECK(n > 0, "KdTree: input has no finite point (" << points.size() << " points given)");
  num_input_points_ = points.size();

  // Each finite point as one record of four floats: its coordinates, then its index's bits in the
  // last lane (see detail::kKdRecord). The build partitions whole records, and turns the buffer
  // into leaf blocks at the end.
  size_ = n;
  // (+ 4 floats of padding: a leaf scan's last four-wide load may run past the last block)
  coords_.resize(static_cast<std::size_t>(detail::kKdRecord) * n + 4);
  std::fill(coords_.end() - 4, coords_.end(), 0.0f);
  std::size_t j = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    if (!p.allFinite()) continue;
    float* r = coords_.data() + detail::kKdRecord * j;
    for (int k = 0; k < Dim; ++k) r[k] = p[k];
    for (int k = Dim; k < detail::kKdRecord - 1; ++k) r[k] = 0.0f;
    detail::kd_set_record_id(r, static_cast<std::uint32_t>(i));
    ++j;
  }
  build();
}

template <int Dim>
void KdTree<Dim>::build() {
  const std::size_t n = size_;
  float* records = coords_.data();
  const std::size_t leaf_size = settings_.leaf_size;
  constexpr std::size_t R = detail::kKdRecord;
  // One buffer of records: a node's partition reorders its range in place, so its children find
  // their records in the two halves.

  using Box = detail::KdBuildBox<Dim>;
  struct Task {
    std::uint32_t begin, end, parent, depth;
    bool is_right;
    Box box;
  };

  nodes_.clear();
  nodes_.reserve(2 * (n / std::max<std::size_t>(leaf_size / 2, 1)) + 1);
  // Leaf-blocked layout, written as each leaf is made (its records are still in cache): the points
  // of leaf [a, b) occupy coords_[4 a, 4 b), first their m = b - a x coordinates, then the y's
  // (then the z's), then their indices, so a leaf scan reads one contiguous block. No other node
  // reads that range once the leaf is reached, so the block replaces the leaf's records. The
  // points go in the order of their input indices: the in-place partition scrambles them, and
  // queries run about 15 % faster over leaves whose points follow the input (scan) order.
  std::vector<float> scratch;
  std::vector<std::uint64_t> order;  // index << 32 | slot in the leaf
  auto finish_leaf = [&](const Task& t) {
    const std::size_t m = t.end - t.begin;
    float* block = records + R * t.begin;
    scratch.assign(block, block + R * m);
    order.resize(m);
    for (std::size_t j = 0; j < m; ++j) {
      order[j] = static_cast<std::uint64_t>(detail::kd_record_id(scratch.data() + R * j)) << 32 | j;
    }
    if (m <= 32) {  // insertion sort: a leaf holds a few points
      for (std::size_t j = 1; j < m; ++j) {
        const std::uint64_t key = order[j];
        std::size_t i = j;
        for (; i > 0 && order[i - 1] > key; --i) order[i] = order[i - 1];
        order[i] = key;
      }
    } else {
      std::sort(order.begin(), order.end());
    }
    for (std::size_t j = 0; j < m; ++j) {
      const float* rec = scratch.data() + R * (order[j] & 0xffffffffu);
      for (int k = 0; k < Dim; ++k) block[static_cast<std::size_t>(k) * m + j] = rec[k];
      std::memcpy(block + (R - 1) * m + j, rec + R - 1, sizeof(float));  // the index's bits, as they are
    }
  };
  std::vector<Task> stack;
  stack.reserve(64);
  Task root{0, static_cast<std::uint32_t>(n), 0, 0, false,
            detail::kd_box<Dim>(records, 0, static_cast<std::uint32_t>(n))};
  max_depth_ = 0;
  for (int k = 0; k < Dim; ++k) {
    box_lo_[k] = root.box.lo[k];
    box_hi_[k] = root.box.hi[k];
  }
  stack.push_back(root);

  while (!stack.empty()) {
    const Task t = stack.back();
    stack.pop_back();
    const auto id = static_cast<std::uint32_t>(nodes_.size());
    max_depth_ = std::max<std::size_t>(max_depth_, t.depth);
    nodes_.push_back(Node{t.begin, t.end, 0.0f, 0.0f, kLeaf});  // a leaf unless split below
    if (t.is_right) nodes_[t.parent].a = id;
    if (t.end - t.begin <= leaf_size) {  // a leaf
      finish_leaf(t);
      continue;
    }

    float extent = 0.0f;
    const int dim = detail::kd_widest_dim<Dim>(t.box, extent);
    if (!(extent > 0.0f)) {  // all points coincide: one bucket, whatever its size
      nodes_[id].dim = kCoincidentLeaf;
      finish_leaf(t);
      continue;
    }

    // Mean (or midpoint) along dim lies in [lo, hi] of the tight box, so "coordinate < split"
    // leaves both sides non-empty unless split rounds onto lo (or past hi): then split at hi.
    const float lo = t.box.lo[dim];
    const float hi = t.box.hi[dim];
    float split = 0.5f * lo + 0.5f * hi;
    if (settings_.split == KdTreeSplit::kMean) {
      split = t.box.sum[dim] / static_cast<float>(t.end - t.begin);
    }
    if (!(split > lo) || split > hi) split = hi;

    const std::uint32_t mid = detail::kd_partition_records(records, dim, split, t.begin, t.end);
    const Box left = detail::kd_box<Dim>(records, t.begin, mid);
    const Box right = detail::kd_box<Dim>(records, mid, t.end);
    Node& node = nodes_[id];
    node.a = 0;  // right child, patched when it is created
    node.b = 0;
    node.lo = left.hi[dim];
    node.hi = right.lo[dim];
    node.dim = dim;
    stack.push_back(Task{mid, t.end, id, t.depth + 1, true, right});
    // popped next: becomes node id + 1
    stack.push_back(Task{t.begin, mid, id, t.depth + 1, false, left});
  }
}

// ---- queries ----------------------------------------------------------------------------------

/// Squared distance from q to the bounding box of all points, with its per-dimension terms.
template <int Dim>
float KdTree<Dim>::root_box_dist(const float* q, float* box_d) const {
  float total = 0.0f;
  for (int k = 0; k < Dim; ++k) {
    float t = 0.0f;
    if (q[k] < box_lo_[k]) t = box_lo_[k] - q[k];
    if (q[k] > box_hi_[k]) t = q[k] - box_hi_[k];
    box_d[k] = t * t;
    total += box_d[k];
  }
  return total;
}

// Scan one leaf into the set. A coincident leaf has one distance for all of its points, so it stops
// as soon as the set takes no more (a bucket of thousands of repeated returns costs O(k)).
template <int Dim>
template <typename Set>
void KdTree<Dim>::scan_leaf(const Node& node, const float* q, Set& set) const {
  const std::uint32_t m = node.b - node.a;
  const float* x = coords_.data() + static_cast<std::size_t>(detail::kKdRecord) * node.a;
  const float* id = x + static_cast<std::size_t>(detail::kKdRecord - 1) * m;  // the indices' row
  if (node.dim == kCoincidentLeaf) {
    const float d = leaf_dist(x, m, 0, q);
    for (std::uint32_t j = 0; j < m && set.accepts(d); ++j) set.add(d, leaf_id(id, j));
    return;
  }
  std::uint32_t j = 0;
#if defined(__SSE2__)
  if constexpr (Set::kStrictBound) {
    // Four points per step, each lane summing exactly as leaf_dist does (bit-identical distances);
    // only lanes below the set's bound reach add(), in order. The bound only shrinks, so a lane
    // masked out here would have been rejected by add() too: the result is that of the plain
    // loop, with one branch per four points (rarely taken once a kNN set is full) instead of one
    // per point.
    __m128 qv[Dim];
    for (int k = 0; k < Dim; ++k) qv[k] = _mm_set1_ps(q[k]);
    for (; j + 4 <= m; j += 4) {
      __m128 d4 = _mm_setzero_ps();
      for (int k = 0; k < Dim; ++k) {
        const __m128 t = _mm_sub_ps(_mm_loadu_ps(x + static_cast<std::size_t>(k) * m + j), qv[k]);
        d4 = _mm_add_ps(d4, _mm_mul_ps(t, t));
      }
      const int mask = _mm_movemask_ps(_mm_cmplt_ps(d4, _mm_set1_ps(set.bound())));
      if (mask == 0) continue;
      alignas(16) float d[4];
      _mm_store_ps(d, d4);
      for (std::uint32_t lane = 0; lane < 4; ++lane) {
        if (mask & (1 << lane)) set.add(d[lane], leaf_id(id, j + lane));
      }
    }
    if (j < m) {
      // The last 1-3 points the same way: the loads run on into the next row of the block (or
      // the padding after the last block); those lanes are zeroed before any arithmetic and
      // masked out after it.
      const std::uint32_t rest = m - j;
      const __m128 valid = _mm_castsi128_ps(_mm_set_epi32(0, rest > 2 ? -1 : 0, rest > 1 ? -1 : 0, -1));
      __m128 d4 = _mm_setzero_ps();
      for (int k = 0; k < Dim; ++k) {
        const __m128 c = _mm_and_ps(_mm_loadu_ps(x + static_cast<std::size_t>(k) * m + j), valid);
        const __m128 t = _mm_sub_ps(c, qv[k]);
        d4 = _mm_add_ps(d4, _mm_mul_ps(t, t));
      }
      const int mask = _mm_movemask_ps(_mm_cmplt_ps(d4, _mm_set1_ps(set.bound()))) & ((1 << rest) - 1);
      if (mask != 0) {
        alignas(16) float d[4];
        _mm_store_ps(d, d4);
        for (std::uint32_t lane = 0; lane < rest; ++lane) {
          if (mask & (1 << lane)) set.add(d[lane], leaf_id(id, j + lane));
        }
      }
      j = m;
    }
  }
#endif
  for (; j < m; ++j) set.add(leaf_dist(x, m, j, q), leaf_id(id, j));
}

// Depth-first search, nearer child first. box_d[k] holds the squared distance along dimension k
// from q to the current cell; entering the farther child replaces one term (incremental box
// distance as in Arya & Mount). The bound is re-summed in dimension order so that it never exceeds
// the float distance of a point inside the cell (see detail::dist_sq).
//
// Iterative: the descent goes to the nearer child and pushes the farther one with its bound and
// box terms; pending cells are popped (LIFO, the same order as recursion) and skipped when the
// bound no longer beats the set. The stack holds at most one entry per level: trees deeper than
// kMaxStack (only from pathological, exponentially spaced data) use the recursive variant.
template <int Dim>
template <typename Set>
void KdTree<Dim>::search(const float* q, float* box_d, Set& set) const {
  if (max_depth_ >= kMaxStack) {
    search_recursive(0, q, box_d, set);
    return;
  }
  struct Pending {
    std::uint32_t node;
    float bound;
    float box_d[Dim];
  };
  const Node* nodes = nodes_.data();
  // Nearest-point queries descend first without box bookkeeping, recording only the path. Most
  // queries of a cloud's own points end there (distance 0 in the first leaf); otherwise the
  // pending far children are rebuilt from the path exactly as the bookkeeping descent pushes them.
  std::uint32_t path[kMaxStack];
  int depth = 0;
  std::uint32_t node_id = 0;
  if constexpr (Set::kFastFirstLeaf) {
    while (nodes[node_id].dim >= 0) {
      const Node& node = nodes[node_id];
      path[depth++] = node_id;
      const float x = q[node.dim];
      node_id = (x - node.lo) + (x - node.hi) >= 0.0f ? node.a : node_id + 1;
    }
    scan_leaf(nodes[node_id], q, set);
    if (set.done()) return;
  }

  Pending stack[kMaxStack];
  int top = 0;
  // Branch-free step: the nearer child is next, the farther one is pushed (and dropped at once
  // when its bound cannot beat the set). The farther child's slab lies beyond its boundary, at
  // distance max(q - lo, 0) on the left or max(hi - q, 0) on the right: clamped, because after a
  // refit() a cut may overlap its sibling (lo > hi) and q may lie inside both slabs. Returns the
  // nearer child.
  auto step = [&](std::uint32_t id) {
    const Node& node = nodes[id];
    const int dim = node.dim;
    const float diff_lo = q[dim] - node.lo;
    const float diff_hi = q[dim] - node.hi;
    const bool go_right = diff_lo + diff_hi >= 0.0f;
    const std::uint32_t left_child = id + 1;
    const std::uint32_t near_child = go_right ? node.a : left_child;
    const std::uint32_t far_child = go_right ? left_child : node.a;
    const float t = go_right ? std::max(diff_lo, 0.0f) : std::min(diff_hi, 0.0f);
    const float cut = t * t;
    Pending& p = stack[top];
    float far_bound = 0.0f;
    for (int k = 0; k < Dim; ++k) {
      p.box_d[k] = k == dim ? std::max(cut, box_d[k]) : box_d[k];
      far_bound += p.box_d[k];
    }
    p.node = far_child;
    p.bound = far_bound;
    top += set.visit(far_bound) ? 1 : 0;
    return near_child;
  };
  for (int i = 0; i < depth; ++i) step(path[i]);
  bool at_root = !Set::kFastFirstLeaf;  // otherwise the first leaf is done: pop
  for (;;) {
    for (; !at_root;) {
      if (top == 0) return;
      const Pending& p = stack[--top];
      if (!set.visit(p.bound)) continue;
      node_id = p.node;
      for (int k = 0; k < Dim; ++k) box_d[k] = p.box_d[k];
      break;
    }
    at_root = false;
    while (nodes[node_id].dim >= 0) node_id = step(node_id);
    scan_leaf(nodes[node_id], q, set);
  }
}

template <int Dim>
template <typename Set>
void KdTree<Dim>::search_recursive(std::uint32_t node_id, const float* q, float* box_d,
                                   Set& set) const {
  const Node& node = nodes_[node_id];
  if (node.dim < 0) {
    scan_leaf(node, q, set);
    return;
  }
  const int dim = node.dim;
  const float diff_lo = q[dim] - node.lo;
  const float diff_hi = q[dim] - node.hi;
  std::uint32_t near_child;
  std::uint32_t far_child;
  float cut;
  if (diff_lo + diff_hi < 0.0f) {
    near_child = node_id + 1;
    far_child = node.a;
    cut = diff_hi < 0.0f ? diff_hi * diff_hi : 0.0f;
  } else {
    near_child = node.a;
    far_child = node_id + 1;
    cut = diff_lo > 0.0f ? diff_lo * diff_lo : 0.0f;
  }
  search_recursive(near_child, q, box_d, set);
  const float saved = box_d[dim];
  box_d[dim] = std::max(cut, saved);
  float bound = 0.0f;
  for (int k = 0; k < Dim; ++k) bound += box_d[k];
  if (set.visit(bound)) search_recursive(far_child, q, box_d, set);
  box_d[dim] = saved;
}

template <int Dim>
std::size_t KdTree<Dim>::knn(const Point& query, std::size_t k, std::size_t* indices,
                             float* sq_dists) const {
  return knn(query, k, indices, sq_dists, std::numeric_limits<float>::infinity());
}

template <int Dim>
std::size_t KdTree<Dim>::knn(const Point& query, std::size_t k, std::size_t* indices, float* sq_dists,
                             float max_dist_sq) const {
  k = std::min(k, size());
  if (k == 0 || !query.allFinite() || !(max_dist_sq >= 0.0f)) return 0;
  KnnSet set{indices, sq_dists, k};
  // The set keeps d < worst: start one float above the limit so that d == max_dist_sq counts.
  set.worst = detail::next_float_up(max_dist_sq);
  float box_d[Dim];
  if (!set.visit(root_box_dist(query.data(), box_d))) return 0;
  search(query.data(), box_d, set);
  return set.count;
}

template <int Dim>
std::size_t KdTree<Dim>::knn(const Point& query, std::size_t k, std::vector<std::size_t>& indices,
                             std::vector<float>& sq_dists) const {
  k = std::min(k, size());
  indices.resize(k);
  sq_dists.resize(k);
  const std::size_t count = knn(query, k, indices.data(), sq_dists.data());
  indices.resize(count);
  sq_dists.resize(count);
  return count;
}

template <int Dim>
std::vector<Neighbor> KdTree<Dim>::knn(const Point& query, std::size_t k) const {
  std::vector<std::size_t> idx;
  std::vector<float> d;
  knn(query, k, idx, d);
  std::vector<Neighbor> out(idx.size());
  for (std::size_t i = 0; i < idx.size(); ++i) out[i] = {idx[i], d[i]};
  return out;
}

template <int Dim>
std::optional<Neighbor> KdTree<Dim>::nearest(const Point& query, float max_dist_sq) const {
  if (!query.allFinite() || !(max_dist_sq >= 0.0f)) return std::nullopt;
  // Accept d <= max_dist_sq: the set keeps d < best_d, so start one float above the limit.
  NnSet set;
  set.best_d = detail::next_float_up(max_dist_sq);
  float box_d[Dim];
  const float bound = root_box_dist(query.data(), box_d);
  if (!set.visit(bound)) return std::nullopt;
  search(query.data(), box_d, set);
  if (set.best_i == NnSet::kNone) return std::nullopt;
  return Neighbor{set.best_i, set.best_d};
}

template <int Dim>
std::vector<Neighbor> KdTree<Dim>::nearest_batch(const std::vector<Point>& queries,
                                                 float max_dist_sq) const {
  std::vector<Neighbor> out(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    if (auto nb = nearest(queries[i], max_dist_sq)) out[i] = *nb;
  }
  return out;
}

template <int Dim>
std::size_t KdTree<Dim>::radius(const Point& query, float r, std::vector<std::size_t>& indices,
                                std::vector<float>& sq_dists, bool sorted) const {
  indices.clear();
  sq_dists.clear();
  if (!query.allFinite() || !(r >= 0.0f)) return 0;
  RadiusSet set{&indices, &sq_dists, r * r};
  float box_d[Dim];
  const float bound = root_box_dist(query.data(), box_d);
  if (set.visit(bound)) search(query.data(), box_d, set);
  const std::size_t count = indices.size();
  if (sorted && count > 1) {
    std::vector<Neighbor> tmp(count);
    for (std::size_t i = 0; i < count; ++i) tmp[i] = {indices[i], sq_dists[i]};
    std::sort(tmp.begin(), tmp.end(), [](const Neighbor& x, const Neighbor& y) {
      return x.dist_sq < y.dist_sq || (x.dist_sq == y.dist_sq && x.index < y.index);
    });
    for (std::size_t i = 0; i < count; ++i) {
      indices[i] = tmp[i].index;
      sq_dists[i] = tmp[i].dist_sq;
    }
  }
  return count;
}

template <int Dim>
std::vector<Neighbor> KdTree<Dim>::radius(const Point& query, float r, bool sorted) const {
  std::vector<std::size_t> idx;
  std::vector<float> d;
  radius(query, r, idx, d, sorted);
  std::vector<Neighbor> out(idx.size());
  for (std::size_t i = 0; i < idx.size(); ++i) out[i] = {idx[i], d[i]};
  return out;
}

}  // namespace plumb
