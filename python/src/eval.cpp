// SPDX-License-Identifier: BSD-3-Clause
// Trajectory evaluation: association, APE, RPE, Umeyama alignment, error statistics.
#include <cstdint>
#include <utility>

#include "convert.hpp"
#include "plumb/eval/align.hpp"
#include "plumb/eval/metrics.hpp"

namespace plumb::python {
namespace {

py::array pairs_to_array(const std::vector<std::pair<std::size_t, std::size_t>>& pairs) {
  py::array_t<std::int64_t> out({static_cast<py::ssize_t>(pairs.size()), py::ssize_t{2}});
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    out.mutable_data()[2 * i] = static_cast<std::int64_t>(pairs[i].first);
    out.mutable_data()[2 * i + 1] = static_cast<std::int64_t>(pairs[i].second);
  }
  return std::move(out);
}

void bind_eval_enums(py::module_& m) {
  py::enum_<eval::AlignMode>(m, "AlignMode", "Which similarity to fit between estimate and reference.")
      .value("none", eval::AlignMode::kNone)
      .value("se3", eval::AlignMode::kSE3)
      .value("sim3", eval::AlignMode::kSim3);
  py::enum_<eval::PositionAxes>(m, "PositionAxes", "Components of a position difference or a path length.")
      .value("xyz", eval::PositionAxes::kXYZ)
      .value("xy", eval::PositionAxes::kXY);
  py::enum_<eval::PathSource>(m, "PathSource", "Which trajectory measures distance travelled.")
      .value("reference", eval::PathSource::kReference)
      .value("estimate", eval::PathSource::kEstimate);
  py::enum_<eval::DeltaUnit>(m, "DeltaUnit", "Unit of the RPE step.")
      .value("frames", eval::DeltaUnit::kFrames)
      .value("meters", eval::DeltaUnit::kMeters);
}

void bind_eval_settings(py::module_& m) {
  py::class_<eval::AssociationSettings>(m, "AssociationSettings", "How associate() pairs two trajectories.")
      .def(py::init<>())
      .def_readwrite("max_time_difference", &eval::AssociationSettings::max_time_difference)
      .def_readwrite("time_offset", &eval::AssociationSettings::time_offset)
      .def_readwrite("min_pairs", &eval::AssociationSettings::min_pairs)
      .def_readwrite("min_pair_fraction", &eval::AssociationSettings::min_pair_fraction);
  py::class_<eval::ApeSettings>(m, "ApeSettings", "Settings of ape().")
      .def(py::init<>())
      .def_readwrite("align", &eval::ApeSettings::align)
      .def_readwrite("axes", &eval::ApeSettings::axes);
  py::class_<eval::RpeSettings>(m, "RpeSettings", "Settings of rpe().")
      .def(py::init<>())
      .def_readwrite("delta", &eval::RpeSettings::delta)
      .def_readwrite("unit", &eval::RpeSettings::unit)
      .def_readwrite("align", &eval::RpeSettings::align)
      .def_readwrite("pairs_along", &eval::RpeSettings::pairs_along);
}

void bind_eval_results(py::module_& m) {
  py::class_<eval::ErrorStats>(m, "ErrorStats", "Summary statistics of a list of errors, as numpy computes them.")
      .def_readonly("rmse", &eval::ErrorStats::rmse)
      .def_readonly("mean", &eval::ErrorStats::mean)
      .def_readonly("median", &eval::ErrorStats::median)
      .def_readonly("std", &eval::ErrorStats::std)
      .def_readonly("min", &eval::ErrorStats::min)
      .def_readonly("max", &eval::ErrorStats::max)
      .def_readonly("sse", &eval::ErrorStats::sse)
      .def_readonly("count", &eval::ErrorStats::count);
  py::class_<eval::ErrorSeries>(m, "ErrorSeries", "Per-pose errors (float64 array) and their statistics.")
      .def_property_readonly("values", [](const eval::ErrorSeries& s) { return vector_to_array(s.values); })
      .def_readonly("stats", &eval::ErrorSeries::stats);
  py::class_<eval::UmeyamaResult>(m, "UmeyamaResult", "The similarity p_ref = scale * R * p_est + t.")
      .def_property_readonly("T_ref_est", [](const eval::UmeyamaResult& r) { return pose_to_array(r.T_ref_est); })
      .def_readonly("scale", &eval::UmeyamaResult::scale)
      .def_readonly("rmse", &eval::UmeyamaResult::rmse)
      .def_readonly("status", &eval::UmeyamaResult::status);
  py::class_<eval::AlignResult>(m, "AlignResult", "An estimate aligned to its reference and the similarity used.")
      .def_readonly("aligned", &eval::AlignResult::aligned)
      .def_readonly("transform", &eval::AlignResult::transform);
  py::class_<eval::AssociationResult>(m, "AssociationResult", "Two trajectories cut to their associated poses.")
      .def_readonly("estimate", &eval::AssociationResult::estimate)
      .def_readonly("reference", &eval::AssociationResult::reference)
      .def_property_readonly("estimate_indices",
                             [](const eval::AssociationResult& r) { return indices_to_array(r.estimate_indices); })
      .def_property_readonly("reference_indices",
                             [](const eval::AssociationResult& r) { return indices_to_array(r.reference_indices); })
      .def_readonly("by_stamp", &eval::AssociationResult::by_stamp);
  py::class_<eval::ApeResult>(m, "ApeResult", "Absolute pose error: translation [m], rotation [deg], full.")
      .def_readonly("translation", &eval::ApeResult::translation)
      .def_readonly("rotation_deg", &eval::ApeResult::rotation_deg)
      .def_readonly("full", &eval::ApeResult::full)
      .def_readonly("alignment", &eval::ApeResult::alignment)
      .def_readonly("status", &eval::ApeResult::status);
  py::class_<eval::RpeResult>(m, "RpeResult", "Relative pose error; `pairs` is an (M, 2) int64 array of indices.")
      .def_readonly("translation", &eval::RpeResult::translation)
      .def_readonly("rotation_deg", &eval::RpeResult::rotation_deg)
      .def_readonly("full", &eval::RpeResult::full)
      .def_property_readonly("pairs", [](const eval::RpeResult& r) { return pairs_to_array(r.pairs); })
      .def_readonly("status", &eval::RpeResult::status);
}

/// Bind `name(estimate, reference, **settings)` calling `function` with the GIL released.
template <typename Settings, typename Result>
void def_pair_function(py::module_& m, const char* name,
                       Result (*function)(const Trajectory&, const Trajectory&, const Settings&), const char* doc) {
  m.def(
      name,
      [name, function](const Trajectory& estimate, const Trajectory& reference, const py::kwargs& kwargs) {
        const auto settings = settings_from_kwargs<Settings>(kwargs, name);
        py::gil_scoped_release release;
        return function(estimate, reference, settings);
      },
      py::arg("estimate"), py::arg("reference"), doc);
}

void bind_eval_functions(py::module_& m) {
  def_pair_function(m, "associate", &eval::associate,
                    "Pair the poses of two trajectories by stamp (or by index without stamps). Keyword arguments: "
                    "the fields of AssociationSettings.");
  def_pair_function(m, "ape", &eval::compute_ape,
                    "Absolute pose error (C++ eval::compute_ape) of an associated estimate (pose i with pose i). "
                    "Keyword arguments: the fields of ApeSettings (align, axes).");
  def_pair_function(m, "rpe", &eval::compute_rpe,
                    "Relative pose error (C++ eval::compute_rpe) of an associated estimate. Keyword arguments: the "
                    "fields of RpeSettings (delta, unit, align, pairs_along).");
  m.def(
      "align_umeyama",
      [](const py::object& source, const py::object& target, bool with_scale) {
        const auto s = positions_from_array(source, "align_umeyama: source");
        const auto t = positions_from_array(target, "align_umeyama: target");
        py::gil_scoped_release release;
        return eval::umeyama(s, t, with_scale);
      },
      py::arg("source"), py::arg("target"), py::arg("with_scale") = false,
      "Umeyama's closed form (C++ eval::umeyama) between (N, 3) point arrays: the similarity minimising "
      "sum |target_i - (s R source_i + t)|^2.");
  m.def("align_trajectory", &eval::align_trajectory, py::arg("estimate"), py::arg("reference"),
        py::arg("mode") = eval::AlignMode::kSE3, py::call_guard<py::gil_scoped_release>(),
        "Fit `mode` between the positions of two associated trajectories and apply it to the estimate.");
  m.def(
      "compute_stats",
      [](const py::object& errors) { return eval::compute_stats(doubles_from_array(errors, "compute_stats: errors")); },
      py::arg("errors"), "Statistics of an (N,) array of errors.");
}

}  // namespace

void bind_eval(py::module_& m) {
  bind_eval_enums(m);
  bind_eval_settings(m);
  bind_eval_results(m);
  bind_eval_functions(m);
}

}  // namespace plumb::python
