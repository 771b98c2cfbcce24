// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief Explicit instantiation declarations of the Eigen decompositions plumb's sources use
///        (symmetric eigen solvers, LDLT, LLT). Each costs every including file seconds of compile
///        time, so with PLUMB_EIGEN_EXTERN_TEMPLATES (set for plumb's own build tree) they are
///        compiled once, in plumb_core (src/core/eigen_instantiations.cpp). A private header of
///        src/, not installed: it names Eigen internals, which a user's Eigen may lay out otherwise.
///        Only decompositions of a plain matrix are covered.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace plumb::eigen_instantiations {
using Matrix3d = Eigen::Matrix3d;
using Matrix4d = Eigen::Matrix4d;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix15d = Eigen::Matrix<double, 15, 15>;
using MatrixXd = Eigen::MatrixXd;
}  // namespace plumb::eigen_instantiations

// `Prefix` is `extern template` (the declarations below) or `template` (the one definition). The
// symmetric eigen solvers as whole classes (computeDirect() too); LDLT / LLT only compute(), the rest
// of those classes (rcond(), ...) is small and stays inline.
#define PLUMB_EIGEN_SYMMETRIC_EIGEN(Prefix, M)                                     \
  Prefix class Eigen::SelfAdjointEigenSolver<plumb::eigen_instantiations::M>;      \
  Prefix Eigen::SelfAdjointEigenSolver<plumb::eigen_instantiations::M>&            \
  Eigen::SelfAdjointEigenSolver<plumb::eigen_instantiations::M>::compute(          \
      const Eigen::EigenBase<plumb::eigen_instantiations::M>&, int);
#define PLUMB_EIGEN_CHOLESKY(Prefix, Solver, M)                                    \
  Prefix Eigen::Solver<plumb::eigen_instantiations::M>&                            \
  Eigen::Solver<plumb::eigen_instantiations::M>::compute(const Eigen::EigenBase<plumb::eigen_instantiations::M>&);
#define PLUMB_EIGEN_INSTANTIATIONS(Prefix)     \
  PLUMB_EIGEN_SYMMETRIC_EIGEN(Prefix, Matrix3d) \
  PLUMB_EIGEN_SYMMETRIC_EIGEN(Prefix, Matrix4d) \
  PLUMB_EIGEN_SYMMETRIC_EIGEN(Prefix, Matrix6d) \
  PLUMB_EIGEN_CHOLESKY(Prefix, LDLT, Matrix6d)  \
  PLUMB_EIGEN_CHOLESKY(Prefix, LDLT, MatrixXd)  \
  PLUMB_EIGEN_CHOLESKY(Prefix, LLT, Matrix15d)  \
  PLUMB_EIGEN_CHOLESKY(Prefix, LLT, MatrixXd)

// The two halves of SelfAdjointEigenSolver<M>::compute(), for solvers built from an expression
// (`es(H / n)`, `es(D * H * D)`), whose compute<expression> the declarations above do not cover.
// Eigen internals: declared for the Eigen 3.4 signatures only.
#define PLUMB_EIGEN_TRIDIAGONAL(Prefix, N)                                                       \
  Prefix void Eigen::internal::tridiagonalization_inplace(                                       \
      Eigen::Matrix<double, N, N>&, Eigen::Matrix<double, N, 1>&, Eigen::Matrix<double, N - 1, 1>&, \
      Eigen::Matrix<double, N - 1, 1>&, bool);                                                   \
  Prefix Eigen::ComputationInfo Eigen::internal::computeFromTridiagonal_impl(                    \
      Eigen::Matrix<double, N, 1>&, Eigen::Matrix<double, N - 1, 1>&, const Eigen::Index, bool,    \
      Eigen::Matrix<double, N, N>&);
#if EIGEN_VERSION_AT_LEAST(3, 4, 0) && !EIGEN_VERSION_AT_LEAST(3, 4, 90)
#define PLUMB_EIGEN_TRIDIAGONAL_INSTANTIATIONS(Prefix) \
  PLUMB_EIGEN_TRIDIAGONAL(Prefix, 4)                  \
  PLUMB_EIGEN_TRIDIAGONAL(Prefix, 6)
#else
#define PLUMB_EIGEN_TRIDIAGONAL_INSTANTIATIONS(Prefix)
#endif

#if defined(PLUMB_EIGEN_EXTERN_TEMPLATES) && !defined(PLUMB_EIGEN_INSTANTIATIONS_DEFINE)
PLUMB_EIGEN_INSTANTIATIONS(extern template)
PLUMB_EIGEN_TRIDIAGONAL_INSTANTIATIONS(extern template)
#endif
