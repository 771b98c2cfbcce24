// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The binning of compute_fpfh(), for plumb's own sources and tests (not installed).

namespace plumb::detail {

/// Bin of the α feature α = atan2(y, x) in [-π, π], floor(11 (α + π) / 2π), without atan2: the
/// bin is the number of bin edges β_k = -π + 2πk/11 (k = 1..10) with α >= β_k. Edges below 0 are
/// all passed when y >= 0 and the rest none when y < 0; within a half plane α >= β_k is the sign
/// of the cross product (cos β_k, sin β_k) x (x, y). (x, y) = (0, 0), α = 0, is the middle bin.
int fpfh_angle_bin(float y, float x);

}  // namespace plumb::detail
