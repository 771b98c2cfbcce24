// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The templates of plumb/optim/least_squares.hpp (included at its end); the rest is compiled in
// src/optim/least_squares.cpp.

#include <type_traits>
#include <utility>

namespace plumb {

// ---------------------------------------------------------------------------------------------
// ManifoldValues

template <int N>
Eigen::Map<const Eigen::Matrix<double, N, 1>> ManifoldValues::vector(int block) const {
  static_assert(N > 0, "ManifoldValues::vector<N>: N must be positive");
  PLUMB_CHECK(kind(block) == BlockKind::kVector && dims_[static_cast<std::size_t>(block)] == N,
              "ManifoldValues::vector<" << N << ">: block " << block << " is not a vector of size " << N);
  return Eigen::Map<const Eigen::Matrix<double, N, 1>>(data_.data() + slots_[static_cast<std::size_t>(block)]);
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

}  // namespace plumb
