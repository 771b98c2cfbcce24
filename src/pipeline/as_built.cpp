// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/pipeline/as_built.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>

#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {
namespace {

/// Observations whose normals are within this angle of a face's mean normal belong to it.
const double kFaceCos = std::cos(30.0 * kPi / 180.0);
constexpr std::size_t kMaxFaces = 8;

Matrix6d diagonal_information(double sigma_t, double sigma_r) {
  Vector6d d;
  d << Vector3d::Constant(1.0 / (sigma_t * sigma_t)), Vector3d::Constant(1.0 / (sigma_r * sigma_r));
  return d.asDiagonal();
}

/// Row of a residual n.(p - ...) with respect to a motion (translation, rotation about `centre`).
Vector6d motion_row(const Vector3d& n, const Vector3d& p, const Vector3d& centre) {
  Vector6d a;
  a << n, (p - centre).cross(n);
  return a;
}

/// A key point paired with a design point of an element.
struct Pair {
  std::size_t element;
  Vector6d a, h;  // rows of the pose error and of the element's displacement
  double z;       // n . (x - q), against the design
  double r;       // z against the element as estimated
  Vector3d n, q;
};

/// Pairs of one element in one frame lie on one surface, up to noise: those farther than
/// `distance` from the median residual of their element are clutter in front of it or another
/// surface behind it (a chair at a column, the wall behind a door frame), not the element.
void reject_outliers(std::vector<Pair>& pairs, std::size_t num_elements, double distance) {
  std::vector<std::vector<double>> residuals(num_elements);
  for (const Pair& p : pairs) residuals[p.element].push_back(p.r);
  std::vector<double> median(num_elements, 0.0);
  for (std::size_t e = 0; e < num_elements; ++e) {
    std::vector<double>& v = residuals[e];
    if (v.empty()) continue;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    median[e] = *mid;
  }
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(),
                             [&](const Pair& p) { return std::abs(p.r - median[p.element]) > distance; }),
              pairs.end());
}

/// Edge of the cells in which junctions are found [m]: a few thousand design points each.
constexpr double kJunctionCell = 2.0;

}  // namespace

bool AsBuiltMap::junction(std::size_t i) {
  if (cells_ == nullptr) return false;
  const PointCloud& design = *design_;
  const std::size_t c = cells_->cell(design.points[i]);
  if (!junction_done_[c]) {
    // The cell's points against every point within the radius of the cell: the same neighbours a
    // search over the whole cloud finds (the box is widened a little for rounding).
    junction_done_[c] = true;
    const double r = settings_.junction_radius;
    Eigen::AlignedBox3d box = cells_->cell_box(c);
    box.min().array() -= r + 1e-3;
    box.max().array() += r + 1e-3;
    std::vector<std::uint32_t> around;
    cells_->points_in_box(design.points, box, around);
    std::vector<Vector3f> points(around.size());
    for (std::size_t k = 0; k < around.size(); ++k) points[k] = design.points[around[k]];
    const KdTree3f tree(points);
    std::vector<std::size_t> near;
    std::vector<float> near_sq;
    for (const std::uint32_t* it = cells_->cell_begin(c); it != cells_->cell_end(c); ++it) {
      tree.radius(design.points[*it], static_cast<float>(r), near, near_sq, false);
      for (std::size_t k : near) {
        if (design.labels[around[k]] != design.labels[*it]) {
          junction_[*it] = true;
          break;
        }
      }
    }
  }
  return junction_[i];
}

PointCloud displaced_points(const PointCloud& design, const std::vector<std::uint32_t>& indices,
                            const Eigen::VectorXd& mean, const std::vector<Vector3d>& pivots) {
  PointCloud out;
  displaced_points(design, indices, mean, pivots, out);
  return out;
}

