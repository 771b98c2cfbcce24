// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The building as built, estimated while the robot drives: every element of the model is a
///        landmark whose small rigid displacement from its design pose is estimated online from the
///        key points registered to it.
///
/// Unknowns: for every element e a displacement delta_e = (t, w) — translation t and rotation w about
/// the element's pivot c_e (the centroid of its design points) — so that a design point q of e is as
/// built at q + t + w x (q - c_e). A zero-mean prior from the construction tolerance
/// (sigma_translation, sigma_rotation per axis) makes the elements independent a priori and keeps
/// the design frame as the datum.
///
/// A frame's registered key points observe the elements they were paired with: a key point x
/// (world frame, at the registered pose) paired with design point q of e, normal n, gives the
/// residual n.(x - q) + [n; (x - c) x n] . d_pose - [n; (q - c_e) x n] . delta_e, linear in the
/// unknowns, with d_pose the error of the frame's pose (a motion about the robot position c). That
/// pose error is shared by every point of the frame, so it is eliminated (Schur complement, under a
/// weak prior) before the frame's information joins the others: the elements are measured only
/// against each other, never against a pose the same points have just fitted, and elements seen
/// together become correlated. The joint information over all elements is sparse (elements couple
/// only when seen in one frame); it is solved exactly (sparse LDL^T) when the estimate is asked for.
/// Directions no frame constrains — an element seen edge-on, a wall's in-plane translation, what
/// all elements of a view share — keep their prior.
///
/// Errors that repeat are not counted as new information: the points of one element in one frame
/// share their errors (range bias, the element's unevenness) and count as at most
/// `max_points_per_element` points, and a frame counts in full only once the robot has moved
/// `decorrelation_distance` since the element was last seen. Pairs at junctions between elements,
/// where a key point's element is ambiguous, are not used.
///
/// The corrected BIM cloud (`corrected_cloud`) moves every design point and normal by its element's
/// current estimate: the registration of later frames is done against it.

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/types.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/search/cell_index.hpp"

