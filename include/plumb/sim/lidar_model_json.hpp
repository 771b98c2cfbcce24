// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The text of the LiDAR model file of `plumb simulate --lidar FILE.json` (the file is read by
/// read_lidar_model() of app/simulate.hpp): a preset to start from and the fields to change, e.g.
///
///     {"preset": "vlp16", "columns": 900}
///     {"name": "my-16", "elevations_deg": [-15, -13, ..., 15], "columns": 1800, "rate_hz": 10,
///      "min_range": 0.5, "max_range": 100, "range_sigma": 0.03, "dropout": 0.01}
///
/// Keys: `preset` (lidar_preset()), `name`, `elevations_deg` or `elevations_rad` (one per row),
/// `columns` (a whole number), `rate_hz`, `min_range`, `max_range`, `range_sigma`, `dropout`;
/// others are ignored. Without a preset, the rows are required. The result passes
/// LidarModel::validate() (its limits: at most 65535 rows, columns in [1, 100000], at most 2^22
/// rays per sweep, 1-100 Hz).

#include <string>

#include "plumb/sim/lidar.hpp"

namespace plumb::sim {

/// @brief Parse a LiDAR model from JSON text; `name` stands for the file in messages.
/// @throws plumb::Error naming `name` (and for malformed JSON, the line and column) when the
///         text is not a JSON object, a value has the wrong type or the model fails validate().
LidarModel parse_lidar_model(const std::string& text, const std::string& name = "<lidar model>");

}  // namespace plumb::sim