namespace {

/// Points per chunk of displaced_points() (a tall model's band is millions of points).
constexpr std::size_t kDisplaceGrain = 1 << 15;

/// One element's displacement in displaced_points(): q -> q + t + w x (q - pivot).
struct ElementMove {
  Vector3d t, w, pivot;
};

/// displaced_points() of the design points index(0), ..., index(count - 1).
template <typename Index>
void displace_into(const PointCloud& design, std::size_t count, Index index, const Eigen::VectorXd& mean,
                   const std::vector<Vector3d>& pivots, PointCloud& out, int threads) {
  PLUMB_CHECK(threads >= 0, "displaced_points: threads must be >= 0 (0 = every core), got " << threads);
  PLUMB_CHECK(design.has_labels() && design.has_normals(), "displaced_points: the cloud needs labels and normals");
  PLUMB_CHECK(&design != &out, "displaced_points: the output cannot be the design cloud itself");
  // Each element's displacement looked up once, not at each of its points (a tall model's band is
  // millions of points and a few hundred elements).
  const std::size_t elements = std::min(static_cast<std::size_t>(mean.size() / 6), pivots.size());
  std::vector<ElementMove> moves(elements);
  std::vector<char> moved(elements, 0);
  for (std::size_t e = 0; e < elements; ++e) {
    const Vector6d d = mean.segment<6>(static_cast<Eigen::Index>(6 * e));
    moved[e] = d.isZero(0.0) ? 0 : 1;
    moves[e] = ElementMove{d.head<3>(), d.tail<3>(), pivots[e]};
  }
  out.intensities.clear();
  out.rings.clear();
  out.times.clear();
  out.points.resize(count);
  out.normals.resize(count);
  out.labels.resize(count);
  // Each point is written from its own design point alone: any split of the points gives the same.
  parallel_for(threads, count, kDisplaceGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      const std::size_t i = index(k);
      PLUMB_CHECK(i < design.size(),
                  "displaced_points: index " << i << " out of range for " << design.size() << " points");
      const std::int32_t label = design.labels[i];
      out.labels[k] = label;
      if (label < 0 || static_cast<std::size_t>(label) >= elements || moved[static_cast<std::size_t>(label)] == 0) {
        out.points[k] = design.points[i];
        out.normals[k] = design.normals[i];
        continue;
      }
      const ElementMove& m = moves[static_cast<std::size_t>(label)];
      const Vector3d q = design.points[i].cast<double>();
      out.points[k] = (q + m.t + m.w.cross(q - m.pivot)).cast<float>();
      const Vector3d n = design.normals[i].cast<double>();
      out.normals[k] = (n + m.w.cross(n)).normalized().cast<float>();
    }
  });
}

}  // namespace

void displaced_points(const PointCloud& design, const std::vector<std::uint32_t>& indices,
                      const Eigen::VectorXd& mean, const std::vector<Vector3d>& pivots, PointCloud& out,
                      int threads) {
  displace_into(
      design, indices.size(), [&indices](std::size_t k) { return static_cast<std::size_t>(indices[k]); }, mean,
      pivots, out, threads);
}

void displaced_points(const PointCloud& design, const Eigen::VectorXd& mean, const std::vector<Vector3d>& pivots,
                      PointCloud& out, int threads) {
  displace_into(design, design.size(), [](std::size_t k) { return k; }, mean, pivots, out, threads);
}

double ElementEstimate::displacement_sigma(const Vector3d& q, const Vector3d& direction) const {
  const Vector6d h = motion_row(direction, q, pivot);
  return std::sqrt(std::max(0.0, h.dot(covariance * h)));
}

double ElementEstimate::face_offset_sigma() const {
  if (face_observations == 0) return std::sqrt(std::max(0.0, covariance(0, 0)));
  return displacement_sigma(face_point, face_normal);
}

std::vector<Vector3d> element_centroids(const PointCloud& cloud, std::vector<std::size_t>* counts) {
  PLUMB_CHECK(cloud.has_labels(), "element_centroids: the cloud has no element labels");
  std::int32_t max_label = -1;
  for (std::int32_t l : cloud.labels) max_label = std::max(max_label, l);
  const auto n = static_cast<std::size_t>(max_label + 1);
  std::vector<Vector3d> centroid(n, Vector3d::Zero());
  std::vector<std::size_t> count(n, 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.labels[i] < 0) continue;
    const auto e = static_cast<std::size_t>(cloud.labels[i]);
    centroid[e] += cloud.points[i].cast<double>();
    ++count[e];
  }
  for (std::size_t e = 0; e < n; ++e) {
    if (count[e] > 0) centroid[e] /= static_cast<double>(count[e]);
  }
  if (counts != nullptr) *counts = std::move(count);
  return centroid;
}

