// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Template body of KdTree::refit (plumb/search/kdtree.hpp); include that header, not this one.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "plumb/search/kdtree.hpp"

namespace plumb {

template <int Dim>
void KdTree<Dim>::refit(const std::vector<Point>& points, int threads) {
  PLUMB_CHECK(points.size() == num_input_points_, "KdTree::refit: " << points.size()
                                                      << " points given, the tree was built from "
                                                      << num_input_points_);
  PLUMB_CHECK(threads >= 0, "KdTree::refit: threads must be >= 0 (0 = every core), got " << threads);
  std::size_t finite = 0;
  for (const Point& p : points) finite += p.allFinite() ? 1 : 0;
  PLUMB_CHECK(finite == size_, "KdTree::refit: " << finite << " finite points given, the tree holds " << size_);
  constexpr std::size_t R = detail::kKdRecord;
  // Nothing is written before every stored index is known to be finite (the tree stays as it was
  // on a throw). With as many finite points as stored ones, that holds at once when the tree
  // skipped none; otherwise each stored index is looked at.
  if (num_skipped() > 0) {
    for (const Node& node : nodes_) {
      if (node.dim >= 0) continue;
      const std::uint32_t m = node.b - node.a;
      const float* ids = coords_.data() + R * node.a + (R - 1) * m;
      for (std::uint32_t j = 0; j < m; ++j) {
        const std::uint32_t i = leaf_id(ids, j);
        PLUMB_CHECK(points[i].allFinite(),
                    "KdTree::refit: point " << i << " is not finite, it was when the tree was built");
      }
    }
  }
  // The work is cut into subtrees: the nodes at depth kRefitSplitDepth, and the leaves above it.
  // Each is a contiguous run of nodes (depth-first order) whose leaves' points are in a run of
  // their own, so the subtrees are refitted on any thread without sharing a byte; the nodes above
  // them are then combined on this one. Bounds are minima and maxima, exact in any order: the tree
  // is the same for any thread count.
  struct Box {
    float lo[Dim], hi[Dim];
  };
  struct Subtree {
    std::uint32_t first, end;  ///< nodes [first, end)
    Box box;
  };
  std::vector<Subtree> subtrees;
  {
    struct Pending {
      std::uint32_t id;
      int depth;
    };
    std::vector<Pending> todo{{0, 0}};
    while (!todo.empty()) {
      const Pending t = todo.back();
      todo.pop_back();
      const Node& node = nodes_[t.id];
      if (node.dim < 0 || t.depth == kRefitSplitDepth) {
        std::uint32_t last = t.id;  // the subtree's last node: down its right spine
        while (nodes_[last].dim >= 0) last = nodes_[last].a;
        subtrees.push_back(Subtree{t.id, last + 1, Box{}});
        continue;
      }
      todo.push_back(Pending{node.a, t.depth + 1});     // right, taken second
      todo.push_back(Pending{t.id + 1, t.depth + 1});   // left, taken first
    }
  }
  struct Context {
    KdTree* tree;
    const std::vector<Point>* points;
    std::vector<Subtree>* subtrees;
  } context{this, &points, &subtrees};
  detail::kd_parallel_chunks(threads, subtrees.size(), [](void* c, std::size_t s) {
    const Context& ctx = *static_cast<const Context*>(c);
    Subtree& sub = (*ctx.subtrees)[s];
    sub.box = ctx.tree->template refit_subtree<Box>(*ctx.points, sub.first, sub.end);
  }, &context);
  // The nodes above the subtrees, bottom-up as in refit_subtree(), each subtree one box.
  std::vector<Box> stack;
  stack.reserve(kRefitSplitDepth + 2);
  std::size_t next = subtrees.size();  // subtrees in depth-first order; the sweep meets the last first
  for (std::size_t id = nodes_.size(); id-- > 0;) {
    if (next > 0 && id + 1 == subtrees[next - 1].end) {
      --next;
      stack.push_back(subtrees[next].box);
      id = subtrees[next].first;
      continue;
    }
    Node& node = nodes_[id];
    const Box left = stack.back();
    stack.pop_back();
    const Box right = stack.back();
    stack.pop_back();
    stack.push_back(join_children<Box>(node, left, right));
  }
  for (int k = 0; k < Dim; ++k) {
    box_lo_[k] = stack.back().lo[k];
    box_hi_[k] = stack.back().hi[k];
  }
}

template <int Dim>
template <typename Box>
Box KdTree<Dim>::join_children(Node& node, const Box& left, const Box& right) {
  node.lo = left.hi[node.dim];  // the left child's largest coordinate along dim
  node.hi = right.lo[node.dim]; // the right child's smallest
  Box box;
  for (int k = 0; k < Dim; ++k) {
    box.lo[k] = std::min(left.lo[k], right.lo[k]);
    box.hi[k] = std::max(left.hi[k], right.hi[k]);
  }
  return box;
}

template <int Dim>
template <typename Box>
Box KdTree<Dim>::refit_subtree(const std::vector<Point>& points, std::uint32_t first, std::uint32_t end) {
  constexpr std::size_t R = detail::kKdRecord;
  // The leaves' blocks, in storage order (a gather from `points`: the loads of one leaf are
  // independent, so they overlap).
  for (std::uint32_t id = first; id < end; ++id) {
    const Node& node = nodes_[id];
    if (node.dim >= 0) continue;
    const std::uint32_t m = node.b - node.a;
    float* x = coords_.data() + R * node.a;
    const float* ids = x + (R - 1) * m;
    for (std::uint32_t j = 0; j < m; ++j) {
      const Point& p = points[leaf_id(ids, j)];
      for (int k = 0; k < Dim; ++k) x[static_cast<std::size_t>(k) * m + j] = p[k];
    }
  }
  // Bottom-up. The nodes are in depth-first order (a node, its left subtree, its right subtree),
  // so the reverse sweep meets a node's right subtree, then its left one, then the node: with each
  // subtree leaving its box on a stack, a node finds its left child's box on top and its right
  // child's below. The stack holds at most one box per level.
  std::vector<Box> stack;
  stack.reserve(max_depth_ + 2);
  for (std::uint32_t id = end; id-- > first;) {
    Node& node = nodes_[id];
    if (node.dim >= 0) {
      const Box left = stack.back();
      stack.pop_back();
      const Box right = stack.back();
      stack.pop_back();
      stack.push_back(join_children<Box>(node, left, right));
      continue;
    }
    Box box;
    const std::uint32_t m = node.b - node.a;
    const float* x = coords_.data() + R * node.a;
    bool coincide = true;
    for (int k = 0; k < Dim; ++k) {
      const float* row = x + static_cast<std::size_t>(k) * m;
      float l = row[0], h = row[0];
      for (std::uint32_t j = 1; j < m; ++j) {
        l = std::min(l, row[j]);
        h = std::max(h, row[j]);
      }
      box.lo[k] = l;
      box.hi[k] = h;
      coincide = coincide && l == h;
    }
    // A bucket is scanned as one point only while its points coincide.
    if (node.dim == kCoincidentLeaf && !coincide) node.dim = kLeaf;
    stack.push_back(box);
  }
  return stack.back();
}

}  // namespace plumb
