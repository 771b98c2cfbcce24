// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The inlier counting of fit_plane_ransac(), for plumb's own sources and tests (not installed).

#include <cstddef>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb::detail {

/// Candidate coordinates (and normals) gathered into contiguous float arrays, so the inlier count
/// of a hypothesis is one vectorizable pass.
struct PlaneCandidates {
  std::vector<float> x, y, z, nx, ny, nz;
  std::vector<std::size_t> index;  // into the caller's points
  bool has_normals = false;
};

/// Number of candidates within `tau` of plane (a, b, c, d) whose normal agrees (|n_i . n| >= cos_max).
/// Counts in blocks and gives up (returning a count <= `beat`) as soon as the remaining candidates
/// can no longer lift the count above `beat`: most hypotheses are poor and stop early.
std::size_t count_plane_inliers(const PlaneCandidates& c, float a, float b, float cc, float d, float tau,
                                float cos_max, std::size_t beat);

/// The candidates again, grouped by the direction of their normal about an axis, so that a
/// hypothesis only visits the groups whose normals can agree with its own (exact pruning: the
/// same count as count_plane_inliers()).
///
/// With unit vectors e1, e2, axis, a normal n = (n_a along the axis, n_p across it) and a
/// hypothesis h: |h.n| <= |h_a| max|n_a| + |h_p| max|n_p| max|cos(phi_h - phi_n)|, where phi is the
/// direction of the part across the axis, as a line (mod pi). Groups are bins of phi (through a
/// monotone pseudo-angle, no trigonometry); the max of |cos| over a bin that does not contain
/// phi_h is reached at one of its edges.
struct NormalBins {
  static constexpr int kBins = 32;
  std::vector<float> x, y, z, nx, ny, nz;  // candidates ordered by bin
  std::size_t start[kBins + 1] = {};
  double max_along[kBins] = {};   // max |n . axis| in the bin
  double max_across[kBins] = {};  // max |n - (n . axis) axis| in the bin
  double edge_u[kBins + 1] = {}, edge_v[kBins + 1] = {};  // unit edge directions in (e1, e2)
  Vector3d axis, e1, e2;

  /// Pseudo-angle in [0, 2) of the line through (u, v): monotone in its angle in [0, pi).
  static double line_pseudo_angle(double u, double v);
  static int bin_of(double t);

  /// Groups the candidates (with normals) of `c` about `unit_axis`.
  void build(const PlaneCandidates& c, const Vector3d& unit_axis);

  /// count_plane_inliers() over the bins that can hold agreeing normals.
  std::size_t count(const Vector3d& h, float a, float b, float cc, float d, float tau, float cos_max,
                    std::size_t beat) const;
};

}  // namespace plumb::detail
