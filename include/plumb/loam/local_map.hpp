// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A bounded local map for LiDAR odometry: points kept in a voxel hash map (at most
///        `max_points_per_voxel` per voxel, so revisited space stops growing), voxels farther than
///        `max_distance` from the robot dropped, and a hard cap on the number of voxels.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Settings of VoxelHashMap.
struct VoxelHashMapSettings {
  double voxel_size = 0.5;          ///< edge of a voxel [m]
  int max_points_per_voxel = 10;    ///< a full voxel ignores further points, >= 1
  double max_distance = 80.0;       ///< prune() drops voxels whose centre is farther than this [m]
  std::size_t max_voxels = 200000;  ///< prune() also drops the farthest voxels beyond this count
  /// prune() also drops voxels that got no new point in this many prune() calls (one per frame in
  /// HybridLio), full ones included, so that the next frames fill them afresh: a map of what was
  /// seen recently, like LeGO-LOAM's window of recent keyframes, instead of everything ever seen
  /// within max_distance (which, on a route that comes back, closes the loop). 0: no age limit.
  std::size_t max_age = 0;
};

/// @brief Points in a voxel hash map (the local maps of HybridLio, pipeline/hybrid_lio.hpp).
/// @note Deterministic: points() lists voxels in the order they were first filled and each voxel's
///       points in insertion order. Not thread-safe for writes.
class VoxelHashMap {
 public:
  /// @throws plumb::Error on non-positive voxel size, max_points_per_voxel or max_distance.
  explicit VoxelHashMap(const VoxelHashMapSettings& settings = {}) : settings_(settings) {
    PLUMB_CHECK(std::isfinite(settings.voxel_size) && settings.voxel_size > 0.0,
                "VoxelHashMap: voxel_size must be > 0, got " << settings.voxel_size);
    PLUMB_CHECK(settings.max_points_per_voxel >= 1,
                "VoxelHashMap: max_points_per_voxel must be >= 1, got " << settings.max_points_per_voxel);
    PLUMB_CHECK(settings.max_distance > 0.0, "VoxelHashMap: max_distance must be > 0, got " << settings.max_distance);
    PLUMB_CHECK(settings.max_voxels >= 1, "VoxelHashMap: max_voxels must be >= 1");
  }

  const VoxelHashMapSettings& settings() const { return settings_; }
  std::size_t num_voxels() const { return index_.size(); }  ///< @brief Voxels holding a point.
  std::size_t num_points() const { return num_points_; }    ///< @brief Points held.
  bool empty() const { return num_points_ == 0; }

  /// @brief Add points [m] (non-finite ones are skipped); a full voxel keeps what it has.
  void insert(const std::vector<Vector3f>& points) {
    for (const Vector3f& p : points) {
      if (!p.allFinite()) continue;
      const Key k = key_of(p);
      auto it = index_.find(k);
      if (it == index_.end()) {
        it = index_.emplace(k, voxels_.size()).first;
        voxels_.push_back({k, {}, generation_});
        voxels_.back().points.reserve(static_cast<std::size_t>(settings_.max_points_per_voxel));
      }
      Voxel& v = voxels_[it->second];
      if (static_cast<int>(v.points.size()) >= settings_.max_points_per_voxel) continue;
      v.points.push_back(p);
      v.touched = generation_;
      ++num_points_;
    }
  }

  /// @brief Drop voxels farther than max_distance from `center` or older than max_age, then the
  ///        farthest ones beyond max_voxels; then start the next age step.
  void prune(const Vector3d& center) {
    const double max_sq = settings_.max_distance * settings_.max_distance;
    const std::uint64_t max_age = settings_.max_age;
    std::vector<std::pair<double, std::size_t>> keep;
    keep.reserve(voxels_.size());
    for (std::size_t i = 0; i < voxels_.size(); ++i) {
      const double d_sq = (center_of(voxels_[i].key) - center).squaredNorm();
      const bool recent = max_age == 0 || generation_ - voxels_[i].touched < max_age;
      if (d_sq <= max_sq && recent) keep.emplace_back(d_sq, i);
    }
    ++generation_;
    if (keep.size() > settings_.max_voxels) {
      std::stable_sort(keep.begin(), keep.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      keep.resize(settings_.max_voxels);
      std::sort(keep.begin(), keep.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
    }
    if (keep.size() == voxels_.size()) return;
    std::vector<Voxel> kept;
    kept.reserve(keep.size());
    index_.clear();
    num_points_ = 0;
    for (const auto& e : keep) {
      index_.emplace(voxels_[e.second].key, kept.size());
      num_points_ += voxels_[e.second].points.size();
      kept.push_back(std::move(voxels_[e.second]));
    }
    voxels_ = std::move(kept);
  }

  /// @brief Every point held, voxel by voxel.
  std::vector<Vector3f> points() const {
    std::vector<Vector3f> out;
    out.reserve(num_points_);
    for (const Voxel& v : voxels_) out.insert(out.end(), v.points.begin(), v.points.end());
    return out;
  }

  /// @brief Remove everything.
  void clear() {
    voxels_.clear();
    index_.clear();
    num_points_ = 0;
    generation_ = 0;
  }

 private:
  struct Key {
    std::int32_t x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      // Teschner et al. 2003 spatial hash.
      return static_cast<std::size_t>((static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.x)) * 73856093u) ^
                                      (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.y)) * 19349669u) ^
                                      (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.z)) * 83492791u));
    }
  };
  struct Voxel {
    Key key;
    std::vector<Vector3f> points;
    std::uint64_t touched = 0;  ///< the age step of the voxel's newest point
  };

  Key key_of(const Vector3f& p) const {
    const double s = settings_.voxel_size;
    auto c = [s](float v) {
      const double f = std::floor(static_cast<double>(v) / s);
      return static_cast<std::int32_t>(std::clamp(f, -2.0e9, 2.0e9));
    };
    return {c(p.x()), c(p.y()), c(p.z())};
  }
  Vector3d center_of(const Key& k) const {
    return (Vector3d(k.x, k.y, k.z) + Vector3d::Constant(0.5)) * settings_.voxel_size;
  }

  VoxelHashMapSettings settings_;
  std::vector<Voxel> voxels_;
  std::unordered_map<Key, std::size_t, KeyHash> index_;
  std::size_t num_points_ = 0;
  std::uint64_t generation_ = 0;  ///< prune() calls so far: the age step that insert() stamps
};

}  // namespace plumb