namespace plumb {

/// @brief Centroid of each element's points in a labelled cloud: entry e is the mean of the points
///        labelled e (zero for a label no point carries); points with a negative label are skipped.
///        The pivot about which AsBuiltMap and the element-weighted anchors turn an element.
/// @param counts when not null, receives the number of points of each element
/// @throws plumb::Error when the cloud has no labels
std::vector<Vector3d> element_centroids(const PointCloud& cloud, std::vector<std::size_t>* counts = nullptr);

/// @brief The points `indices` of a labelled design cloud (with its normals and labels), every
///        element e displaced by mean.segment<6>(6 e) = (t, w) about pivots[e]: a design point q at
///        q + t + w x (q - pivot), its normal n at normalize(n + w x n); elements without an entry
///        in `mean` (or a zero one) stay where they are. AsBuiltMap::corrected_cloud() is this over
///        every point, with the current estimate.
/// @throws plumb::Error when the cloud has no labels or normals, or an index is out of range
PointCloud displaced_points(const PointCloud& design, const std::vector<std::uint32_t>& indices,
                            const Eigen::VectorXd& mean, const std::vector<Vector3d>& pivots);
/// @brief The same into `out` (its points, normals and labels replaced; their memory reused), on
///        up to `threads` threads (0 = every core; the result is the same for any count).
void displaced_points(const PointCloud& design, const std::vector<std::uint32_t>& indices,
                      const Eigen::VectorXd& mean, const std::vector<Vector3d>& pivots, PointCloud& out,
                      int threads = 1);
/// @brief displaced_points() of every point of `design`, into `out`.
void displaced_points(const PointCloud& design, const Eigen::VectorXd& mean, const std::vector<Vector3d>& pivots,
                      PointCloud& out, int threads = 1);

/// @brief Settings of AsBuiltMap.
struct AsBuiltSettings {
  double sigma_translation = 0.01;  ///< construction tolerance, per axis [m] (prior of every element)
  double sigma_rotation = 0.2 * kPi / 180.0;  ///< construction tolerance, per axis [rad]
  double point_sigma = 0.02;        ///< std of one key point's residual along its normal (range noise, unevenness) [m]
  /// The points of one element in one frame count as at most this many independent points.
  double max_points_per_element = 20.0;
  double pose_sigma_translation = 1.0;  ///< weak prior of a frame's pose error, per axis [m]
  double pose_sigma_rotation = 10.0 * kPi / 180.0;  ///< likewise, per axis [rad]
  /// Largest |n . (x - q(mu))| [m] a pair may have to count: farther pairs are clutter or another
  /// surface, not the element moved by a construction tolerance.
  double max_residual = 0.08;
  /// Pairs farther than this from the median residual of their element in the frame are not the
  /// element (clutter in front of it, another surface behind it) [m].
  double outlier_distance = 0.03;
  /// Design points within this distance of another element's points are at a junction (wall
  /// meets slab, column in a wall), where a key point's element is ambiguous: their pairs do not
  /// count [m].
  double junction_radius = 0.1;
  /// An element's errors from one viewpoint repeat in the next frames (the same range biases, the
  /// same pose error): a frame counts in full only once the robot has moved this far since the
  /// element was last observed, in proportion before [m].
  double decorrelation_distance = 2.0;
};

/// @brief One element's estimate.
struct ElementEstimate {
  Vector3d pivot = Vector3d::Zero();        ///< c_e, centroid of the element's design points (world) [m]
  Vector6d mean = Vector6d::Zero();         ///< (t [m], w [rad]) of the displacement about the pivot
  Matrix6d covariance = Matrix6d::Zero();   ///< of `mean`
  std::size_t observations = 0;             ///< key points paired with the element so far
  std::size_t frames = 0;                   ///< frames in which it was observed
  /// The face seen most: outward unit normal (world) and the mean design point of its observations.
  Vector3d face_normal = Vector3d::Zero();
  Vector3d face_point = Vector3d::Zero();
  std::size_t face_observations = 0;        ///< observations on that face
  /// @brief The displacement of a design point q of the element, and its std along a unit direction.
  Vector3d displacement(const Vector3d& q) const { return mean.head<3>() + mean.tail<3>().cross(q - pivot); }
  double displacement_sigma(const Vector3d& q, const Vector3d& direction) const;
  /// @brief The displacement of the main face along its normal [m] (0 when never observed).
  double face_offset() const { return face_observations > 0 ? face_normal.dot(displacement(face_point)) : 0.0; }
  /// @brief Its std [m] (the prior's when never observed).
  double face_offset_sigma() const;
};

/// @brief Online estimate of every element's as-built displacement (see the file comment).
/// @note Not thread-safe; deterministic.
class AsBuiltMap {
 public:
  /// @param design the BIM cloud with normals and per-point element labels (bim::sample_bim_cloud);
  ///        shared, not copied
  /// @throws plumb::Error when the cloud is null, has no normals or labels, a negative label, or
  ///         bad settings
  explicit AsBuiltMap(std::shared_ptr<const PointCloud> design, const AsBuiltSettings& settings = {});
  /// @brief The same on a copy of `design`.
  explicit AsBuiltMap(const PointCloud& design, const AsBuiltSettings& settings = {})
      : AsBuiltMap(std::make_shared<const PointCloud>(design), settings) {}

  /// @brief Take one frame's registration: its correspondences (source points moved by the
  ///        registered pose, target indices into `design`) and the robot position the pose error
  ///        turns about. Returns the number of pairs used.
  std::size_t observe(const std::vector<IcpCorrespondence>& pairs, const Vector3d& robot_position);

  /// @brief The design cloud moved element by element by the current estimates (normals turned).
  PointCloud corrected_cloud() const;
  /// @brief The design cloud the map was made from.
  const PointCloud& design() const { return *design_; }
  /// @brief The estimate of every element: 6 per element, (t, w) of element e at 6e.
  const Eigen::VectorXd& mean() const;

