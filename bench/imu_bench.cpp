// SPDX-License-Identifier: BSD-3-Clause
// IMU preintegration speed: samples per second integrated (mean, bias Jacobians, 9x9 and 15x15
// covariances) for a 200 Hz stream of a moving body; and the IMU factor's residual + Jacobians.
// No peer: GTSAM (the reference implementation of Forster's preintegration) is not installed here.

#include <vector>

#include <benchmark/benchmark.h>

#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/imu/imu.hpp"
#include "plumb/imu/preintegration.hpp"

namespace {

// 10 s at 200 Hz: smoothly varying rates and forces of a ground vehicle, gravity along body z.
std::vector<plumb::ImuSample> stream_200hz() {
  plumb::Rng rng(1);
  std::vector<plumb::ImuSample> out;
  plumb::Vector3d w(0.1, -0.05, 0.3), a(0.5, 0.2, 9.8);
  for (int k = 0; k < 2000; ++k) {
    w += 0.01 * plumb::Vector3d(rng.normal(), rng.normal(), rng.normal());
    a += 0.05 * plumb::Vector3d(rng.normal(), rng.normal(), rng.normal());
    out.push_back({0.005 * k, w, a});
  }
  return out;
}

void BM_Preintegration200Hz(benchmark::State& state) {
  const auto samples = stream_200hz();
  const double t0 = samples.front().stamp + 0.0012, t1 = samples.back().stamp - 0.0013;
  std::size_t integrated = 0;
  for (auto _ : state) {
    plumb::ImuPreintegration pim;
    const plumb::Status s = pim.integrate(samples, t0, t1);
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(pim.covariance_with_bias().data());
    integrated += pim.num_measurements();
  }
  state.SetItemsProcessed(static_cast<int64_t>(integrated));
}
BENCHMARK(BM_Preintegration200Hz)->Name("preintegration/plumb/200hz")->Unit(benchmark::kMicrosecond);

void BM_ImuFactorResidual(benchmark::State& state) {
  const auto samples = stream_200hz();
  plumb::ImuPreintegration pim;
  pim.integrate(samples, 0.0, 0.1);  // one 10 Hz LiDAR frame interval
  plumb::ImuState xi;
  xi.R_world_body = plumb::so3::exp(plumb::Vector3d(0.1, 0.2, 0.3));
  xi.v_world = plumb::Vector3d(1.0, 0.5, 0.0);
  plumb::Vector15d d;
  d.setConstant(0.01);
  const plumb::ImuState xj = plumb::retract(pim.predict(xi), d);
  for (auto _ : state) {
    const plumb::ImuFactorResidual f = pim.residual(xi, xj);
    benchmark::DoNotOptimize(f.J_r_xi_i.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_ImuFactorResidual)->Name("imu_factor_residual/plumb/10hz_frame");

}  // namespace

BENCHMARK_MAIN();
