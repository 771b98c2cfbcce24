// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Template bodies of plumb/search/kdtree.hpp; include that header, not this one.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "plumb/search/kdtree.hpp"

namespace plumb {

// ---- result collectors ------------------------------------------------------------------------

/// Fixed-capacity sorted insertion array (positions, distances) in caller memory: for the small k
/// of typical queries this beats a heap. `worst` is the pruning bound: infinite until k are held.
template <int Dim>
struct KdTree<Dim>::KnnSet {
  std::size_t* idx;
  float* dist;
  std::size_t k;
  std::size_t count = 0;
  float worst = std::numeric_limits<float>::infinity();

  bool visit(float box_dist) const { return box_dist < worst; }
  void add(float d, std::uint32_t i) {
    if (!(d < worst)) return;
    std::size_t j = count < k ? count++ : k - 1;
    while (j > 0 && dist[j - 1] > d) {
      dist[j] = dist[j - 1];
      idx[j] = idx[j - 1];
      --j;
    }
    dist[j] = d;
    idx[j] = i;
    if (count == k) worst = dist[k - 1];
  }
};

/// Every point with d <= r^2, appended to the caller's vectors (as stored positions).
template <int Dim>
struct KdTree<Dim>::RadiusSet {
  std::vector<std::size_t>* idx;
  std::vector<float>* dist;
  float r_sq;

  bool visit(float box_dist) const { return box_dist <= r_sq; }
  void add(float d, std::uint32_t i) {
    if (d <= r_sq) {
      idx->push_back(i);
      dist->push_back(d);
    }
  }
};

// ---- construction -----------------------------------------------------------------------------

template <int Dim>
KdTree<Dim>::KdTree(const std::vector<Point>& points, const KdTreeSettings& settings)
    : settings_(settings), num_input_points_(points.size()) {
  PLUMB_CHECK(settings.leaf_size >= 1, "KdTree: settings.leaf_size must be >= 1 (got 0)");
  PLUMB_CHECK(points.size() < static_cast<std::size_t>(std::numeric_limits<std::uint32_t>::max()),
              "KdTree: " << points.size() << " points exceed the limit of 2^32 - 1");
  std::size_t n = 0;
  for (const Point& p : points) n += p.allFinite() ? 1 : 0;
  PLUMB_CHECK(n > 0, "KdTree: input has no finite point (" << points.size() << " points given)");

  coords_.resize(static_cast<std::size_t>(Dim) * n);
  ids_.resize(n);
  for (int k = 0; k < Dim; ++k) {
    box_lo_[k] = std::numeric_limits<float>::infinity();
    box_hi_[k] = -std::numeric_limits<float>::infinity();
  }
  std::size_t j = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    if (!p.allFinite()) continue;
    for (int k = 0; k < Dim; ++k) {
      coords_[static_cast<std::size_t>(k) * n + j] = p[k];
      box_lo_[k] = std::min(box_lo_[k], p[k]);
      box_hi_[k] = std::max(box_hi_[k], p[k]);
    }
    ids_[j] = static_cast<std::uint32_t>(i);
    ++j;
  }
  build();
}