  std::size_t num_elements() const { return elements_.size(); }
  /// @brief Estimate of element e (label value e of the design cloud). @throws plumb::Error when out of range.
  ElementEstimate element(std::size_t e) const;
  /// @brief Frames in which element e was observed (0 for an element out of range).
  std::size_t frames(std::size_t e) const { return e < elements_.size() ? elements_[e].frames : 0; }
  /// @brief True when the design cloud has points of element e.
  bool has_points(std::size_t e) const { return e < elements_.size() && elements_[e].present; }
  const AsBuiltSettings& settings() const { return settings_; }

 private:
  struct Face {
    Vector3d normal_sum = Vector3d::Zero();
    Vector3d point_sum = Vector3d::Zero();
    std::size_t count = 0;
  };
  struct State {
    Vector3d pivot = Vector3d::Zero();
    std::size_t observations = 0, frames = 0;
    std::vector<Face> faces;
    bool present = false;  ///< the design cloud has points of it
    bool seen = false;     ///< observed at least once; then last_position is where from
    Vector3d last_position = Vector3d::Zero();
  };

  AsBuiltSettings settings_;
  std::shared_ptr<const PointCloud> design_;
  /// Per design point: near another element's points. Found cell by cell of `cells_` when a pair
  /// first lands in the cell (`junction_done_`), so a building's size costs nothing until the
  /// robot sees it.
  std::vector<bool> junction_;
  std::vector<bool> junction_done_;
  std::unique_ptr<CellIndex> cells_;
  bool junction(std::size_t i);
  std::vector<State> elements_;
  Matrix6d prior_information_ = Matrix6d::Zero();
  /// The data's information over all elements: for element e, the 6x6 blocks (e, f) with f >= e.
  std::vector<std::map<std::size_t, Matrix6d>> information_;
  Eigen::VectorXd gradient_;  ///< the data's gradient at zero displacement
  struct Solution;
  /// The prior plus the data, factorised, and the mean; made when asked for after new data.
  mutable std::shared_ptr<const Solution> solution_;
  const Solution& solve() const;
};

/// @brief What the deviation report says of one element.
enum class DeviationStatus {
  kOk,          ///< observed; within the tolerance, or not beyond it with 3 sigma confidence
  kDeviates,    ///< |offset| - 3 sigma > tolerance
  kUnobserved,  ///< never observed, or its face offset's sigma is still above 0.9 of the prior's
};

/// @brief Stable lower-case name ("ok", "deviates", "unobserved").
const char* deviation_status_name(DeviationStatus s);

/// @brief One element of the deviation report.
struct DeviationReportRow {
  std::size_t element = 0;      ///< index in BimMesh::elements (the BIM cloud's label)
  std::string global_id, type, name, storey;  ///< from the model (storey: its name, empty when none)
  std::size_t observations = 0; ///< key points paired with the element
  Vector3d normal = Vector3d::Zero();  ///< outward unit normal of the face seen most (world)
  Vector3d point = Vector3d::Zero();   ///< a point of that face in the design (world) [m]
  double offset_m = 0.0;        ///< signed displacement of that face along `normal` [m]
  double sigma_m = 0.0;         ///< its std [m]
  double rotation_deg = 0.0;    ///< magnitude of the element's estimated rotation [deg]
  DeviationStatus status = DeviationStatus::kUnobserved;
};

/// @brief The deviation report of every element the BIM cloud has points of, in element order.
/// @param tolerance_m construction tolerance an offset is judged against [m] (> 0)
/// @throws plumb::Error when the map has elements the mesh does not, or tolerance_m <= 0
std::vector<DeviationReportRow> deviation_report(const AsBuiltMap& map, const bim::BimMesh& mesh, double tolerance_m);

}  // namespace plumb
