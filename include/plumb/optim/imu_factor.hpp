// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The IMU factor (plumb/imu/preintegration.hpp) as residual blocks of a LeastSquaresProblem:
///        an IMU state is five blocks (R: SO(3), p, v, b_g, b_a: R^3), the factor is whitened by the
///        preintegration's 15x15 covariance (Zhou et al. 2021, eq. 19, E_B, with velocity and bias terms).

#include "plumb/imu/preintegration.hpp"
#include "plumb/optim/least_squares.hpp"

namespace plumb {

/// @brief Block ids of one ImuState in a LeastSquaresProblem.
struct ImuStateBlocks {
  int R = -1;   ///< rotation R_world_body (SO(3))
  int p = -1;   ///< position p_world_body (R^3)
  int v = -1;   ///< velocity v_world (R^3)
  int bg = -1;  ///< gyro bias (R^3)
  int ba = -1;  ///< accel bias (R^3)
};

/// @brief Add the five blocks of `state` (all free, or all constant).
ImuStateBlocks add_imu_state(LeastSquaresProblem& problem, const ImuState& state, bool constant = false);

/// @brief Read an ImuState back from the problem's values.
ImuState imu_state(const ManifoldValues& values, const ImuStateBlocks& b);

/// @brief Add the IMU factor between states i and j: residual U r with U^T U the inverse of
///        `pim.covariance_with_bias()`, Jacobians U J (ImuTangent order, state i's blocks then j's).
/// @note `pim` is referenced, not copied: it must outlive the problem and stay unchanged.
/// @throws plumb::Error when the preintegration's covariance is not positive definite.
void add_imu_factor(LeastSquaresProblem& problem, const ImuPreintegration& pim, const ImuStateBlocks& i,
                    const ImuStateBlocks& j, const RobustLoss& loss = {});

}  // namespace plumb
