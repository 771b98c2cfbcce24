// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The as-built deviation report (deviation_report(), `RunReport::deviations`) in the forms a
///        construction team opens: a floor plan coloured by each element's offset (SVG, for a
///        browser) and one BCF issue per deviating element (for a BIM viewer), plus a one-line
///        summary. What `plumb run --as-built` writes as deviations.svg and deviations.bcf.

#include <cstdint>
#include <string>
#include <vector>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/types.hpp"
#include "plumb/io/bcf.hpp"
#include "plumb/io/svg.hpp"
#include "plumb/pipeline/as_built.hpp"

namespace plumb {

/// @brief Settings of deviation_bcf().
struct DeviationBcfSettings {
  std::string project_name;      ///< the BCF project's name (e.g. the model's file name)
  std::string author = "plumb";  ///< CreationAuthor of every topic
  /// CreationDate of every topic, an xs:dateTime chosen by the caller so that the same report gives
  /// the same file (`plumb run`: the recording's start, see bcf_date_time()).
  std::string date;
  std::uint64_t seed = 1;        ///< of the GUIDs (io::bcf_guid)
  double camera_distance = 3.0;  ///< the camera stands this far from the face along its normal [m]
  /// BimMesh::origin_offset: the rows are in the mesh frame, BCF cameras in IFC coordinates
  /// (mesh frame + origin_offset) [m].
  Vector3d origin_offset = Vector3d::Zero();
  double color_limit = 0.03;     ///< the selected element is coloured by diverging_color(offset, this) [m]
};

/// @brief A topic title, e.g. "IfcWall 'Partition 2/3' off by +2.4 cm" (the offset to 0.1 cm).
std::string deviation_title(const DeviationReportRow& row);

/// @brief One BCF topic per row with status kDeviates, in row order; none when nothing deviates
///        (the archive then holds the version and project files only, as BCF 2.1 allows).
///
/// Topic: the title of deviation_title(), a description with the offset, its std, the tolerance,
/// the rotation, the storey, the GlobalId and the observations; type "Issue", status "Open"; the
/// GUID io::bcf_guid(seed, "deviation\n" + global_id), so that a topic keeps its GUID from run to
/// run and a viewer re-importing the file updates it. Viewpoint: the element selected by its
/// GlobalId (coloured as in the SVG), a perspective camera `camera_distance` from the face point
/// along the face normal, looking at it (up = z, or y for a horizontal face). A row whose GlobalId
/// is not of IFC form (io::is_ifc_guid) gets its topic without a component, and its description
/// says so.
/// @throws plumb::Error when tolerance_m or camera_distance is not positive, or a deviating row has
///         no unit face normal
io::BcfProject deviation_bcf(const std::vector<DeviationReportRow>& rows, double tolerance_m,
                             const DeviationBcfSettings& settings);

/// @brief Settings of deviation_svg().
struct DeviationSvgSettings {
  std::string title = "as built";  ///< first part of the plot title; the counts follow
  double height = 1.0;             ///< the floor plan is the model cut at this height (mesh frame) [m]
  double color_limit = 0.03;       ///< offsets at +-this are the ends of the colour scale [m]
};

/// @brief The floor plan (bim::slice_floor_plan at `height`) with every row drawn as one
///        io::SvgShape: the element's segments of the plan, or, for an element the cut misses (a
///        slab, an element above or below), a diamond at its face point (its bounding box's centre when
///        unobserved). Observed elements are coloured by their offset (io::diverging_color, clipped
///        at color_limit, legend in cm), unobserved ones grey and dashed, deviating ones outlined in
///        black and labelled with name and offset. Each shape has the id "element-<index>" and the
///        class "element <status>" (status as deviation_status_name()), and a tooltip with the
///        element's type, name, GlobalId, offset and std. The title counts the rows by status.
/// @throws plumb::Error when tolerance_m or color_limit is not positive, or a row's element is not
///         in `mesh`
io::SvgPlot deviation_svg(const std::vector<DeviationReportRow>& rows, double tolerance_m, const bim::BimMesh& mesh,
                          const DeviationSvgSettings& settings = {});

/// @brief One line, e.g. "18 elements checked (2 unobserved), 1 deviates beyond 2 cm: Exterior wall
///        north (+7.8 cm)": the first three deviating elements by name and offset, then "and N more";
///        "none deviates beyond 2 cm" when none does.
std::string deviation_summary(const std::vector<DeviationReportRow>& rows, double tolerance_m);

/// @brief A time in seconds since 1970-01-01 UTC as an xs:dateTime in UTC, to the second
///        ("1970-01-01T00:00:00Z" for 0). @throws plumb::Error when not finite or before 1970.
std::string bcf_date_time(double unix_seconds);

}  // namespace plumb
