// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/optim/imu_factor.hpp"

namespace plumb {

ImuStateBlocks add_imu_state(LeastSquaresProblem& problem, const ImuState& state, bool constant) {
  ImuStateBlocks b;
  b.R = problem.add_rotation(state.R_world_body, constant);
  b.p = problem.add_vector(state.p_world_body, constant);
  b.v = problem.add_vector(state.v_world, constant);
  b.bg = problem.add_vector(state.bias.gyro, constant);
  b.ba = problem.add_vector(state.bias.accel, constant);
  return b;
}

ImuState imu_state(const ManifoldValues& values, const ImuStateBlocks& b) {
  ImuState s;
  s.R_world_body = values.rotation(b.R);
  s.p_world_body = values.vector<3>(b.p);
  s.v_world = values.vector<3>(b.v);
  s.bias.gyro = values.vector<3>(b.bg);
  s.bias.accel = values.vector<3>(b.ba);
  return s;
}

void add_imu_factor(LeastSquaresProblem& problem, const ImuPreintegration& pim, const ImuStateBlocks& i,
                    const ImuStateBlocks& j, const RobustLoss& loss) {
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
