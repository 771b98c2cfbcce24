// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief CellIndex: the points of a cloud binned in cubic cells, to take the points inside a box
///        without visiting the whole cloud (a building's BIM cloud around the robot).

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Finite points binned in a regular grid of cubic cells over their bounding box.
///
/// Built in O(n) (a counting sort by cell, which keeps each cell's points in ascending index
/// order); 4 bytes per point plus 4 per cell. When the box would need more cells than
/// `max_cells`, the cells grow until it does not (a stray point far away costs a coarser grid,
/// never memory). Non-finite points are left out of every answer.
class CellIndex {
 public:
  /// @param points the cloud's points; the index refers to them by position and keeps no copy
  /// @param cell_size edge of a cell [m], > 0 (the grid may choose a larger one, see cell_size())
  /// @param max_cells most cells the grid may have (>= 1)
  /// @throws plumb::Error when cell_size is not positive and finite, max_cells is 0 or the
  ///         cloud has more than 2^32 - 1 points
  CellIndex(const std::vector<Vector3f>& points, double cell_size, std::size_t max_cells = std::size_t{1} << 24);

  /// @brief Indices of the finite points inside the closed box [lo, hi], ascending.
  void points_in_box(const std::vector<Vector3f>& points, const Eigen::AlignedBox3d& box,
                     std::vector<std::uint32_t>& out) const;

  /// @brief Number of cells.
  std::size_t num_cells() const { return start_.size() - 1; }
  /// @brief The cell a finite point falls in (points outside bounds() go to the nearest cell).
  std::size_t cell(const Vector3f& p) const;
  /// @brief The box of cell `c` (its points lie in it, up to rounding).
  Eigen::AlignedBox3d cell_box(std::size_t c) const;
  /// @brief The indices of cell `c`'s points, ascending: [first, last).
  const std::uint32_t* cell_begin(std::size_t c) const { return order_.data() + start_[c]; }
  const std::uint32_t* cell_end(std::size_t c) const { return order_.data() + start_[c + 1]; }

  /// @brief Bounding box of the finite points (empty when there are none).
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }
  /// @brief Number of finite points indexed.
  std::size_t size() const { return order_.size(); }
  /// @brief The cells' edge [m].
  double cell_size() const { return cell_; }

 private:
  Eigen::AlignedBox3d bounds_;
  double cell_ = 1.0;
  Eigen::Array3i dims_ = Eigen::Array3i::Zero();
  std::vector<std::uint32_t> start_;  ///< per cell (x fastest), then one past the last: offsets into order_
  std::vector<std::uint32_t> order_;  ///< point indices grouped by cell
  Eigen::Array3i cell_of(const Vector3d& p) const;
};

}  // namespace plumb
