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
inline ImuStateBlocks add_imu_state(LeastSquaresProblem& problem, const ImuState& state, bool constant = false) {
  ImuStateBlocks b;
  b.R = problem.add_rotation(state.R_world_body, constant);
  b.p = problem.add_vector(state.p_world_body, constant);
  b.v = problem.add_vector(state.v_world, constant);
  b.bg = problem.add_vector(state.bias.gyro, constant);
  b.ba = problem.add_vector(state.bias.accel, constant);
  return b;
}

/// @brief Read an ImuState back from the problem's values.
inline ImuState imu_state(const ManifoldValues& values, const ImuStateBlocks& b) {
  ImuState s;
  s.R_world_body = values.rotation(b.R);
  s.p_world_body = values.vector<3>(b.p);
  s.v_world = values.vector<3>(b.v);
  s.bias.gyro = values.vector<3>(b.bg);
  s.bias.accel = values.vector<3>(b.ba);
  return s;
}

/// @brief Add the IMU factor between states i and j: residual U r with U^T U the inverse of
///        `pim.covariance_with_bias()`, Jacobians U J (ImuTangent order, state i's blocks then j's).
/// @note `pim` is referenced, not copied: it must outlive the problem and stay unchanged.
/// @throws plumb::Error when the preintegration's covariance is not positive definite.
inline void add_imu_factor(LeastSquaresProblem& problem, const ImuPreintegration& pim, const ImuStateBlocks& i,
                           const ImuStateBlocks& j, const RobustLoss& loss = {}) {
  const Matrix15d U = pim.sqrt_information_with_bias();
  const ImuPreintegration* p = &pim;
  problem.add_residual<15>(
      {i.R, i.p, i.v, i.bg, i.ba, j.R, j.p, j.v, j.bg, j.ba},
      [p, U, i, j](const ManifoldValues& x, Eigen::Matrix<double, 15, 1>& r,
                   Eigen::Matrix<double, 15, Eigen::Dynamic>* J) {
        const ImuFactorResidual f = p->residual(imu_state(x, i), imu_state(x, j));
        r.noalias() = U * f.r;
        if (J != nullptr) {
          J->leftCols<15>().noalias() = U * f.J_r_xi_i;
          J->rightCols<15>().noalias() = U * f.J_r_xi_j;
        }
      },
      loss);
}

}  // namespace plumb
