// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief KdTree<Dim>: a static kd-tree over float points for exact k-nearest, nearest and radius
/// queries (nanoflann-style: leaf buckets, widest-dimension splits, incremental box distances).

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/search/neighbors.hpp"

namespace plumb {

namespace detail {
/// std::allocator whose value-less construct() leaves the value uninitialised: a vector resized
/// with it is not zero-filled first (the kd-tree's build writes every slot it reads).
template <typename T>
struct KdUninitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = KdUninitAllocator<U>;
  };
  KdUninitAllocator() = default;
  template <typename U>
  KdUninitAllocator(const KdUninitAllocator<U>& /*other*/) noexcept {}
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
}  // namespace detail

/// @brief Where a KdTree node is cut along its widest dimension.
/// On the benchmark clouds kMean builds a shallower tree (LiDAR density falls
/// with range) and answers kNN/NN queries faster than kMidpoint.
enum class KdTreeSplit {
  kMean,      ///< mean coordinate of the node's points (balanced on uneven density)
  kMidpoint,  ///< middle of the node's tight bounding box (cubic cells)
};

/// @brief Tuning of KdTree construction.
struct KdTreeSettings {
  /// Maximum number of points in a leaf bucket (>= 1). Small buckets prune more, large ones make
  /// a shallower tree and faster builds; 10 (nanoflann's default) is a good choice for 3D kNN with
  /// k <= 20. A bucket whose points all coincide is never split, whatever its size.
  std::size_t leaf_size = 10;
  KdTreeSplit split = KdTreeSplit::kMean;  ///< cut position, see KdTreeSplit
};

/// @brief Static kd-tree over `Dim`-dimensional float points (Dim = 2 or 3).
///
/// The finite input points are copied and reordered so that each leaf's points lie contiguously
/// (coordinates stored per dimension); every stored point keeps its original index, and all
/// queries report original indices into the vector (or cloud) the tree was built from.
///
/// Construction splits a node's points on the widest dimension of their tight bounding box, at
/// the mean coordinate (default; or at the box midpoint, see KdTreeSplit), with a branch-free
/// in-place partition of 16-byte point records (coordinates and index), until at most `leaf_size`
/// points remain or all points of a node coincide; the children's tight boxes (and coordinate
/// sums) take one SIMD pass over their records. Nodes live in one vector in depth-first order
/// (left child next to its parent); each leaf stores its points as one contiguous block (x's,
/// y's, z's, indices), in the order of their input indices, in the buffer the records occupied.
/// O(n log n) time, O(n) memory: 16 bytes per point, and 5-8 per point of nodes.
///
/// Non-finite points (NaN or inf in any coordinate, common in organised LiDAR frames) are skipped
/// when building and never appear in results; size() counts only the indexed points. A tree needs
/// at least one finite point: an empty input, or one with only non-finite points, throws
/// plumb::Error. A query with a non-finite coordinate finds nothing (count 0 / std::nullopt).
///
/// All distances are squared Euclidean distances in float [m^2]. Searches are exact (no
/// approximation factor). Among points at exactly equal distance the one that is returned is
/// unspecified.
/// @note The tree changes only through rebuild() and refit(); every query is const, keeps no shared
///       scratch state, and may be called concurrently from any number of threads.
template <int Dim>
class KdTree {
  static_assert(Dim == 2 || Dim == 3, "KdTree supports Dim = 2 and 3");

 public:
  using Point = Eigen::Matrix<float, Dim, 1>;

  /// @brief Build the tree over a copy of `points`.
  /// @throws plumb::Error when there is no finite point, when settings.leaf_size == 0, or when
  ///         there are 2^32 or more points.
  explicit KdTree(const std::vector<Point>& points, const KdTreeSettings& settings = {});

  /// @brief Build the tree again over `points`, as a new KdTree(points, settings()) would, into
  ///        the memory this one holds (no fresh pages for a tree of about the same size).
  /// @throws plumb::Error as the constructor does, and the tree is then left as it was.
  void rebuild(const std::vector<Point>& points);

