// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/app/deviation_files.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>

#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"

namespace plumb {
namespace {

/// "%+.1f cm" of a length in metres.
std::string signed_cm(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%+.1f cm", metres * 100.0);
  return buf;
}

/// "%.1f cm" of a length in metres.
std::string cm(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f cm", metres * 100.0);
  return buf;
}

/// "%g cm": a tolerance as given, without trailing zeros.
std::string tolerance_cm(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g cm", metres * 100.0);
  return buf;
}

std::string element_text(const DeviationReportRow& row) { return row.type + " '" + row.name + "'"; }

void check_positive(double value, const char* what) {
  PLUMB_CHECK(std::isfinite(value) && value > 0.0, what << " must be positive, not " << value);
}

std::string description(const DeviationReportRow& row, double tolerance_m, bool guid_ok) {
  char normal[96];
  std::snprintf(normal, sizeof(normal), "(%.3f, %.3f, %.3f)", row.normal.x(), row.normal.y(), row.normal.z());
  char rotation[48];
  std::snprintf(rotation, sizeof(rotation), "%.2f deg", row.rotation_deg);
  std::string text = "The face of " + element_text(row) + " stands " + signed_cm(row.offset_m) +
                     " from its design position along its normal " + normal + " (std " + cm(row.sigma_m) +
                     "): beyond the tolerance of " + tolerance_cm(tolerance_m) +
                     " by more than 3 std. Positive: the face stands out toward the side it was seen from. "
                     "Rotation of the element: " + rotation + ". Storey: " +
                     (row.storey.empty() ? std::string("none") : row.storey) + ". GlobalId: " + row.global_id +
                     ". Observed by " + std::to_string(row.observations) + " LiDAR key points (plumb run --as-built).";
  if (!guid_ok) text += " The model gives this element no valid GlobalId, so the viewpoint selects no element.";
  return text;
}

io::BcfCamera face_camera(const DeviationReportRow& row, const DeviationBcfSettings& s) {
  PLUMB_CHECK(row.normal.allFinite() && std::abs(row.normal.norm() - 1.0) < 1e-6,
              "deviation_bcf: " << element_text(row) << " deviates but has no unit face normal");
  io::BcfCamera c;
  c.viewpoint = row.point + s.origin_offset + s.camera_distance * row.normal;
  c.direction = -row.normal;
  c.up = std::abs(row.normal.z()) > 0.9 ? Vector3d::UnitY() : Vector3d::UnitZ();
  c.field_of_view_deg = 60.0;
  return c;
}

}  // namespace

std::string deviation_title(const DeviationReportRow& row) {
  return element_text(row) + " off by " + signed_cm(row.offset_m);
}

io::BcfProject deviation_bcf(const std::vector<DeviationReportRow>& rows, double tolerance_m,
                             const DeviationBcfSettings& settings) {
  check_positive(tolerance_m, "deviation_bcf: the tolerance");
  check_positive(settings.camera_distance, "deviation_bcf: the camera distance");
  check_positive(settings.color_limit, "deviation_bcf: the colour limit");
  io::BcfProject project;
  project.name = settings.project_name;
  project.seed = settings.seed;
  for (const DeviationReportRow& row : rows) {
    if (row.status != DeviationStatus::kDeviates) continue;
    const bool guid_ok = io::is_ifc_guid(row.global_id);
    io::BcfTopic t;
    t.guid = io::bcf_guid(settings.seed, "deviation\n" + row.global_id);
    t.title = deviation_title(row);
    t.description = description(row, tolerance_m, guid_ok);
    t.author = settings.author;
    t.date = settings.date;
    t.type = "Issue";
    t.status = "Open";
    t.camera = face_camera(row, settings);
    if (guid_ok) t.components.push_back({row.global_id, io::diverging_color(row.offset_m, settings.color_limit).substr(1)});
    project.topics.push_back(std::move(t));
  }
  return project;
}

io::SvgPlot deviation_svg(const std::vector<DeviationReportRow>& rows, double tolerance_m, const bim::BimMesh& mesh,
                          const DeviationSvgSettings& settings) {
  check_positive(tolerance_m, "deviation_svg: the tolerance");
  check_positive(settings.color_limit, "deviation_svg: the colour limit");
  io::SvgPlot plot;
  std::map<std::size_t, std::vector<std::array<Vector2d, 2>>> cut;  // element -> its segments of the plan
  const bim::FloorPlan fp = bim::slice_floor_plan(mesh, settings.height);
  for (std::size_t i = 0; i < fp.segment_start.size(); ++i) {
    plot.floor_plan.push_back({fp.segment_start[i], fp.segment_end[i]});
    if (fp.segment_element[i] >= 0) {
      cut[static_cast<std::size_t>(fp.segment_element[i])].push_back({fp.segment_start[i], fp.segment_end[i]});
    }
  }
  std::size_t counts[3] = {0, 0, 0};  // ok, deviates, unobserved
  for (const DeviationReportRow& row : rows) {
    PLUMB_CHECK(row.element < mesh.elements.size(),
                "deviation_svg: element " << row.element << " is not in the model (" << mesh.elements.size() << " elements)");
    const bool observed = row.status != DeviationStatus::kUnobserved;
    const bool deviates = row.status == DeviationStatus::kDeviates;
    ++counts[static_cast<int>(row.status)];
    io::SvgShape shape;
    shape.id = "element-" + std::to_string(row.element);
    shape.css_class = std::string("element ") + deviation_status_name(row.status);
    shape.tooltip = element_text(row) + " " + row.global_id + ": " +
                    (observed ? signed_cm(row.offset_m) + " (std " + cm(row.sigma_m) + "), " : std::string()) +
                    deviation_status_name(row.status);
    shape.color = observed ? io::diverging_color(row.offset_m, settings.color_limit) : "#BBBBBB";
    shape.dashed = !observed;
    if (deviates) {
      shape.outline = "#000000";
      shape.label = row.name + " " + signed_cm(row.offset_m);
    }
    const auto it = cut.find(row.element);
    if (it != cut.end()) {
      shape.segments = it->second;
    } else {
      const bim::BimElement& e = mesh.elements[row.element];
      const bool have_box = e.bbox_min.allFinite() && e.bbox_max.allFinite();
      const Vector3d at = observed || !have_box ? row.point : Vector3d(0.5 * (e.bbox_min + e.bbox_max));
      shape.markers.push_back(at.head<2>());
    }
    plot.shapes.push_back(std::move(shape));
  }
  plot.title = settings.title + ": " + std::to_string(rows.size()) + " elements, " + std::to_string(counts[0]) +
               " ok, " + std::to_string(counts[1]) + " deviating beyond " + tolerance_cm(tolerance_m) + ", " +
               std::to_string(counts[2]) + " unobserved";
  const double limit_cm = settings.color_limit * 100.0;
  plot.color_bar.title = "offset along the face normal [cm]";
  plot.color_bar.stops = io::diverging_color_stops(limit_cm);
  for (double t : {-1.0, -0.5, 0.0, 0.5, 1.0}) plot.color_bar.ticks.push_back(t * limit_cm);
  io::SvgPath unobserved_key, deviates_key;
  unobserved_key.label = "unobserved";
  unobserved_key.color = "#BBBBBB";
  unobserved_key.dashed = true;
  deviates_key.label = "deviates (labelled)";
  deviates_key.color = "#000000";
  deviates_key.width = 4.0;
  plot.paths.push_back(unobserved_key);
  plot.paths.push_back(deviates_key);
  return plot;
}

std::string deviation_summary(const std::vector<DeviationReportRow>& rows, double tolerance_m) {
  constexpr std::size_t kSummaryNames = 3;  // a line on a terminal: the rest are in the files
  std::size_t checked = 0, unobserved = 0;
  std::string names;
  std::size_t deviating = 0;
  for (const DeviationReportRow& row : rows) {
    if (row.status == DeviationStatus::kUnobserved) {
      ++unobserved;
      continue;
    }
    ++checked;
    if (row.status != DeviationStatus::kDeviates) continue;
    if (++deviating <= kSummaryNames) names += (names.empty() ? "" : ", ") + row.name + " (" + signed_cm(row.offset_m) + ")";
  }
  if (deviating > kSummaryNames) names += " and " + std::to_string(deviating - kSummaryNames) + " more";
  std::string line = std::to_string(checked) + " elements checked (" + std::to_string(unobserved) + " unobserved), ";
  if (deviating == 0) return line + "none deviates beyond " + tolerance_cm(tolerance_m);
  return line + std::to_string(deviating) + (deviating == 1 ? " deviates" : " deviate") + " beyond " +
         tolerance_cm(tolerance_m) + ": " + names;
}

std::string bcf_date_time(double unix_seconds) {
  PLUMB_CHECK(std::isfinite(unix_seconds) && unix_seconds >= 0.0 && unix_seconds < 253402300800.0,
              "bcf_date_time: " << unix_seconds << " s is not a time between 1970 and 9999");
  const std::time_t t = static_cast<std::time_t>(std::floor(unix_seconds));
  std::tm utc{};
  PLUMB_CHECK(gmtime_r(&t, &utc) != nullptr, "bcf_date_time: cannot convert " << unix_seconds << " s");
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

}  // namespace plumb
