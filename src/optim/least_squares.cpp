// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/optim/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "plumb/core/levenberg_marquardt.hpp"

namespace plumb {

int ManifoldValues::add_rotation(const Matrix3d& R) {
  PLUMB_CHECK(R.allFinite() && (R.transpose() * R - Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0,
              "ManifoldValues::add_rotation: block " << num_blocks() << " is not a rotation matrix");
  kinds_.push_back(BlockKind::kRotation);
  dims_.push_back(3);
  slots_.push_back(rotations_.size());
  rotations_.push_back(R);
  return num_blocks() - 1;
}

int ManifoldValues::add_vector(const Eigen::VectorXd& x) {
  PLUMB_CHECK(x.size() > 0, "ManifoldValues::add_vector: block " << num_blocks() << " is empty");
  PLUMB_CHECK(x.allFinite(), "ManifoldValues::add_vector: block " << num_blocks() << " is not finite");
  kinds_.push_back(BlockKind::kVector);
  dims_.push_back(static_cast<int>(x.size()));
  slots_.push_back(data_.size());
  data_.insert(data_.end(), x.data(), x.data() + x.size());
  return num_blocks() - 1;
}

const Matrix3d& ManifoldValues::rotation(int block) const {
  PLUMB_CHECK(kind(block) == BlockKind::kRotation, "ManifoldValues::rotation: block " << block << " is not a rotation");
  return rotations_[slots_[static_cast<std::size_t>(block)]];
}

Eigen::Map<const Eigen::VectorXd> ManifoldValues::vector(int block) const {
  PLUMB_CHECK(kind(block) == BlockKind::kVector, "ManifoldValues::vector: block " << block << " is not a vector");
  const auto b = static_cast<std::size_t>(block);
  return Eigen::Map<const Eigen::VectorXd>(data_.data() + slots_[b], dims_[b]);
}

void ManifoldValues::set_rotation(int block, const Matrix3d& R) {
  PLUMB_CHECK(kind(block) == BlockKind::kRotation, "ManifoldValues::set_rotation: block " << block << " is not a rotation");
  PLUMB_CHECK(R.allFinite() && (R.transpose() * R - Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0,
              "ManifoldValues::set_rotation: block " << block << ": not a rotation matrix");
  rotations_[slots_[static_cast<std::size_t>(block)]] = R;
}

void ManifoldValues::set_vector(int block, const Eigen::VectorXd& x) {
  PLUMB_CHECK(kind(block) == BlockKind::kVector && x.size() == tangent_dim(block),
              "ManifoldValues::set_vector: block " << block << " is not a vector of size " << x.size());
  PLUMB_CHECK(x.allFinite(), "ManifoldValues::set_vector: block " << block << ": value not finite");
  std::copy(x.data(), x.data() + x.size(), data_.begin() + static_cast<std::ptrdiff_t>(slots_[static_cast<std::size_t>(block)]));
}

void ManifoldValues::retract(int block, const double* delta) {
  const auto b = static_cast<std::size_t>(block);
  check(block);
  if (kinds_[b] == BlockKind::kRotation) {
    Matrix3d& R = rotations_[slots_[b]];
    R = R * so3::exp(Vector3d(delta[0], delta[1], delta[2]));
  } else {
    double* x = data_.data() + slots_[b];
    for (int k = 0; k < dims_[b]; ++k) x[k] += delta[k];
  }
}

double ManifoldValues::vectors_norm() const {
  double s = 0.0;
  for (double v : data_) s += v * v;
  return std::sqrt(s);
}

LeastSquaresProblem::LeastSquaresProblem() = default;

LeastSquaresProblem::~LeastSquaresProblem() = default;

LeastSquaresProblem::LeastSquaresProblem(LeastSquaresProblem&&) noexcept = default;

LeastSquaresProblem& LeastSquaresProblem::operator=(LeastSquaresProblem&&) noexcept = default;

int LeastSquaresProblem::add_rotation(const Matrix3d& R, bool constant) {
  const int id = values_.add_rotation(R);
  constant_.push_back(constant);
  return id;
}

int LeastSquaresProblem::add_vector(const Eigen::VectorXd& x, bool constant) {
  const int id = values_.add_vector(x);
  constant_.push_back(constant);
  return id;
}

void LeastSquaresProblem::set_constant(int block, bool constant) {
  PLUMB_CHECK(block >= 0 && block < values_.num_blocks(), "LeastSquaresProblem::set_constant: no block " << block);
  constant_[static_cast<std::size_t>(block)] = constant;
}

bool LeastSquaresProblem::is_constant(int block) const {
  PLUMB_CHECK(block >= 0 && block < values_.num_blocks(), "LeastSquaresProblem::is_constant: no block " << block);
  return constant_[static_cast<std::size_t>(block)];
}

int LeastSquaresProblem::num_free_parameters() const {
  int n = 0;
  for (int b = 0; b < values_.num_blocks(); ++b) {
    if (!constant_[static_cast<std::size_t>(b)]) n += values_.tangent_dim(b);
  }
  return n;
}

double LeastSquaresProblem::cost() const {
  double c = 0.0;
  for (const auto& t : terms_) c += 0.5 * t->loss().rho(t->squared_norm(values_));
  return c;
}

double LeastSquaresProblem::max_jacobian_error(double eps) const {
  PLUMB_CHECK(eps > 0.0, "LeastSquaresProblem::max_jacobian_error: eps must be positive");
  double worst = 0.0;
  Eigen::VectorXd r, rp, rm;
  Eigen::MatrixXd J;
  for (const auto& t : terms_) {
    t->evaluate(values_, r, &J);
    Eigen::MatrixXd N(J.rows(), J.cols());
    for (std::size_t a = 0; a < t->blocks().size(); ++a) {
      for (int k = 0; k < t->dims()[a]; ++k) {
        Eigen::VectorXd d = Eigen::VectorXd::Zero(t->dims()[a]);
        d(k) = eps;
        ManifoldValues plus = values_, minus = values_;
        plus.retract(t->blocks()[a], d.data());
        d(k) = -eps;
        minus.retract(t->blocks()[a], d.data());
        t->evaluate(plus, rp, nullptr);
        t->evaluate(minus, rm, nullptr);
        N.col(t->cols()[a] + k) = (rp - rm) / (2.0 * eps);
      }
    }
    worst = std::max(worst, (N - J).norm() / std::max(1.0, J.norm()));
  }
  return worst;
}

namespace {

// Cost and normal equations H = sum w J^T J, g = sum w J^T r over the free blocks.
double linearize(const LeastSquaresProblem& problem, const std::vector<int>& offset, Eigen::MatrixXd& H,
                        Eigen::VectorXd& g) {
  H.setZero();
  g.setZero();
  double cost = 0.0;
  for (const auto& t : problem.terms()) {
    const double s = t->accumulate(problem.values(), offset, H, g);
    cost += 0.5 * t->loss().rho(s);
  }
  return cost;
}

void apply_step(ManifoldValues& values, const std::vector<int>& offset, const Eigen::VectorXd& h) {
  for (int b = 0; b < values.num_blocks(); ++b) {
    const int o = offset[static_cast<std::size_t>(b)];
    if (o >= 0) values.retract(b, h.data() + o);
  }
}

}  // namespace

LeastSquaresResult solve_least_squares(LeastSquaresProblem& problem, const LeastSquaresSettings& settings) {
  PLUMB_CHECK(settings.max_iterations >= 0, "solve_least_squares: max_iterations must not be negative");
  PLUMB_CHECK(settings.initial_lambda > 0.0 && settings.max_lambda >= settings.initial_lambda,
              "solve_least_squares: need 0 < initial_lambda <= max_lambda");
  ManifoldValues& values = problem.values();
  std::vector<int> offset(static_cast<std::size_t>(values.num_blocks()), -1);
  int n = 0;
  for (int b = 0; b < values.num_blocks(); ++b) {
    if (!problem.is_constant(b)) {
      offset[static_cast<std::size_t>(b)] = n;
      n += values.tangent_dim(b);
    }
  }
  LeastSquaresResult result;
  Eigen::MatrixXd H(n, n);
  Eigen::VectorXd g(n);
  double cost = linearize(problem, offset, H, g);
  result.initial_cost = result.final_cost = cost;
  if (!std::isfinite(cost) || !H.allFinite() || !g.allFinite()) {
    result.status = Status::kInvalidInput;
    return result;
  }
  if (n == 0 || problem.num_residual_blocks() == 0) {
    result.converged = true;
    result.status = Status::kOk;
    result.information = H;
    return result;
  }
  const bool lm = settings.method == LeastSquaresMethod::kLevenbergMarquardt;
  LevenbergMarquardtSettings lm_settings;
  lm_settings.initial_lambda = settings.initial_lambda;
  lm_settings.max_lambda = settings.max_lambda;
  LevenbergMarquardt damping(lm_settings);
  Eigen::VectorXd h(n);
  bool degenerate = false;
  for (int iter = 0; iter < settings.max_iterations && !result.converged; ++iter) {
    result.iterations = iter + 1;
    if (g.lpNorm<Eigen::Infinity>() <= settings.gradient_tolerance) {
      result.converged = true;
      break;
    }
    const ManifoldValues saved = values;
    double new_cost = cost;
    if (lm) {
      // The accepted step's cost is the last one evaluated: values stay where it moved them.
      const bool accepted = damping.step(H, g, cost, [&](const Eigen::VectorXd& d) {
        values = saved;
        apply_step(values, offset, d);
        const double c = problem.cost();
        new_cost = std::isfinite(c) ? c : std::numeric_limits<double>::infinity();
        return new_cost;
      }, h);
      result.num_rejected_steps = damping.num_rejected();
      if (!accepted) {
        values = saved;
        // No step within the attempts lowered the cost: at the damping's limit (or with a
        // non-finite solve) give up; otherwise try again with the larger damping.
        if (damping.at_max_lambda() || !h.allFinite()) break;
        continue;
      }
    } else {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
      const double max_d = ldlt.vectorD().cwiseAbs().maxCoeff();
      if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-14 * max_d)) {
        degenerate = true;
        break;
      }
      h = ldlt.solve(-g);
      if (!h.allFinite()) {
        degenerate = true;
        break;
      }
      apply_step(values, offset, h);
      new_cost = problem.cost();
      if (!std::isfinite(new_cost)) {
        values = saved;
        break;
      }
    }
    if (h.norm() <= settings.step_tolerance * (1.0 + saved.vectors_norm())) result.converged = true;
    const double decrease = cost - new_cost;
    cost = linearize(problem, offset, H, g);
    if (decrease >= 0.0 && decrease <= settings.function_tolerance * std::max(cost + decrease, 1e-300)) {
      result.converged = true;
    }
  }
  result.final_cost = cost;
  result.information = H;
  result.status = result.converged ? Status::kOk : (degenerate ? Status::kDegenerate : Status::kNotConverged);
  return result;
}

}  // namespace plumb
