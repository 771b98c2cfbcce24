// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/loam/local_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "plumb/core/error.hpp"

namespace plumb {

namespace {

constexpr unsigned kMinSlotBits = 4;

// The fewest bits whose table keeps at most half its slots filled by n voxels.
unsigned slot_bits_for(std::size_t n) {
  unsigned bits = kMinSlotBits;
  while ((std::size_t{1} << bits) < 2 * n) ++bits;
  return bits;
}

}  // namespace

VoxelHashMap::VoxelHashMap(const VoxelHashMapSettings& settings) : settings_(settings) {
  PLUMB_CHECK(std::isfinite(settings.voxel_size) && settings.voxel_size > 0.0,
              "VoxelHashMap: voxel_size must be > 0, got " << settings.voxel_size);
  PLUMB_CHECK(settings.max_points_per_voxel >= 1,
              "VoxelHashMap: max_points_per_voxel must be >= 1, got " << settings.max_points_per_voxel);
  PLUMB_CHECK(settings.max_distance > 0.0, "VoxelHashMap: max_distance must be > 0, got " << settings.max_distance);
  PLUMB_CHECK(settings.max_voxels >= 1, "VoxelHashMap: max_voxels must be >= 1");
  block_ = static_cast<std::size_t>(settings.max_points_per_voxel);
  rebuild_index(kMinSlotBits);
}

VoxelHashMap::Key VoxelHashMap::key_of(const Vector3f& p) const {
  const double s = settings_.voxel_size;
  auto c = [s](float v) {
    const double f = std::floor(static_cast<double>(v) / s);
    return static_cast<std::int32_t>(std::clamp(f, -2.0e9, 2.0e9));
  };
  return {c(p.x()), c(p.y()), c(p.z())};
}

Vector3d VoxelHashMap::center_of(const Key& k) const {
  return (Vector3d(k.x, k.y, k.z) + Vector3d::Constant(0.5)) * settings_.voxel_size;
}

std::size_t VoxelHashMap::home_slot(const Key& k) const {
  // Teschner et al. 2003's spatial hash, then a Fibonacci multiply whose top bits pick the slot
  // (the spatial hash alone leaves the low bits poorly mixed).
  const std::uint64_t h = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.x)) * 73856093u) ^
                          (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.y)) * 19349669u) ^
                          (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.z)) * 83492791u);
  return static_cast<std::size_t>((h * 0x9E3779B97F4A7C15ull) >> (64 - slot_bits_));
}

void VoxelHashMap::rebuild_index(unsigned bits) {
  slot_bits_ = bits;
  slots_.assign(std::size_t{1} << bits, 0u);
  const std::size_t mask = slots_.size() - 1;
  for (std::size_t v = 0; v < keys_.size(); ++v) {
    std::size_t s = home_slot(keys_[v]);
    while (slots_[s] != 0) s = (s + 1) & mask;
    slots_[s] = static_cast<std::uint32_t>(v + 1);
  }
}

std::size_t VoxelHashMap::find_or_add(const Key& k) {
  const std::size_t mask = slots_.size() - 1;
  std::size_t s = home_slot(k);
  for (; slots_[s] != 0; s = (s + 1) & mask) {
    const std::size_t v = slots_[s] - 1;
    if (keys_[v] == k) return v;
  }
  const std::size_t v = keys_.size();
  PLUMB_CHECK(v < std::numeric_limits<std::uint32_t>::max(), "VoxelHashMap: more than 2^32 - 1 voxels");
  keys_.push_back(k);
  counts_.push_back(0);
  touched_.push_back(generation_);
  points_.resize(points_.size() + block_);
  if (2 * keys_.size() > slots_.size()) {
    rebuild_index(slot_bits_ + 1);  // places the new voxel too
  } else {
    slots_[s] = static_cast<std::uint32_t>(v + 1);
  }
  return v;
}

void VoxelHashMap::insert(const std::vector<Vector3f>& points) {
  for (const Vector3f& p : points) {
    if (!p.allFinite()) continue;
    const std::size_t v = find_or_add(key_of(p));
    if (counts_[v] >= block_) continue;
    points_[v * block_ + counts_[v]] = p;
    ++counts_[v];
    touched_[v] = generation_;
    ++num_points_;
  }
}

void VoxelHashMap::prune(const Vector3d& center) {
  const double max_sq = settings_.max_distance * settings_.max_distance;
  const std::uint64_t max_age = settings_.max_age;
  std::vector<std::pair<double, std::size_t>> keep;
  keep.reserve(keys_.size());
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    const double d_sq = (center_of(keys_[i]) - center).squaredNorm();
    const bool recent = max_age == 0 || generation_ - touched_[i] < max_age;
    if (d_sq <= max_sq && recent) keep.emplace_back(d_sq, i);
  }
  ++generation_;
  if (keep.size() > settings_.max_voxels) {
    std::stable_sort(keep.begin(), keep.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    keep.resize(settings_.max_voxels);
    std::sort(keep.begin(), keep.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  }
  if (keep.size() == keys_.size()) return;
  // Compact in place: kept voxels move down, in their order.
  num_points_ = 0;
  for (std::size_t w = 0; w < keep.size(); ++w) {
    const std::size_t r = keep[w].second;
    if (r != w) {
      keys_[w] = keys_[r];
      counts_[w] = counts_[r];
      touched_[w] = touched_[r];
      std::copy_n(points_.begin() + static_cast<std::ptrdiff_t>(r * block_), counts_[w],
                  points_.begin() + static_cast<std::ptrdiff_t>(w * block_));
    }
    num_points_ += counts_[w];
  }
  keys_.resize(keep.size());
  counts_.resize(keep.size());
  touched_.resize(keep.size());
  points_.resize(keep.size() * block_);
  // The table keeps its size unless it is far larger than needed (so a map that is refilled each
  // frame does not grow it back every time).
  const unsigned needed = slot_bits_for(keys_.size());
  rebuild_index(slot_bits_ > needed + 2 ? needed + 1 : slot_bits_);
}

std::vector<Vector3f> VoxelHashMap::points() const {
  std::vector<Vector3f> out;
  out.reserve(num_points_);
  for (std::size_t v = 0; v < keys_.size(); ++v) {
    const auto first = points_.begin() + static_cast<std::ptrdiff_t>(v * block_);
    out.insert(out.end(), first, first + counts_[v]);
  }
  return out;
}

void VoxelHashMap::clear() {
  keys_.clear();
  counts_.clear();
  touched_.clear();
  points_.clear();
  num_points_ = 0;
  generation_ = 0;
  rebuild_index(kMinSlotBits);
}

}  // namespace plumb