AsBuiltMap::AsBuiltMap(std::shared_ptr<const PointCloud> design_cloud, const AsBuiltSettings& settings)
    : settings_(settings), design_(std::move(design_cloud)) {
  const AsBuiltSettings& s = settings;
  PLUMB_CHECK(s.sigma_translation > 0.0 && s.sigma_rotation > 0.0 && std::isfinite(s.sigma_translation) &&
                  std::isfinite(s.sigma_rotation),
              "AsBuiltMap: sigma_translation and sigma_rotation must be positive and finite");
  PLUMB_CHECK(s.point_sigma > 0.0 && std::isfinite(s.point_sigma), "AsBuiltMap: point_sigma must be positive");
  PLUMB_CHECK(s.max_points_per_element >= 1.0, "AsBuiltMap: max_points_per_element must be >= 1");
  PLUMB_CHECK(s.pose_sigma_translation > 0.0 && s.pose_sigma_rotation > 0.0,
              "AsBuiltMap: pose_sigma_translation and pose_sigma_rotation must be positive");
  PLUMB_CHECK(s.max_residual > 0.0, "AsBuiltMap: max_residual must be positive");
  PLUMB_CHECK(s.outlier_distance > 0.0, "AsBuiltMap: outlier_distance must be positive");
  PLUMB_CHECK(s.junction_radius >= 0.0 && std::isfinite(s.junction_radius),
              "AsBuiltMap: junction_radius must be >= 0");
  PLUMB_CHECK(s.decorrelation_distance >= 0.0 && std::isfinite(s.decorrelation_distance),
              "AsBuiltMap: decorrelation_distance must be >= 0");
  PLUMB_CHECK(design_ != nullptr, "AsBuiltMap: no design cloud");
  const PointCloud& design = *design_;
  design.check_consistent("AsBuiltMap: design");
  PLUMB_CHECK(design.has_normals(), "AsBuiltMap: the design cloud has no normals");
  PLUMB_CHECK(design.has_labels(), "AsBuiltMap: the design cloud has no element labels");
  prior_information_ = diagonal_information(s.sigma_translation, s.sigma_rotation);
  std::int32_t max_label = -1;
  for (std::int32_t l : design.labels) {
    PLUMB_CHECK(l >= 0, "AsBuiltMap: the design cloud has a negative element label " << l);
    max_label = std::max(max_label, l);
  }
  elements_.resize(static_cast<std::size_t>(max_label + 1));
  std::vector<std::size_t> count;
  const std::vector<Vector3d> centroid = element_centroids(design, &count);
  junction_.assign(design.size(), false);
  if (s.junction_radius > 0.0 && design.size() > 0) {
    cells_ = std::make_unique<CellIndex>(design.points, std::max(kJunctionCell, 4.0 * s.junction_radius));
    junction_done_.assign(cells_->num_cells(), false);
  }
  information_.resize(elements_.size());
  gradient_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(6 * elements_.size()));
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    State& st = elements_[e];
    st.present = count[e] > 0;
    st.pivot = centroid[e];
  }
}

struct AsBuiltMap::Solution {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  Eigen::VectorXd mean;
};