template <int Dim>
void KdTree<Dim>::build() {
  const std::size_t n = ids_.size();
  const std::size_t leaf_size = settings_.leaf_size;
  float* c[Dim];
  for (int k = 0; k < Dim; ++k) c[k] = coords_.data() + static_cast<std::size_t>(k) * n;
  std::uint32_t* ids = ids_.data();

  struct Box {
    float lo[Dim];
    float hi[Dim];
  };
  struct Task {
    std::uint32_t begin, end, parent;
    bool is_right;
    Box box;
  };
  Box empty_box;
  for (int k = 0; k < Dim; ++k) {
    empty_box.lo[k] = std::numeric_limits<float>::infinity();
    empty_box.hi[k] = -std::numeric_limits<float>::infinity();
  }

  nodes_.clear();
  nodes_.reserve(2 * (n / std::max<std::size_t>(leaf_size / 2, 1)) + 1);
  std::vector<Task> stack;
  stack.reserve(64);
  Task root{0, static_cast<std::uint32_t>(n), 0, false, {}};
  for (int k = 0; k < Dim; ++k) {
    root.box.lo[k] = box_lo_[k];
    root.box.hi[k] = box_hi_[k];
  }
  stack.push_back(root);

  while (!stack.empty()) {
    const Task t = stack.back();
    stack.pop_back();
    const auto id = static_cast<std::uint32_t>(nodes_.size());
    nodes_.push_back(Node{t.begin, t.end, 0.0f, 0.0f, -1});  // a leaf unless split below
    if (t.is_right) nodes_[t.parent].a = id;

    // Widest dimension of the (tight) bounding box.
    int dim = 0;
    float extent = t.box.hi[0] - t.box.lo[0];
    for (int k = 1; k < Dim; ++k) {
      const float e = t.box.hi[k] - t.box.lo[k];
      if (e > extent) {
        extent = e;
        dim = k;
      }
    }
    if (t.end - t.begin <= leaf_size || !(extent > 0.0f)) continue;  // leaf (or all coincide)

    // Midpoint of the tight box: both sides are non-empty because the box is tight. When the
    // midpoint rounds onto the low end (adjacent floats), split at the high end instead.
    const float lo = t.box.lo[dim];
    const float hi = t.box.hi[dim];
    float split = 0.5f * lo + 0.5f * hi;
    if (!(split > lo)) split = hi;

    // Hoare partition on coordinate < split; the children's boxes accumulate on the way.
    Box left = empty_box;
    Box right = empty_box;
    const float* cd = c[dim];
    auto grow = [&](Box& box, std::uint32_t i) {
      for (int k = 0; k < Dim; ++k) {
        box.lo[k] = std::min(box.lo[k], c[k][i]);
        box.hi[k] = std::max(box.hi[k], c[k][i]);
      }
    };
    std::uint32_t i = t.begin;
    std::uint32_t j = t.end;
    for (;;) {
      while (i < j && cd[i] < split) grow(left, i++);
      while (i < j && !(cd[j - 1] < split)) grow(right, --j);
      if (i >= j) break;
      --j;
      for (int k = 0; k < Dim; ++k) std::swap(c[k][i], c[k][j]);
      std::swap(ids[i], ids[j]);
      grow(left, i++);
      grow(right, j);
    }
    const std::uint32_t mid = i;

    Node& node = nodes_[id];
    node.a = 0;  // right child, patched when it is created
    node.b = 0;
    node.lo = left.hi[dim];
    node.hi = right.lo[dim];
    node.dim = dim;
    stack.push_back(Task{mid, t.end, id, true, right});
    stack.push_back(Task{t.begin, mid, id, false, left});  // popped next: becomes node id + 1
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

// Depth-first search, nearer child first. box_d[k] holds the squared distance along dimension k
// from q to the current cell; entering the farther child replaces one term (incremental box
// distance as in Arya & Mount). The bound is re-summed in dimension order so that it never exceeds
// the float distance of a point inside the cell (see detail::dist_sq).
template <int Dim>
template <typename Set>
void KdTree<Dim>::search(std::uint32_t node_id, const float* q, float* box_d, Set& set) const {
  const Node& node = nodes_[node_id];
  if (node.dim < 0) {
    const std::size_t n = ids_.size();
    const float* c = coords_.data();
    for (std::uint32_t i = node.a; i < node.b; ++i) {
      const float t0 = c[i] - q[0];
      const float t1 = c[n + i] - q[1];
      float d = t0 * t0;
      d += t1 * t1;
      if constexpr (Dim == 3) {
        const float t2 = c[2 * n + i] - q[2];
        d += t2 * t2;
      }
      set.add(d, i);
    }
    return;
  }
  const int dim = node.dim;
  const float diff_lo = q[dim] - node.lo;
  const float diff_hi = q[dim] - node.hi;
  std::uint32_t near_child;
  std::uint32_t far_child;
  float cut;
  if (diff_lo + diff_hi < 0.0f) {  // q is nearer the left side
    near_child = node_id + 1;
    far_child = node.a;
    cut = diff_hi < 0.0f ? diff_hi * diff_hi : 0.0f;
  } else {
    near_child = node.a;
    far_child = node_id + 1;
    cut = diff_lo > 0.0f ? diff_lo * diff_lo : 0.0f;
  }
  search(near_child, q, box_d, set);
  const float saved = box_d[dim];
  const float new_d = std::max(cut, saved);
  box_d[dim] = new_d;
  float bound = 0.0f;
  for (int k = 0; k < Dim; ++k) bound += box_d[k];
  if (set.visit(bound)) search(far_child, q, box_d, set);
  box_d[dim] = saved;
}

template <int Dim>
void KdTree<Dim>::search_nn(std::uint32_t node_id, const float* q, float* box_d, float& best_d,
                            std::uint32_t& best_i) const {
  const Node& node = nodes_[node_id];
  if (node.dim < 0) {
    const std::size_t n = ids_.size();
    const float* c = coords_.data();
    for (std::uint32_t i = node.a; i < node.b; ++i) {
      const float t0 = c[i] - q[0];
      const float t1 = c[n + i] - q[1];
      float d = t0 * t0;
      d += t1 * t1;
      if constexpr (Dim == 3) {
        const float t2 = c[2 * n + i] - q[2];
        d += t2 * t2;
      }
      if (d < best_d) {
        best_d = d;
        best_i = i;
      }
    }
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
  search_nn(near_child, q, box_d, best_d, best_i);
  const float saved = box_d[dim];
  box_d[dim] = std::max(cut, saved);
  float bound = 0.0f;
  for (int k = 0; k < Dim; ++k) bound += box_d[k];
  if (bound < best_d) search_nn(far_child, q, box_d, best_d, best_i);
  box_d[dim] = saved;
}

template <int Dim>
std::size_t KdTree<Dim>::knn(const Point& query, std::size_t k, std::size_t* indices,
                             float* sq_dists) const {
  k = std::min(k, size());
  if (k == 0 || !query.allFinite()) return 0;
  KnnSet set{indices, sq_dists, k};
  float box_d[Dim];
  root_box_dist(query.data(), box_d);
  search(0, query.data(), box_d, set);
  for (std::size_t i = 0; i < set.count; ++i) indices[i] = ids_[indices[i]];
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
  if (!query.allFinite()) return std::nullopt;
  // Accept d <= max_dist_sq: the search keeps d < best_d, so start just above the limit.
  float best_d = std::nextafter(max_dist_sq, std::numeric_limits<float>::infinity());
  std::uint32_t best_i = std::numeric_limits<std::uint32_t>::max();
  float box_d[Dim];
  const float bound = root_box_dist(query.data(), box_d);
  if (!(bound < best_d)) return std::nullopt;
  search_nn(0, query.data(), box_d, best_d, best_i);
  if (best_i == std::numeric_limits<std::uint32_t>::max()) return std::nullopt;
  return Neighbor{ids_[best_i], best_d};
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
  if (set.visit(bound)) search(0, query.data(), box_d, set);
  const std::size_t count = indices.size();
  if (sorted && count > 1) {
    std::vector<Neighbor> tmp(count);
    for (std::size_t i = 0; i < count; ++i) tmp[i] = {ids_[indices[i]], sq_dists[i]};
    std::sort(tmp.begin(), tmp.end(), [](const Neighbor& x, const Neighbor& y) {
      return x.dist_sq < y.dist_sq || (x.dist_sq == y.dist_sq && x.index < y.index);
    });
    for (std::size_t i = 0; i < count; ++i) {
      indices[i] = tmp[i].index;
      sq_dists[i] = tmp[i].dist_sq;
    }
  } else {
    for (std::size_t i = 0; i < count; ++i) indices[i] = ids_[indices[i]];
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
