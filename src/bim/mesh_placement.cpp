// SPDX-License-Identifier: BSD-3-Clause
// The Builder's access to the STEP file (checked arguments, references and numbers, the failures that
// name an entity, the tally of unsupported types), and the geometry every item is placed with:
// points and directions, IfcAxis2Placement2D/3D, IfcLocalPlacement chains (cached) and
// IfcCartesianTransformationOperator.
#include "mesh_builder.hpp"

#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb::bim::mesh_detail {

void Builder::fail(std::uint32_t id, const std::string& msg) const {
  PLUMB_THROW(f_.where(id) << ": " << f_.type_of(id) << " #" << id << ": " << msg);
}

void Builder::check_depth(std::uint32_t id, int depth) const {
  if (depth > settings_.max_depth) {
    fail(id, "reference chain deeper than " + std::to_string(settings_.max_depth) + " (cycle?)");
  }
}

Args Builder::args_of(std::uint32_t id, std::size_t min_args) const {
  if (!f_.contains(id)) PLUMB_THROW(f_.name() << ": dangling reference #" << id);
  Args a = f_.args(id);
  if (a.size() < min_args) fail(id, "expects at least " + std::to_string(min_args) + " arguments");
  return a;
}

std::uint32_t Builder::ref(const StepValue& v, std::uint32_t owner, const char* what) const {
  if (!v.is_ref()) fail(owner, std::string(what) + " is not a reference");
  if (!f_.contains(v.ref)) fail(owner, std::string(what) + " refers to missing #" + std::to_string(v.ref));
  return v.ref;
}

double Builder::num(const StepValue& v, std::uint32_t owner, const char* what) const {
  const double x = v.number();
  if (!std::isfinite(x) || std::abs(x) > 1e12) fail(owner, std::string(what) + " is not a finite number");
  return x;
}

void Builder::unsupported(std::uint32_t id) {
  auto& e = unsupported_[f_.type_of(id)];
  if (e.first++ == 0) e.second = id;
}

Vector3d Builder::point3(std::uint32_t id) const {
  const Args a = args_of(id, 1);
  if (!a[0].is_list() || a[0].items.empty() || a[0].items.size() > 3) fail(id, "expects a coordinate list");
  Vector3d p = Vector3d::Zero();
  for (std::size_t i = 0; i < a[0].items.size(); ++i) p[static_cast<int>(i)] = num(a[0].items[i], id, "coordinate");
  return p;
}

Vector3d Builder::direction(std::uint32_t id) const {
  Vector3d d = point3(id);  // IfcDirection has the same layout
  const double n = d.norm();
  if (!(n > 0.0)) fail(id, "zero direction");
  return d / n;
}

Vector3d Builder::opt_dir(const StepValue& v, std::uint32_t owner, const Vector3d& dflt) const {
  if (v.is_null()) return dflt;
  return direction(ref(v, owner, "direction"));
}

Eigen::Matrix3d Builder::frame_from(const Vector3d& z_in, const Vector3d& x_in) {
  const Vector3d z = z_in.normalized();
  Vector3d x = x_in - x_in.dot(z) * z;
  if (x.norm() < 1e-12) {
    x = std::abs(z.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
    x = (x - x.dot(z) * z);
  }
  x.normalize();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

/// IfcAxis2Placement3D / 2D (or $ -> identity).
Affine Builder::axis_placement(const StepValue& v, std::uint32_t owner) const {
  if (v.is_null()) return Affine::Identity();
  const std::uint32_t id = ref(v, owner, "placement");
  const std::string& t = f_.type_of(id);
  Affine T = Affine::Identity();
  if (t == "IFCAXIS2PLACEMENT3D") {
    const Args a = args_of(id, 3);
    const Vector3d o = point3(ref(a[0], id, "Location"));
    const Vector3d z = opt_dir(a[1], id, Vector3d::UnitZ());
    const Vector3d x = opt_dir(a[2], id, Vector3d::UnitX());
    T.linear() = frame_from(z, x);
    T.translation() = o;
  } else if (t == "IFCAXIS2PLACEMENT2D") {
    const Args a = args_of(id, 2);
    const Vector3d o = point3(ref(a[0], id, "Location"));
    Vector3d x = opt_dir(a[1], id, Vector3d::UnitX());
    x.z() = 0.0;
    T.linear() = frame_from(Vector3d::UnitZ(), x);
    T.translation() = Vector3d(o.x(), o.y(), 0.0);
  } else {
    fail(id, "unsupported placement type");
  }
  return T;
}

Affine Builder::local_placement(std::uint32_t id, int depth) {
  check_depth(id, depth);
  auto it = placement_cache_.find(id);
  if (it != placement_cache_.end()) return it->second;
  const std::string& t = f_.type_of(id);
  Affine T = Affine::Identity();
  if (t == "IFCLOCALPLACEMENT") {
    const Args a = args_of(id, 2);
    Affine parent = Affine::Identity();
    if (!a[0].is_null()) parent = local_placement(ref(a[0], id, "PlacementRelTo"), depth + 1);
    T = parent * axis_placement(a[1], id);
  } else {
    fail(id, "unsupported object placement");
  }
  placement_cache_.emplace(id, T);
  return T;
}

/// IfcCartesianTransformationOperator2D/3D (+NonUniform).
Affine Builder::transformation_operator(std::uint32_t id) const {
  const std::string& t = f_.type_of(id);
  const bool is3d = t.find("3D") != std::string::npos;
  const Args a = args_of(id, 4);
  const Vector3d origin = point3(ref(a[2], id, "LocalOrigin"));
  const double s1 = a[3].is_null() ? 1.0 : num(a[3], id, "Scale");
  double s2 = s1, s3 = s1;
  Vector3d z = Vector3d::UnitZ();
  if (is3d && a.size() >= 5 && !a[4].is_null()) z = direction(ref(a[4], id, "Axis3"));
  if (t.find("NONUNIFORM") != std::string::npos) {
    const std::size_t k = is3d ? 5 : 4;
    if (a.size() > k && !a[k].is_null()) s2 = num(a[k], id, "Scale2");
    if (is3d && a.size() > k + 1 && !a[k + 1].is_null()) s3 = num(a[k + 1], id, "Scale3");
  }
  Vector3d x = a[0].is_null() ? Vector3d::UnitX() : direction(ref(a[0], id, "Axis1"));
  Eigen::Matrix3d R = frame_from(z, x);
  if (!a[1].is_null()) {  // Axis2: projected orthogonal to z and x
    Vector3d y = direction(ref(a[1], id, "Axis2"));
    y = y - y.dot(R.col(2)) * R.col(2) - y.dot(R.col(0)) * R.col(0);
    if (y.norm() > 1e-12 && y.normalized().dot(R.col(1)) < 0.0) R.col(1) = -R.col(1);
  }
  Affine T = Affine::Identity();
  T.linear() = R * Vector3d(s1, s2, s3).asDiagonal();
  T.translation() = is3d ? origin : Vector3d(origin.x(), origin.y(), 0.0);
  return T;
}

}  // namespace plumb::bim::mesh_detail
