// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/search/cell_index.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "plumb/core/error.hpp"

namespace plumb {

CellIndex::CellIndex(const std::vector<Vector3f>& points, double cell_size, std::size_t max_cells) {
  PLUMB_CHECK(cell_size > 0.0 && std::isfinite(cell_size), "CellIndex: cell_size must be positive, got " << cell_size);
  PLUMB_CHECK(max_cells >= 1, "CellIndex: max_cells must be >= 1");
  PLUMB_CHECK(points.size() < std::numeric_limits<std::uint32_t>::max(),
              "CellIndex: " << points.size() << " points are more than 32-bit indices hold");
  for (const Vector3f& p : points) {
    if (p.allFinite()) bounds_.extend(p.cast<double>());
  }
  if (bounds_.isEmpty()) {
    start_.assign(1, 0);
    return;
  }
  cell_ = cell_size;
  const Eigen::Array3d extent = bounds_.sizes().array();
  for (;;) {
    const Eigen::Array3d d = (extent / cell_).floor() + 1.0;
    if (d.prod() <= static_cast<double>(max_cells)) {
      dims_ = d.cast<int>();
      break;
    }
    cell_ *= 2.0;
  }
  const auto cells = static_cast<std::size_t>(dims_.prod());
  std::vector<std::uint32_t> cell_id(points.size(), std::numeric_limits<std::uint32_t>::max());
  start_.assign(cells + 1, 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    const Eigen::Array3i c = cell_of(points[i].cast<double>());
    cell_id[i] = static_cast<std::uint32_t>(c(0) + dims_(0) * (c(1) + dims_(1) * c(2)));
    ++start_[cell_id[i] + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  order_.resize(start_[cells]);
  std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (cell_id[i] != std::numeric_limits<std::uint32_t>::max()) order_[next[cell_id[i]]++] = static_cast<std::uint32_t>(i);
  }
}

Eigen::Array3i CellIndex::cell_of(const Vector3d& p) const {
  const Eigen::Array3d f = ((p - bounds_.min()).array() / cell_).floor();
  return f.max(0.0).min((dims_ - 1).cast<double>()).cast<int>();
}

std::size_t CellIndex::cell(const Vector3f& p) const {
  if (order_.empty()) return 0;
  const Eigen::Array3i c = cell_of(p.cast<double>());
  return static_cast<std::size_t>(c(0) + dims_(0) * (c(1) + dims_(1) * c(2)));
}

Eigen::AlignedBox3d CellIndex::cell_box(std::size_t c) const {
  if (order_.empty()) return {};
  const auto i = static_cast<int>(c);
  const Eigen::Array3d cell(i % dims_(0), (i / dims_(0)) % dims_(1), i / (dims_(0) * dims_(1)));
  const Vector3d lo = bounds_.min() + (cell * cell_).matrix();
  return {lo, lo + Vector3d::Constant(cell_)};
}

void CellIndex::points_in_box(const std::vector<Vector3f>& points, const Eigen::AlignedBox3d& box,
                              std::vector<std::uint32_t>& out) const {
  out.clear();
  const Eigen::AlignedBox3d b = box.intersection(bounds_);
  if (b.isEmpty() || order_.empty()) return;
  const Eigen::Array3i lo = cell_of(b.min()), hi = cell_of(b.max());
  for (int z = lo(2); z <= hi(2); ++z) {
    for (int y = lo(1); y <= hi(1); ++y) {
      const auto row = static_cast<std::size_t>(dims_(0) * (y + dims_(1) * z));
      for (std::uint32_t k = start_[row + lo(0)]; k < start_[row + hi(0) + 1]; ++k) {
        const std::uint32_t i = order_[k];
        if (box.contains(points[i].cast<double>())) out.push_back(i);
      }
    }
  }
  std::sort(out.begin(), out.end());
}

}  // namespace plumb