  /// @brief Move the stored points to `points` and keep the tree's cells: each node's bounds are
  ///        taken again from the points under it (O(n), no partition or sort).
  ///
  /// For a cloud that deforms a little between uses, such as a building model whose elements are
  /// displaced by centimetres: queries stay exact (a parent's cut may then overlap its sibling's,
  /// which the search allows) and cost about what a rebuilt tree's would while the points move by
  /// less than a leaf cell; they slow down, never err, as they move farther.
  /// @param points the same number of points as the tree was built (or last rebuilt) from, finite
  ///        exactly where those were; index i is the point that was index i.
  /// @param threads threads to work on (0 = every core); the tree is the same for any count.
  /// @throws plumb::Error when the size or the finite points differ, or threads < 0; the tree is
  ///         then left as it was.
  void refit(const std::vector<Point>& points, int threads = 1);

  /// @brief Build the tree over `cloud.points` (Dim = 3 only); indices refer to the cloud.
  template <int D = Dim, typename = std::enable_if_t<D == 3>>
  explicit KdTree(const PointCloud& cloud, const KdTreeSettings& settings = {})
      : KdTree(cloud.points, settings) {}

  /// @brief Number of indexed (finite) points.
  std::size_t size() const { return size_; }
  /// @brief Number of points given to the constructor, finite or not.
  std::size_t num_input_points() const { return num_input_points_; }
  /// @brief Number of input points skipped because a coordinate was not finite.
  std::size_t num_skipped() const { return num_input_points_ - size_; }
  /// @brief Number of tree nodes (inner + leaves).
  std::size_t num_nodes() const { return nodes_.size(); }
  /// @brief Depth of the deepest node (root = 0); about log2(size() / leaf_size) on typical data.
  std::size_t max_depth() const { return max_depth_; }
  /// @brief Settings the tree was built with.
  const KdTreeSettings& settings() const { return settings_; }

  /// @brief The k nearest points, sorted by increasing distance.
  /// @param query the query point; non-finite → no result
  /// @param k number of neighbours wanted; more than size() yields all points
  /// @param indices receives min(k, size()) original indices (resized to the count)
  /// @param sq_dists receives the matching squared distances [m^2]
  /// @return the number of neighbours found: min(k, size()), or 0 for a non-finite query
  std::size_t knn(const Point& query, std::size_t k, std::vector<std::size_t>& indices,
                  std::vector<float>& sq_dists) const;

  /// @brief knn() into caller buffers (no allocation): `indices` and `sq_dists` must hold k values.
  /// @return the count written, as in the vector version.
  std::size_t knn(const Point& query, std::size_t k, std::size_t* indices, float* sq_dists) const;

  /// @brief knn() returning the neighbours as values.
  std::vector<Neighbor> knn(const Point& query, std::size_t k) const;

  /// @brief The k nearest points among those with squared distance <= max_dist_sq [m^2], sorted
  ///        by increasing distance, into caller buffers that hold k values.
  /// @return the count written: fewer than k when fewer points lie within the bound (then every
  ///         other point is farther than max_dist_sq); 0 for a non-finite query or a negative or
  ///         NaN bound. A finite bound prunes from the start, like nearest()'s.
  std::size_t knn(const Point& query, std::size_t k, std::size_t* indices, float* sq_dists,
                  float max_dist_sq) const;

  /// @brief The nearest point whose squared distance is <= max_dist_sq [m^2], if any.
  /// @note A finite max_dist_sq also speeds the search up (it prunes from the start).
  std::optional<Neighbor> nearest(const Point& query,
                                  float max_dist_sq = std::numeric_limits<float>::infinity()) const;

  /// @brief nearest() for each query; an entry without a neighbour within max_dist_sq has
  ///        index kNoNeighbor. Serial; for threads split the queries and call nearest() per thread.
  std::vector<Neighbor> nearest_batch(
      const std::vector<Point>& queries,
      float max_dist_sq = std::numeric_limits<float>::infinity()) const;

