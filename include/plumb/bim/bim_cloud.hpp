// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The BIM cloud a LiDAR is registered to: the model's surfaces a LiDAR sees in the building,
///        sampled with their face normals (Liu et al. 2022, sec. 1.1).

#include "plumb/bim/mesh.hpp"
#include "plumb/core/point_cloud.hpp"

namespace plumb::bim {

/// @brief The BIM cloud a LiDAR is registered to: the model's surfaces sampled every `spacing`
///        metres with their face normals, skipping what a LiDAR does not see in the building
///        (doors are open, windows transmit, spaces and opening volumes are not surfaces, and
///        furnishing is not the structure).
/// @throws plumb::Error when spacing is not positive
PointCloud sample_bim_cloud(const BimMesh& mesh, double spacing);

}  // namespace plumb::bim
