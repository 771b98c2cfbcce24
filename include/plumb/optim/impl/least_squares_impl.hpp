// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Bodies of plumb/optim/least_squares.hpp (included at its end).

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>

#include <Eigen/Cholesky>

namespace plumb {

// ---------------------------------------------------------------------------------------------
// ManifoldValues

inline int ManifoldValues::add_rotation(const Matrix3d& R) {
  PLUMB_CHECK(R.allFinite() && (R.transpose() * R - Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0,
              "ManifoldValues::add_rotation: block " << num_blocks() << " is not a rotation matrix");
  kinds_.push_back(BlockKind::kRotation);
  dims_.push_back(3);
  slots_.push_back(rotations_.size());
  rotations_.push_back(R);
  return num_blocks() - 1;
}

inline int ManifoldValues::add_vector(const Eigen::VectorXd& x) {
  PLUMB_CHECK(x.size() > 0, "ManifoldValues::add_vector: block " << num_blocks() << " is empty");
  PLUMB_CHECK(x.allFinite(), "ManifoldValues::add_vector: block " << num_blocks() << " is not finite");
  kinds_.push_back(BlockKind::kVector);
  dims_.push_back(static_cast<int>(x.size()));
  slots_.push_back(data_.size());
  data_.insert(data_.end(), x.data(), x.data() + x.size());
  return num_blocks() - 1;
}

inline const Matrix3d& ManifoldValues::rotation(int block) const {
  PLUMB_CHECK(kind(block) == BlockKind::kRotation, "ManifoldValues::rotation: block " << block << " is not a rotation");
  return rotations_[slots_[static_cast<std::size_t>(block)]];
}

inline Eigen::Map<const Eigen::VectorXd> ManifoldValues::vector(int block) const {
  PLUMB_CHECK(kind(block) == BlockKind::kVector, "ManifoldValues::vector: block " << block << " is not a vector");
  const auto b = static_cast<std::size_t>(block);
  return Eigen::Map<const Eigen::VectorXd>(data_.data() + slots_[b], dims_[b]);
}

template <int N>
Eigen::Map<const Eigen::Matrix<double, N, 1>> ManifoldValues::vector(int block) const {
  static_assert(N > 0, "ManifoldValues::vector<N>: N must be positive");
  PLUMB_CHECK(kind(block) == BlockKind::kVector && dims_[static_cast<std::size_t>(block)] == N,
              "ManifoldValues::vector<" << N << ">: block " << block << " is not a vector of size " << N);
  return Eigen::Map<const Eigen::Matrix<double, N, 1>>(data_.data() + slots_[static_cast<std::size_t>(block)]);
}

inline void ManifoldValues::set_rotation(int block, const Matrix3d& R) {
  PLUMB_CHECK(kind(block) == BlockKind::kRotation, "ManifoldValues::set_rotation: block " << block << " is not a rotation");
  PLUMB_CHECK(R.allFinite() && (R.transpose() * R - Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0,
              "ManifoldValues::set_rotation: block " << block << ": not a rotation matrix");
  rotations_[slots_[static_cast<std::size_t>(block)]] = R;
}

inline void ManifoldValues::set_vector(int block, const Eigen::VectorXd& x) {
  PLUMB_CHECK(kind(block) == BlockKind::kVector && x.size() == tangent_dim(block),
              "ManifoldValues::set_vector: block " << block << " is not a vector of size " << x.size());
  PLUMB_CHECK(x.allFinite(), "ManifoldValues::set_vector: block " << block << ": value not finite");
  std::copy(x.data(), x.data() + x.size(), data_.begin() + static_cast<std::ptrdiff_t>(slots_[static_cast<std::size_t>(block)]));
}

inline void ManifoldValues::retract(int block, const double* delta) {
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

inline double ManifoldValues::vectors_norm() const {
  double s = 0.0;
  for (double v : data_) s += v * v;
  return std::sqrt(s);
}

// ---------------------------------------------------------------------------------------------
// Residual blocks

namespace optim_detail {

/// Type-erased residual block: its blocks, the column of each block in its Jacobian, its loss.
class TermBase {
 public:
  TermBase(std::vector<int> blocks, std::vector<int> dims, const RobustLoss& loss)
      : blocks_(std::move(blocks)), dims_(std::move(dims)), loss_(loss) {
    int c = 0;
    for (int d : dims_) { cols_.push_back(c); c += d; }
    num_cols_ = c;
  }
  virtual ~TermBase() = default;
  TermBase(const TermBase&) = delete;
  TermBase& operator=(const TermBase&) = delete;

  virtual int dim() const = 0;
  /// |r|^2 at x.
  virtual double squared_norm(const ManifoldValues& x) const = 0;
  /// Adds rho'(s) J^T J and rho'(s) J^T r into H and g (offset[b] < 0: block b constant); returns s.
  virtual double accumulate(const ManifoldValues& x, const std::vector<int>& offset, Eigen::MatrixXd& H,
                            Eigen::VectorXd& g) const = 0;
  /// r and (when J) the Jacobian, as dynamic matrices (for checks).
  virtual void evaluate(const ManifoldValues& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const = 0;

  const std::vector<int>& blocks() const { return blocks_; }
  const std::vector<int>& dims() const { return dims_; }
  const std::vector<int>& cols() const { return cols_; }
  int num_cols() const { return num_cols_; }
  const RobustLoss& loss() const { return loss_; }

 private:
  std::vector<int> blocks_, dims_, cols_;
  int num_cols_ = 0;
  RobustLoss loss_;
};

template <int M, typename F>
class Term final : public TermBase {
 public:
  Term(std::vector<int> blocks, std::vector<int> dims, const RobustLoss& loss, F f)
      : TermBase(std::move(blocks), std::move(dims), loss), f_(std::move(f)), J_(M, num_cols()) {}

  int dim() const override { return M; }

  double squared_norm(const ManifoldValues& x) const override {
    f_(x, r_, static_cast<Eigen::Matrix<double, M, Eigen::Dynamic>*>(nullptr));
    return r_.squaredNorm();
  }

  double accumulate(const ManifoldValues& x, const std::vector<int>& offset, Eigen::MatrixXd& H,
                    Eigen::VectorXd& g) const override {
    J_.setZero();
    f_(x, r_, &J_);
    const double s = r_.squaredNorm();
    const double w = loss().rho_prime(s);
    const std::size_t n = blocks().size();
    for (std::size_t a = 0; a < n; ++a) {
      const int oa = offset[static_cast<std::size_t>(blocks()[a])];
      if (oa < 0) continue;
      const int ca = cols()[a], da = dims()[a];
      if (da == 3) {
        g.segment<3>(oa).noalias() += w * J_.template middleCols<3>(ca).transpose() * r_;
      } else {
        g.segment(oa, da).noalias() += w * J_.middleCols(ca, da).transpose() * r_;
      }
      for (std::size_t b = 0; b < n; ++b) {
        const int ob = offset[static_cast<std::size_t>(blocks()[b])];
        if (ob < 0) continue;
        const int cb = cols()[b], db = dims()[b];
        if (da == 3 && db == 3) {
          H.block<3, 3>(oa, ob).noalias() +=
              w * J_.template middleCols<3>(ca).transpose() * J_.template middleCols<3>(cb);
        } else {
          H.block(oa, ob, da, db).noalias() += w * J_.middleCols(ca, da).transpose() * J_.middleCols(cb, db);
        }
      }
    }
    return s;
  }

  void evaluate(const ManifoldValues& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    J_.setZero();
    f_(x, r_, J != nullptr ? &J_ : nullptr);
    r = r_;
    if (J != nullptr) *J = J_;
  }

 private:
  F f_;
  mutable Eigen::Matrix<double, M, 1> r_;
  mutable Eigen::Matrix<double, M, Eigen::Dynamic> J_;
};

}  // namespace optim_detail

// ---------------------------------------------------------------------------------------------
// LeastSquaresProblem

inline LeastSquaresProblem::LeastSquaresProblem() = default;
inline LeastSquaresProblem::~LeastSquaresProblem() = default;
inline LeastSquaresProblem::LeastSquaresProblem(LeastSquaresProblem&&) noexcept = default;
inline LeastSquaresProblem& LeastSquaresProblem::operator=(LeastSquaresProblem&&) noexcept = default;

inline int LeastSquaresProblem::add_rotation(const Matrix3d& R, bool constant) {
  const int id = values_.add_rotation(R);
  constant_.push_back(constant);
  return id;
}

inline int LeastSquaresProblem::add_vector(const Eigen::VectorXd& x, bool constant) {
  const int id = values_.add_vector(x);
  constant_.push_back(constant);
  return id;
}

inline void LeastSquaresProblem::set_constant(int block, bool constant) {
  PLUMB_CHECK(block >= 0 && block < values_.num_blocks(), "LeastSquaresProblem::set_constant: no block " << block);
  constant_[static_cast<std::size_t>(block)] = constant;
}

inline bool LeastSquaresProblem::is_constant(int block) const {
  PLUMB_CHECK(block >= 0 && block < values_.num_blocks(), "LeastSquaresProblem::is_constant: no block " << block);
  return constant_[static_cast<std::size_t>(block)];
}

template <int M, typename F>
void LeastSquaresProblem::add_residual(const std::vector<int>& blocks, F&& function, const RobustLoss& loss) {
  static_assert(M >= 1, "LeastSquaresProblem::add_residual: M must be a positive compile-time size");
  using Fn = std::decay_t<F>;
  static_assert(std::is_invocable_v<const Fn&, const ManifoldValues&, Eigen::Matrix<double, M, 1>&,
                                    Eigen::Matrix<double, M, Eigen::Dynamic>*>,
                "residual function must be callable as f(const ManifoldValues&, Eigen::Matrix<double, M, 1>&, "
                "Eigen::Matrix<double, M, Eigen::Dynamic>*)");
  PLUMB_CHECK(!blocks.empty(), "LeastSquaresProblem::add_residual: residual " << terms_.size() << " has no block");
  std::vector<int> dims;
  for (std::size_t a = 0; a < blocks.size(); ++a) {
    PLUMB_CHECK(blocks[a] >= 0 && blocks[a] < values_.num_blocks(),
                "LeastSquaresProblem::add_residual: residual " << terms_.size() << " names unknown block " << blocks[a]);
    for (std::size_t b = 0; b < a; ++b) {
      PLUMB_CHECK(blocks[a] != blocks[b],
                  "LeastSquaresProblem::add_residual: residual " << terms_.size() << " names block " << blocks[a] << " twice");
    }
    dims.push_back(values_.tangent_dim(blocks[a]));
  }
  terms_.push_back(std::make_unique<optim_detail::Term<M, Fn>>(blocks, std::move(dims), loss, Fn(std::forward<F>(function))));
}

inline int LeastSquaresProblem::num_free_parameters() const {
  int n = 0;
  for (int b = 0; b < values_.num_blocks(); ++b) {
    if (!constant_[static_cast<std::size_t>(b)]) n += values_.tangent_dim(b);
  }
  return n;
}

inline double LeastSquaresProblem::cost() const {
  double c = 0.0;
  for (const auto& t : terms_) c += 0.5 * t->loss().rho(t->squared_norm(values_));
  return c;
}

inline double LeastSquaresProblem::max_jacobian_error(double eps) const {
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

// ---------------------------------------------------------------------------------------------
// Solver

namespace optim_detail {

// Cost and normal equations H = sum w J^T J, g = sum w J^T r over the free blocks.
inline double linearize(const LeastSquaresProblem& problem, const std::vector<int>& offset, Eigen::MatrixXd& H,
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

inline void apply_step(ManifoldValues& values, const std::vector<int>& offset, const Eigen::VectorXd& h) {
  for (int b = 0; b < values.num_blocks(); ++b) {
    const int o = offset[static_cast<std::size_t>(b)];
    if (o >= 0) values.retract(b, h.data() + o);
  }
}

}  // namespace optim_detail

inline LeastSquaresResult solve_least_squares(LeastSquaresProblem& problem, const LeastSquaresSettings& settings) {
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
  double cost = optim_detail::linearize(problem, offset, H, g);
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
  double lambda = settings.initial_lambda;
  double nu = 2.0;
  Eigen::VectorXd h(n), D(n);
  bool degenerate = false;
  for (int iter = 0; iter < settings.max_iterations && !result.converged; ++iter) {
    result.iterations = iter + 1;
    if (g.lpNorm<Eigen::Infinity>() <= settings.gradient_tolerance) {
      result.converged = true;
      break;
    }
    if (lm) {
      // Marquardt scaling by diag(H), floored so that directions without information stay damped.
      const double floor = 1e-9 * std::max(1.0, H.diagonal().maxCoeff());
      D = H.diagonal().cwiseMax(floor);
      Eigen::MatrixXd A = H;
      A.diagonal() += lambda * D;
      h = A.llt().solve(-g);
    } else {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
      const double max_d = ldlt.vectorD().cwiseAbs().maxCoeff();
      if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-14 * max_d)) {
        degenerate = true;
        break;
      }
      h = ldlt.solve(-g);
    }
    if (!h.allFinite()) {
      degenerate = !lm;
      break;
    }
    if (h.norm() <= settings.step_tolerance * (1.0 + values.vectors_norm())) {
      result.converged = true;
      break;
    }
    const ManifoldValues saved = values;
    optim_detail::apply_step(values, offset, h);
    const double new_cost = problem.cost();
    if (lm) {
      const double predicted = 0.5 * h.dot(lambda * D.cwiseProduct(h) - g);
      const double rho = (cost - new_cost) / predicted;
      if (!std::isfinite(new_cost) || !(predicted > 0.0) || !(rho > 0.0)) {
        values = saved;
        ++result.num_rejected_steps;
        lambda *= nu;
        nu *= 2.0;
        if (lambda > settings.max_lambda) break;
        continue;
      }
      const double r3 = 2.0 * rho - 1.0;
      lambda = std::max(lambda * std::max(1.0 / 3.0, 1.0 - r3 * r3 * r3), 1e-15);
      nu = 2.0;
    } else if (!std::isfinite(new_cost)) {
      values = saved;
      break;
    }
    const double decrease = cost - new_cost;
    cost = optim_detail::linearize(problem, offset, H, g);
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