  /// @brief All points within distance r [m] of the query (dist_sq <= r * r).
  /// @param r search radius [m]; a negative or NaN r finds nothing,
  ///        r = 0 finds points coinciding with the query, r = inf finds every point
  /// @param sorted sort the result by increasing distance (else tree order)
  /// @return the number of points found (the sizes of `indices` and `sq_dists`)
  std::size_t radius(const Point& query, float r, std::vector<std::size_t>& indices,
                     std::vector<float>& sq_dists, bool sorted = true) const;

  /// @brief radius() returning the neighbours as values.
  std::vector<Neighbor> radius(const Point& query, float r, bool sorted = true) const;

 private:
  /// One tree node, 20 bytes. The left child of an inner node is always the next node.
  struct Node {
    std::uint32_t a;  ///< inner: index of the right child; leaf: first point
    std::uint32_t b;  ///< leaf: one past the last point
    float lo;         ///< inner: largest coordinate along `dim` in the left child
    float hi;         ///< inner: smallest coordinate along `dim` in the right child
    std::int32_t dim; ///< split dimension, or kLeaf / kCoincidentLeaf
  };
  static constexpr std::int32_t kLeaf = -1;            ///< a bucket of points
  static constexpr std::int32_t kCoincidentLeaf = -2;  ///< a bucket whose points all coincide

  /// Squared distance of point j of the leaf block `x` (m points) to q, in dimension order.
  static float leaf_dist(const float* x, std::uint32_t m, std::uint32_t j, const float* q) {
    float d = 0.0f;
    for (int k = 0; k < Dim; ++k) {
      const float t = x[static_cast<std::size_t>(k) * m + j] - q[k];
      d += t * t;
    }
    return d;
  }

  /// Original index of point j of a leaf whose index row starts at `ids` (bits stored as floats).
  static std::uint32_t leaf_id(const float* ids, std::uint32_t j) {
    std::uint32_t id;
    std::memcpy(&id, ids + j, sizeof id);
    return id;
  }

  struct KnnSet;
  struct NnSet;
  struct RadiusSet;
  static constexpr int kMaxStack = 64;  ///< pending cells of the iterative search

  /// refit() cuts the tree into the subtrees at this depth (up to 2^depth) to share them out.
  static constexpr int kRefitSplitDepth = 6;

  void build();
  /// refit() of nodes [first, end), one whole subtree; returns its bounds.
  template <typename Box>
  Box refit_subtree(const std::vector<Point>& points, std::uint32_t first, std::uint32_t end);
  /// An inner node's cuts from its children's bounds; returns the node's bounds.
  template <typename Box>
  static Box join_children(Node& node, const Box& left, const Box& right);
  float root_box_dist(const float* q, float* box_d) const;
  template <typename Set>
  void scan_leaf(const Node& node, const float* q, Set& set) const;
  template <typename Set>
  void search(const float* q, float* box_d, Set& set) const;
  template <typename Set>
  void search_recursive(std::uint32_t node, const float* q, float* box_d, Set& set) const;

  KdTreeSettings settings_;
  std::size_t num_input_points_ = 0;
  std::size_t size_ = 0;            ///< number of stored (finite) points
  /// Leaf blocks: leaf [a, b) holds, from 4 a on, its b - a x's, then y's (, z's), then in the
  /// fourth row the bits of their original indices. During construction: one point record each.
  std::vector<float, detail::KdUninitAllocator<float>> coords_;
  std::vector<Node> nodes_;         ///< depth-first; nodes_[0] is the root
  std::size_t max_depth_ = 0;       ///< depth of the deepest node (root = 0)
  float box_lo_[Dim] = {};          ///< bounding box of all stored points
  float box_hi_[Dim] = {};
};

using KdTree2f = KdTree<2>;
using KdTree3f = KdTree<3>;

}  // namespace plumb

#include "plumb/search/impl/kdtree_impl.hpp"
#include "plumb/search/impl/kdtree_refit_impl.hpp"

#ifndef PLUMB_HEADER_ONLY
namespace plumb {
// KdTree<2> and KdTree<3> are compiled once, in plumb_core (src/search/kdtree.cpp); other Dim values
// (none yet) or PLUMB_HEADER_ONLY instantiate from the header as usual.
extern template class KdTree<2>;
extern template class KdTree<3>;
}  // namespace plumb
#endif
