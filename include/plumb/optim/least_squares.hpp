// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A small dense Gauss-Newton / Levenberg-Marquardt solver over manifold blocks (SO(3) by
///        right perturbation, R^n), with robust losses and analytic Jacobians from the residuals.
///
/// Made for per-frame problems of a few blocks and up to thousands of small residuals (the LiDAR/IMU
/// estimator of Zhou et al. 2021, eq. 19-22): the normal equations are dense (tangent dimension up to ~100),
/// residual rows are fixed-size Eigen types, nothing is allocated per residual evaluation.
///
/// Usage:
/// @code
///   LeastSquaresProblem problem;
///   const int R = problem.add_rotation(Matrix3d::Identity());
///   const int t = problem.add_vector(Vector3d::Zero());
///   for (...) problem.add_residual<3>({R, t},
///       [p, q](const ManifoldValues& x, Eigen::Matrix<double, 3, 1>& r, Eigen::Matrix<double, 3, Eigen::Dynamic>* J) {
///         r = x.rotation(R) * p + x.vector<3>(t) - q;
///         if (J) { J->leftCols<3>() = -x.rotation(R) * hat(p); J->rightCols<3>().setIdentity(); }
///       }, RobustLoss::huber(0.1));
///   const LeastSquaresResult result = solve_least_squares(problem);
/// @endcode
/// A residual's Jacobian has one column group per listed block, in the order listed, of the block's
/// tangent size (3 for a rotation: d r / d delta with R <- R exp(delta); n for R^n: x <- x + delta).

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/robust_kernel.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"

namespace plumb {

/// @brief Kind of a variable block.
enum class BlockKind {
  kRotation,  ///< SO(3) as a rotation matrix; tangent 3, retraction R exp(delta)
  kVector,    ///< R^n; tangent n, retraction x + delta
};

/// @brief The variables of a problem: SO(3) and R^n blocks addressed by the ids that add_* return.
class ManifoldValues {
 public:
  /// @brief Add a rotation block. @throws plumb::Error when R is not a rotation (|R^T R - I| > 1e-6).
  int add_rotation(const Matrix3d& R);
  /// @brief Add an R^n block (n >= 1). @throws plumb::Error when empty or not finite.
  int add_vector(const Eigen::VectorXd& x);

  int num_blocks() const { return static_cast<int>(kinds_.size()); }
  BlockKind kind(int block) const { check(block); return kinds_[static_cast<std::size_t>(block)]; }
  /// @brief Tangent dimension: 3 for a rotation, n for R^n.
  int tangent_dim(int block) const { check(block); return dims_[static_cast<std::size_t>(block)]; }

  /// @brief The rotation of a rotation block. @throws plumb::Error for another kind of block.
  const Matrix3d& rotation(int block) const;
  /// @brief The value of an R^n block. @throws plumb::Error for another kind of block.
  Eigen::Map<const Eigen::VectorXd> vector(int block) const;
  /// @brief The value of an R^N block as a fixed-size vector. @throws plumb::Error when n != N.
  template <int N>
  Eigen::Map<const Eigen::Matrix<double, N, 1>> vector(int block) const;

  void set_rotation(int block, const Matrix3d& R);
  void set_vector(int block, const Eigen::VectorXd& x);

  /// @brief block <- block (+) delta (delta of size tangent_dim(block)).
  void retract(int block, const double* delta);

  /// @brief Euclidean norm of all R^n values together (scale for the step tolerance).
  double vectors_norm() const;

 private:
  void check(int block) const {
    PLUMB_CHECK(block >= 0 && block < num_blocks(), "ManifoldValues: no block " << block << " (have " << num_blocks() << ")");
  }
  std::vector<BlockKind> kinds_;
  std::vector<int> dims_;
  std::vector<std::size_t> slots_;  // index into rotations_, or offset into data_
  std::vector<Matrix3d> rotations_;
  std::vector<double> data_;
};

namespace optim_detail {
class TermBase;
}  // namespace optim_detail

/// @brief Variables, which of them are held constant, and residual blocks with robust losses.
/// @note Not thread-safe: evaluation uses per-residual scratch space.
class LeastSquaresProblem {
 public:
  LeastSquaresProblem();
  ~LeastSquaresProblem();
  LeastSquaresProblem(LeastSquaresProblem&&) noexcept;
  LeastSquaresProblem& operator=(LeastSquaresProblem&&) noexcept;

