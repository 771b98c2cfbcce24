// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A bounded local map for LiDAR odometry: points kept in a voxel hash map (at most
///        `max_points_per_voxel` per voxel, so revisited space stops growing), voxels farther than
///        `max_distance` from the robot dropped, and a hard cap on the number of voxels.

#include <cstddef>
#include <cstdint>
#include <vector>

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
///
/// Storage is flat, with no allocation per voxel: each voxel owns a block of max_points_per_voxel
/// points in one array (so that is the memory a voxel takes, however few points it holds), and an
/// open-addressing table maps a voxel's key to its index. prune() compacts the arrays in place,
/// keeping the voxels' order, and rebuilds the table.
class VoxelHashMap {
 public:
  /// @throws plumb::Error on non-positive voxel size, max_points_per_voxel or max_distance.
  explicit VoxelHashMap(const VoxelHashMapSettings& settings = {});

  const VoxelHashMapSettings& settings() const { return settings_; }
  std::size_t num_voxels() const { return keys_.size(); }  ///< @brief Voxels holding a point.
  std::size_t num_points() const { return num_points_; }   ///< @brief Points held.
  bool empty() const { return num_points_ == 0; }

  /// @brief Add points [m] (non-finite ones are skipped); a full voxel keeps what it has.
  void insert(const std::vector<Vector3f>& points);

  /// @brief Drop voxels farther than max_distance from `center` or older than max_age, then the
  ///        farthest ones beyond max_voxels; then start the next age step.
  void prune(const Vector3d& center);

  /// @brief Every point held, voxel by voxel.
  std::vector<Vector3f> points() const;

  /// @brief Remove everything.
  void clear();

 private:
  struct Key {
    std::int32_t x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };

  Key key_of(const Vector3f& p) const;
  Vector3d center_of(const Key& k) const;
  std::size_t home_slot(const Key& k) const;  ///< where k's probe sequence starts in slots_
  std::size_t find_or_add(const Key& k);      ///< the voxel of k, a new empty one if none
  void rebuild_index(unsigned bits);          ///< slots_ with 2^bits entries, every voxel in it

  VoxelHashMapSettings settings_;
  std::size_t block_;                  ///< points per voxel block: max_points_per_voxel
  std::vector<Key> keys_;              ///< per voxel, in first-fill order
  std::vector<std::uint32_t> counts_;  ///< per voxel: points held
  std::vector<std::uint64_t> touched_; ///< per voxel: the age step of its newest point
  std::vector<Vector3f> points_;       ///< voxel v's points at [v * block_, v * block_ + counts_[v])
  std::vector<std::uint32_t> slots_;   ///< linear probing; 0 = empty, else voxel index + 1
  unsigned slot_bits_ = 0;             ///< slots_.size() == 2^slot_bits_
  std::size_t num_points_ = 0;
  std::uint64_t generation_ = 0;  ///< prune() calls so far: the age step that insert() stamps
};

}  // namespace plumb
