// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The settings check of extract_ground(), which segment_frame() runs first, for plumb's own
///        sources (not installed).

#include "plumb/segmentation/ground.hpp"

namespace plumb::detail {

/// Throws plumb::Error for GroundSettings that extract_ground() cannot use.
void check_ground_settings(const GroundSettings& s);

}  // namespace plumb::detail