  /// @brief Add a rotation variable; see ManifoldValues::add_rotation.
  int add_rotation(const Matrix3d& R, bool constant = false);
  /// @brief Add an R^n variable; see ManifoldValues::add_vector.
  int add_vector(const Eigen::VectorXd& x, bool constant = false);
  /// @brief Hold a block fixed (its Jacobian columns are ignored) or free it again.
  void set_constant(int block, bool constant);
  bool is_constant(int block) const;

  /// @brief Add a block of M residuals depending on `blocks` (distinct ids), with a robust loss.
  /// `function(const ManifoldValues& x, Eigen::Matrix<double, M, 1>& r,
  /// Eigen::Matrix<double, M, Eigen::Dynamic>* J)` fills r and, when J is not null, the
  /// M x (sum of the blocks' tangent sizes) Jacobian, which is zero on entry.
  /// @throws plumb::Error for an unknown or repeated block id, or M < 1.
  template <int M, typename F>
  void add_residual(const std::vector<int>& blocks, F&& function, const RobustLoss& loss = {});

  const ManifoldValues& values() const { return values_; }
  ManifoldValues& values() { return values_; }
  std::size_t num_residual_blocks() const { return terms_.size(); }
  /// @brief Sum of the tangent sizes of the free blocks (the size of the normal equations).
  int num_free_parameters() const;

  /// @brief Cost 1/2 sum_k rho_k(|r_k|^2) at the current values.
  double cost() const;

  /// @brief Largest relative difference between each residual's analytic Jacobian and central
  ///        differences through the retraction (step `eps`), over all residuals and blocks
  ///        (constant ones included): a check for whoever writes a residual function.
  double max_jacobian_error(double eps = 1e-6) const;

  /// @cond internal
  const std::vector<std::unique_ptr<optim_detail::TermBase>>& terms() const { return terms_; }
  /// @endcond

 private:
  ManifoldValues values_;
  std::vector<bool> constant_;
  std::vector<std::unique_ptr<optim_detail::TermBase>> terms_;
};

/// @brief Gauss-Newton or Levenberg-Marquardt.
enum class LeastSquaresMethod {
  kGaussNewton,         ///< undamped steps, each one taken (fast near a good start, may diverge)
  kLevenbergMarquardt,  ///< damped steps, each accepted only when it does not raise the cost (LevenbergMarquardt)
};

/// @brief Settings of solve_least_squares().
struct LeastSquaresSettings {
  LeastSquaresMethod method = LeastSquaresMethod::kLevenbergMarquardt;  ///< algorithm
  int max_iterations = 50;            ///< linearisations (LM: each tries up to 10 damped steps)
  /// @brief Converged when an accepted step lowers the cost by less than this fraction of it. At a
  ///        minimum with a nonzero cost this leaves an error ~ sqrt(tolerance) in the variables:
  ///        lower it (or set 0) to stop on the step and gradient tolerances only.
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;  ///< converged when max |J^T W r| falls below this
  double step_tolerance = 1e-12;      ///< converged when |step| < tol (1 + |x|), x the R^n values
  double initial_lambda = 1e-4;       ///< LM damping, relative to diag(J^T W J) (Marquardt scaling)
  double max_lambda = 1e12;           ///< LM gives up (kNotConverged) when no step passes at this damping
};

/// @brief Outcome of solve_least_squares(); the solution is in problem.values().
struct LeastSquaresResult {
  Status status = Status::kNotConverged;  ///< kOk when converged; kInvalidInput for a non-finite start cost;
                                          ///< kDegenerate when Gauss-Newton's normal equations are singular
  bool converged = false;                 ///< a tolerance was met
  int iterations = 0;                     ///< linearisations done
  int num_rejected_steps = 0;             ///< LM steps that raised the cost (undone)
  double initial_cost = 0.0;              ///< 1/2 sum rho at the start
  double final_cost = 0.0;                ///< 1/2 sum rho at the solution
  /// @brief J^T W J at the solution over the free blocks (in block order): its inverse approximates
  ///        the covariance, its small eigenvalues reveal degenerate directions.
  Eigen::MatrixXd information;
};

/// @brief Minimise 1/2 sum rho(|r_k|^2) over the free blocks of `problem`, starting from its values.
/// @note Deterministic; single-threaded; O(iterations * (residual evaluations + n^3)), n the
///       number of free parameters. With no free parameter it only evaluates the cost.
LeastSquaresResult solve_least_squares(LeastSquaresProblem& problem, const LeastSquaresSettings& settings = {});

}  // namespace plumb

#include "plumb/optim/impl/least_squares_impl.hpp"