std::size_t AsBuiltMap::observe(const std::vector<IcpCorrespondence>& pairs, const Vector3d& robot_position) {
  const Eigen::VectorXd& mu = mean();
  std::vector<Pair> used;
  used.reserve(pairs.size());
  std::vector<std::size_t> per_element(elements_.size(), 0);
  for (const IcpCorrespondence& c : pairs) {
    if (c.target_index >= design_->size() || junction(c.target_index)) continue;
    const auto e = static_cast<std::size_t>(design_->labels[c.target_index]);
    const Vector3d q = design_->points[c.target_index].cast<double>();
    const Vector3d n = design_->normals[c.target_index].cast<double>().normalized();
    if (!c.x.allFinite() || !n.allFinite()) continue;
    const Vector6d h = motion_row(n, q, elements_[e].pivot);
    const double z = n.dot(c.x - q);
    const double r = z - h.dot(mu.segment<6>(static_cast<Eigen::Index>(6 * e)));
    // Gate on the residual against the element as estimated: farther pairs are clutter or another surface.
    if (!(std::abs(r) <= settings_.max_residual)) continue;
    used.push_back({e, motion_row(n, c.x, robot_position), h, z, r, n, q});
  }
  reject_outliers(used, elements_.size(), settings_.outlier_distance);
  for (const Pair& p : used) ++per_element[p.element];
  if (used.empty()) return 0;

  // The frame's normal equations over its pose error and the displacements of the elements it saw,
  // for the cost sum w (z + a.d_pose - h.delta_e)^2, at zero.
  std::vector<std::size_t> seen;  // the elements of this frame, and each one's slot in it
  std::vector<std::size_t> slot(elements_.size(), 0);
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    if (per_element[e] == 0) continue;
    slot[e] = seen.size();
    seen.push_back(e);
  }
  const auto k = static_cast<Eigen::Index>(6 * seen.size());
  Eigen::MatrixXd Hee = Eigen::MatrixXd::Zero(k, k), Hep = Eigen::MatrixXd::Zero(k, 6);
  Eigen::VectorXd ge = Eigen::VectorXd::Zero(k);
  Matrix6d Hpp = diagonal_information(settings_.pose_sigma_translation, settings_.pose_sigma_rotation);
  Vector6d gp = Vector6d::Zero();
  std::vector<double> viewpoint(elements_.size(), 1.0);  // how new this frame's view of each element is
  for (std::size_t e : seen) {
    const State& st = elements_[e];
    if (!st.seen || settings_.decorrelation_distance <= 0.0) continue;
    viewpoint[e] = std::min(1.0, (robot_position - st.last_position).norm() / settings_.decorrelation_distance);
  }
  const double w0 = 1.0 / (settings_.point_sigma * settings_.point_sigma);
  for (const Pair& p : used) {
    const double w = w0 * viewpoint[p.element] *
                     std::min(1.0, settings_.max_points_per_element / static_cast<double>(per_element[p.element]));
    const auto o = static_cast<Eigen::Index>(6 * slot[p.element]);
    Hee.block<6, 6>(o, o).noalias() += w * p.h * p.h.transpose();
    Hep.block<6, 6>(o, 0).noalias() -= w * p.h * p.a.transpose();
    ge.segment<6>(o).noalias() -= w * p.z * p.h;
    Hpp.noalias() += w * p.a * p.a.transpose();
    gp.noalias() += w * p.z * p.a;
  }
  // Eliminate the pose error: the elements' information is what remains once it is unknown.
  const Eigen::LDLT<Matrix6d> S(Hpp);
  const Eigen::MatrixXd SinvHpe = S.solve(Hep.transpose());
  const Eigen::MatrixXd H = Hee - Hep * SinvHpe;
  const Eigen::VectorXd g = ge - SinvHpe.transpose() * gp;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const auto oi = static_cast<Eigen::Index>(6 * i);
    gradient_.segment<6>(static_cast<Eigen::Index>(6 * seen[i])) += g.segment<6>(oi);
    for (std::size_t j = i; j < seen.size(); ++j) {
      const auto oj = static_cast<Eigen::Index>(6 * j);
      Matrix6d block = H.block<6, 6>(oi, oj);
      if (i == j) block = 0.5 * (block + block.transpose()).eval();
      auto [it, inserted] = information_[seen[i]].try_emplace(seen[j], block);
      if (!inserted) it->second += block;
    }
  }
  for (std::size_t e : seen) {
    State& st = elements_[e];
    st.observations += per_element[e];
    ++st.frames;
    st.seen = true;
    st.last_position = robot_position;
  }
  for (const Pair& p : used) {
    std::vector<Face>& faces = elements_[p.element].faces;
    auto it = std::find_if(faces.begin(), faces.end(),
                           [&](const Face& f) { return f.normal_sum.normalized().dot(p.n) > kFaceCos; });
    if (it == faces.end()) {
      if (faces.size() >= kMaxFaces) continue;
      faces.emplace_back();
      it = faces.end() - 1;
    }
    it->normal_sum += p.n;
    it->point_sum += p.q;
    ++it->count;
  }
  solution_.reset();
  return used.size();
}

const AsBuiltMap::Solution& AsBuiltMap::solve() const {
  if (solution_ != nullptr) return *solution_;
  const auto n = static_cast<Eigen::Index>(6 * elements_.size());
  std::vector<Eigen::Triplet<double>> triplets;
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    for (int r = 0; r < 6; ++r) triplets.emplace_back(6 * e + r, 6 * e + r, prior_information_(r, r));
    for (const auto& [f, block] : information_[e]) {
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < 6; ++c) {
          triplets.emplace_back(6 * e + r, 6 * f + c, block(r, c));
          if (f != e) triplets.emplace_back(6 * f + c, 6 * e + r, block(r, c));
        }
      }
    }
  }
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(triplets.begin(), triplets.end());
  auto solution = std::make_shared<Solution>();
  solution->ldlt.compute(A);
  PLUMB_CHECK(solution->ldlt.info() == Eigen::Success, "AsBuiltMap: the information matrix is not positive definite");
  solution->mean = -solution->ldlt.solve(gradient_);
  solution_ = solution;
  return *solution_;
}

