// SPDX-License-Identifier: BSD-3-Clause
// Censi's published calibration results (AndreaCensi/calibration, reference-output/l90*): our
// estimate from his tuple files must lie within one standard deviation of his covariance for every
// parameter. His JSON gives wheel diameters; the covariance is over radii (r_L, r_R, b, l_x, l_y, l_θ).

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "test_data.hpp"

namespace {

struct CensiResult {
  double axle = 0, l_diam = 0, r_diam = 0, l_x = 0, l_y = 0, l_theta = 0;
  plumb::Matrix6d covariance = plumb::Matrix6d::Zero();
};

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The number after `"key":` in a flat JSON text (enough for Censi's results files).
double json_number(const std::string& text, const std::string& key, std::size_t* after = nullptr) {
  const std::size_t k = text.find("\"" + key + "\"");
  EXPECT_NE(k, std::string::npos) << key;
  if (k == std::string::npos) return NAN;
  std::size_t p = text.find(':', k) + 1;
  char* end = nullptr;
  const double v = std::strtod(text.c_str() + p, &end);
  if (after != nullptr) *after = static_cast<std::size_t>(end - text.c_str());
  return v;
}

CensiResult read_censi_result(const std::string& path) {
  const std::string text = slurp(path);
  CensiResult r;
  r.axle = json_number(text, "axle");
  r.l_diam = json_number(text, "l_diam");
  r.r_diam = json_number(text, "r_diam");
  r.l_x = json_number(text, "l_x");
  r.l_y = json_number(text, "l_y");
  r.l_theta = json_number(text, "l_theta");
  std::size_t p = text.find("\"covariance\"");
  EXPECT_NE(p, std::string::npos);
  const char* c = text.c_str() + p;
  for (int i = 0; i < 36; ++i) {
    while (*c != '\0' && !(std::isdigit(static_cast<unsigned char>(*c)) || *c == '-')) ++c;
    char* end = nullptr;
    r.covariance(i / 6, i % 6) = std::strtod(c, &end);
    c = end;
  }
  return r;
}

class CensiReferenceTest : public ::testing::TestWithParam<std::string> {};

TEST_P(CensiReferenceTest, WithinOneSigmaOfPublishedResult) {
  const std::string base = "laser2d/calibration_censi/" + GetParam();
  PLUMB_REQUIRE_DATA(tuple_path, base + ".tuple");
  PLUMB_REQUIRE_DATA(result_path, base + "_results.json");
  const auto tuples = plumb::io::read_calib_tuples(tuple_path);
  const CensiResult ref = read_censi_result(result_path);
  ASSERT_GT(ref.covariance(0, 0), 0.0);
  ASSERT_NEAR(ref.covariance(0, 1), ref.covariance(1, 0), 1e-12);

  const auto est = plumb::calibrate_odometry_laser(tuples);
  ASSERT_EQ(est.status, plumb::Status::kOk);
  plumb::Vector6d expected;
  expected << ref.l_diam / 2, ref.r_diam / 2, ref.axle, ref.l_x, ref.l_y, ref.l_theta;
  const plumb::Vector6d got = est.params.vector();
  const char* names[6] = {"r_L", "r_R", "axle", "l_x", "l_y", "l_theta"};
  for (int j = 0; j < 6; ++j) {
    const double sigma = std::sqrt(ref.covariance(j, j));
    const double dev = (got(j) - expected(j)) / sigma;
    EXPECT_LE(std::abs(dev), 1.0) << names[j];  // the requirement
    // We implement the same estimator, so we should agree to the 6 digits his file prints
    // (that rounding is below 1e-3 sigma for every parameter).
    EXPECT_LE(std::abs(dev), 0.01) << names[j];
    // Our covariance is computed the same way (Fisher information from the residual noise; his
    // solver differs in the numerical derivative and evaluates it after one more rejection
    // round): the standard deviations should agree to 10 %.
    EXPECT_GT(std::sqrt(est.covariance(j, j)), 0.9 * sigma) << names[j];
    EXPECT_LT(std::sqrt(est.covariance(j, j)), 1.1 * sigma) << names[j];
  }
}

INSTANTIATE_TEST_SUITE_P(L90, CensiReferenceTest, ::testing::Values("l90", "l90_0", "l90_1", "l90_2"));

}  // namespace