const Eigen::VectorXd& AsBuiltMap::mean() const { return solve().mean; }

ElementEstimate AsBuiltMap::element(std::size_t e) const {
  PLUMB_CHECK(e < elements_.size(), "AsBuiltMap::element: no element " << e << " (have " << elements_.size() << ")");
  const State& st = elements_[e];
  const Solution& sol = solve();
  ElementEstimate out;
  out.pivot = st.pivot;
  out.mean = sol.mean.segment<6>(static_cast<Eigen::Index>(6 * e));
  // The marginal covariance: the element's 6 columns of the inverse.
  Eigen::MatrixXd unit = Eigen::MatrixXd::Zero(sol.mean.size(), 6);
  unit.block<6, 6>(static_cast<Eigen::Index>(6 * e), 0).setIdentity();
  const Eigen::MatrixXd columns = sol.ldlt.solve(unit);
  out.covariance = columns.block<6, 6>(static_cast<Eigen::Index>(6 * e), 0);
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  out.observations = st.observations;
  out.frames = st.frames;
  const Face* best = nullptr;
  for (const Face& f : st.faces) {
    if (best == nullptr || f.count > best->count) best = &f;
  }
  if (best != nullptr) {
    out.face_normal = best->normal_sum.normalized();
    out.face_point = best->point_sum / static_cast<double>(best->count);
    out.face_observations = best->count;
  }
  return out;
}

PointCloud AsBuiltMap::corrected_cloud() const {
  std::vector<Vector3d> pivots(elements_.size());
  for (std::size_t e = 0; e < elements_.size(); ++e) pivots[e] = elements_[e].pivot;
  PointCloud out;
  displaced_points(*design_, mean(), pivots, out);
  out.intensities = design_->intensities;
  out.rings = design_->rings;
  out.times = design_->times;
  return out;
}

const char* deviation_status_name(DeviationStatus s) {
  switch (s) {
    case DeviationStatus::kOk: return "ok";
    case DeviationStatus::kDeviates: return "deviates";
    case DeviationStatus::kUnobserved: return "unobserved";
  }
  return "unknown";
}

std::vector<DeviationReportRow> deviation_report(const AsBuiltMap& map, const bim::BimMesh& mesh, double tolerance_m) {
  PLUMB_CHECK(tolerance_m > 0.0 && std::isfinite(tolerance_m),
              "deviation_report: the tolerance must be positive, got " << tolerance_m);
  PLUMB_CHECK(map.num_elements() <= mesh.elements.size(),
              "deviation_report: the as-built map has " << map.num_elements() << " elements, the model "
                                                          << mesh.elements.size());
  std::vector<DeviationReportRow> rows;
  for (std::size_t e = 0; e < map.num_elements(); ++e) {
    if (!map.has_points(e)) continue;
    const ElementEstimate est = map.element(e);
    const bim::BimElement& el = mesh.elements[e];
    DeviationReportRow d;
    d.element = e;
    d.global_id = el.global_id;
    d.type = el.type;
    d.name = el.name;
    if (el.storey >= 0 && static_cast<std::size_t>(el.storey) < mesh.storeys.size()) {
      d.storey = mesh.storeys[static_cast<std::size_t>(el.storey)].name;
    }
    d.observations = est.observations;
    d.normal = est.face_normal;
    d.point = est.face_point;
    d.offset_m = est.face_offset();
    d.sigma_m = est.face_offset_sigma();
    d.rotation_deg = est.mean.tail<3>().norm() * 180.0 / kPi;
    if (est.face_observations == 0 || d.sigma_m > 0.9 * map.settings().sigma_translation) {
      d.status = DeviationStatus::kUnobserved;
    } else if (std::abs(d.offset_m) - 3.0 * d.sigma_m > tolerance_m) {
      d.status = DeviationStatus::kDeviates;
    } else {
      d.status = DeviationStatus::kOk;
    }
    rows.push_back(std::move(d));
  }
  return rows;
}

}  // namespace plumb
