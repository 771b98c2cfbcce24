// SPDX-License-Identifier: BSD-3-Clause
// The deviation report as files (app/deviation_files.hpp) on rows made by hand for elements of the
// demo office: the floor plan SVG has one shape per element, coloured by its offset (colours worked
// out by hand from the diverging scale's end colours) or grey when unobserved, and a legend; the BCF
// project has a topic per deviating row that selects the row's GlobalId and looks at its face, and
// its archive validates against buildingSMART's BCF 2.1 schemas, also when nothing deviates.
#include "plumb/app/deviation_files.hpp"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bcf_check.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/io/bcf.hpp"
#include "plumb/io/svg.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb {
namespace {

namespace fs = std::filesystem;

const bim::BimMesh& office() {
  static const bim::BimMesh mesh = bim::build_mesh(
      bim::read_ifc(test::source_dir() + "/examples/data/demo_office.ifc"), bim::mesh_settings_with_spaces());
  return mesh;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

DeviationReportRow row_of(std::size_t element, DeviationStatus status, double offset) {
  const bim::BimElement& e = office().elements.at(element);
  DeviationReportRow r;
  r.element = element;
  r.global_id = e.global_id;
  r.type = e.type;
  r.name = e.name;
  r.storey = "Ground floor";
  r.status = status;
  r.normal = Vector3d::UnitX();
  r.point = 0.5 * (e.bbox_min + e.bbox_max);
  if (status != DeviationStatus::kUnobserved) {
    r.observations = 120;
    r.offset_m = offset;
    r.sigma_m = 0.004;
    r.rotation_deg = 0.1;
  }
  return r;
}

/// Four elements the floor plan at 1 m cuts (walls) and one it misses (a slab or another element
/// wholly above or below 1 m): ok +1 cm, deviating -5 cm, unobserved, ok 0 cm, deviating +3.5 cm.
std::vector<DeviationReportRow> some_rows() {
  const bim::FloorPlan fp = bim::slice_floor_plan(office(), 1.0);
  std::vector<std::size_t> cut;
  for (std::int32_t e : fp.segment_element) {
    if (e >= 0 && std::find(cut.begin(), cut.end(), static_cast<std::size_t>(e)) == cut.end()) cut.push_back(e);
  }
  std::size_t missed = office().elements.size();
  for (std::size_t i = 0; i < office().elements.size() && missed == office().elements.size(); ++i) {
    const bim::BimElement& e = office().elements[i];
    if (e.has_body && std::find(cut.begin(), cut.end(), i) == cut.end() && e.bbox_min.allFinite()) missed = i;
  }
  EXPECT_GE(cut.size(), 4u);
  EXPECT_LT(missed, office().elements.size());
  return {row_of(cut[0], DeviationStatus::kOk, 0.01), row_of(cut[1], DeviationStatus::kDeviates, -0.05),
          row_of(cut[2], DeviationStatus::kUnobserved, 0.0), row_of(missed, DeviationStatus::kOk, 0.0),
          row_of(cut[3], DeviationStatus::kDeviates, 0.035)};
}

/// The text of the SVG group of element `i`, up to the next element's group.
std::string group_of(const std::string& svg, std::size_t element) {
  const std::size_t a = svg.find("<g id=\"element-" + std::to_string(element) + "\"");
  if (a == std::string::npos) return {};
  return svg.substr(a, svg.find("<g id=\"element-", a + 1) - a);
}

TEST(DeviationFilesTest, TheSvgHasAShapePerElementColouredByOffsetAndALegend) {
  const std::vector<DeviationReportRow> rows = some_rows();
  DeviationSvgSettings settings;
  settings.height = 1.0;
  const std::string svg = io::render_svg(deviation_svg(rows, 0.02, office(), settings));
  EXPECT_EQ(count_of(svg, "<g id=\"element-"), rows.size());
  // +1 cm of 3: a third of the way from #F7F7F7 to #B2182B; -5 cm clips to #2166AC.
  const std::string expected[] = {"stroke=\"#E0ADB3\"", "stroke=\"#2166AC\"",
                                  "stroke=\"#BBBBBB\" stroke-width=\"4.00\" stroke-dasharray", "fill=\"#F7F7F7\"",
                                  "stroke=\"#B2182B\""};
  const char* classes[] = {"element ok", "element deviates", "element unobserved", "element ok", "element deviates"};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::string g = group_of(svg, rows[i].element);
    ASSERT_FALSE(g.empty()) << i;
    EXPECT_NE(g.find(expected[i]), std::string::npos) << i << ": " << g;
    EXPECT_NE(g.find(std::string("class=\"") + classes[i] + "\""), std::string::npos) << g;
    EXPECT_NE(g.find("<title>"), std::string::npos) << g;
    EXPECT_NE(g.find(rows[i].global_id), std::string::npos) << g;
    // The element the cut misses is a diamond, the others the plan's segments.
    EXPECT_EQ(g.find("<polygon") != std::string::npos, i == 3) << g;
    EXPECT_EQ(g.find("<line") != std::string::npos, i != 3) << g;
    // Deviating elements are outlined in black and labelled.
    EXPECT_EQ(g.find("stroke=\"#000000\"") != std::string::npos, rows[i].status == DeviationStatus::kDeviates) << g;
    EXPECT_EQ(g.find("<text") != std::string::npos, rows[i].status == DeviationStatus::kDeviates) << g;
  }
  EXPECT_NE(group_of(svg, rows[1].element).find("-5.0 cm"), std::string::npos);
  // The legend: a colour bar from -3 to +3 cm and the key of unobserved elements.
  EXPECT_NE(svg.find("fill=\"url(#plumb-color-bar)\""), std::string::npos);
  EXPECT_NE(svg.find("offset along the face normal [cm]"), std::string::npos);
  for (const char* tick : {">-3<", ">0<", ">+3<", ">+1.5<"}) EXPECT_NE(svg.find(tick), std::string::npos) << tick;
  EXPECT_NE(svg.find(">unobserved<"), std::string::npos);
  EXPECT_NE(svg.find("5 elements, 2 ok, 2 deviating beyond 2 cm, 1 unobserved"), std::string::npos);
}

TEST(DeviationFilesTest, TheSvgRefusesRowsOfAnotherModelAndBadTolerances) {
  std::vector<DeviationReportRow> rows = some_rows();
  rows[0].element = office().elements.size();
  EXPECT_NE(test::error_of([&] { deviation_svg(rows, 0.02, office()); }).find("is not in the model"), std::string::npos);
  EXPECT_NE(test::error_of([&] { deviation_svg(some_rows(), 0.0, office()); }).find("tolerance"), std::string::npos);
}

TEST(DeviationFilesTest, ATopicPerDeviatingRowSelectsItsElementAndLooksAtItsFace) {
  std::vector<DeviationReportRow> rows = some_rows();
  rows[4].normal = Vector3d(0.0, -1.0, 0.0);
  DeviationBcfSettings settings;
  settings.project_name = "demo_office.ifc as built";
  settings.date = "2026-03-01T12:30:05Z";
  settings.origin_offset = Vector3d(100.0, 200.0, 0.0);
  const io::BcfProject p = deviation_bcf(rows, 0.02, settings);
  ASSERT_EQ(p.topics.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const DeviationReportRow& row = rows[k == 0 ? 1 : 4];
    const io::BcfTopic& t = p.topics[k];
    ASSERT_EQ(t.components.size(), 1u);
    EXPECT_EQ(t.components[0].ifc_guid, row.global_id);
    EXPECT_EQ(t.title, row.type + " '" + row.name + "' off by " + (k == 0 ? "-5.0 cm" : "+3.5 cm"));
    EXPECT_NE(t.description.find(k == 0 ? "-5.0 cm" : "+3.5 cm"), std::string::npos) << t.description;
    EXPECT_NE(t.description.find("(std 0.4 cm)"), std::string::npos) << t.description;
    EXPECT_NE(t.description.find("tolerance of 2 cm"), std::string::npos) << t.description;
    EXPECT_EQ(t.guid, io::bcf_guid(settings.seed, "deviation\n" + row.global_id));
    EXPECT_EQ(t.date, settings.date);
    // 3 m in front of the face (IFC coordinates), looking back at it.
    EXPECT_TRUE(t.camera.viewpoint.isApprox(row.point + settings.origin_offset + 3.0 * row.normal));
    EXPECT_TRUE(t.camera.direction.isApprox(-row.normal));
  }
  EXPECT_EQ(p.topics[0].components[0].color, "2166AC");
}

TEST(DeviationFilesTest, TheArchiveValidatesAndHoldsATopicPerDeviatingRow) {
  const std::string unavailable = test::bcf_check_unavailable();
  if (!unavailable.empty()) GTEST_SKIP() << unavailable;
  const std::string dir = test::temp_path("deviation_bcf_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::vector<DeviationReportRow> rows = some_rows();
  DeviationBcfSettings settings;
  settings.date = bcf_date_time(0.0);
  io::write_bcf(dir + "/deviations.bcf", deviation_bcf(rows, 0.02, settings));
  test::extract_bcf(dir + "/deviations.bcf", dir + "/x");
  EXPECT_EQ(test::expect_valid_bcf_files(dir + "/x"), 2u + 2u * 2u);
  std::string viewpoints;
  for (const auto& e : fs::recursive_directory_iterator(dir + "/x")) {
    if (e.path().filename() == "viewpoint.bcfv") viewpoints += test::read_text(e.path().string());
  }
  for (const DeviationReportRow& row : rows) {
    EXPECT_EQ(count_of(viewpoints, "<Component IfcGuid=\"" + row.global_id + "\""),
              row.status == DeviationStatus::kDeviates ? 2u : 0u)  // selected and coloured
        << row.global_id;
  }
  // Nothing deviating: the archive still validates, with the version and project files only.
  std::vector<DeviationReportRow> fine = rows;
  for (DeviationReportRow& row : fine) row.status = row.status == DeviationStatus::kDeviates ? DeviationStatus::kOk : row.status;
  io::write_bcf(dir + "/none.bcf", deviation_bcf(fine, 0.02, settings));
  test::extract_bcf(dir + "/none.bcf", dir + "/none");
  EXPECT_EQ(test::expect_valid_bcf_files(dir + "/none"), 2u);
  fs::remove_all(dir);
}

TEST(DeviationFilesTest, TheSummaryCountsAndNamesTheFirstDeviatingElements) {
  std::vector<DeviationReportRow> rows = some_rows();
  EXPECT_EQ(deviation_summary(rows, 0.02), "4 elements checked (1 unobserved), 2 deviate beyond 2 cm: " + rows[1].name +
                                               " (-5.0 cm), " + rows[4].name + " (+3.5 cm)");
  for (DeviationReportRow& row : rows) row.status = row.status == DeviationStatus::kDeviates ? DeviationStatus::kOk : row.status;
  EXPECT_EQ(deviation_summary(rows, 0.02), "4 elements checked (1 unobserved), none deviates beyond 2 cm");
  // More than three: the first three by name, then how many more.
  rows = some_rows();
  for (DeviationReportRow& row : rows) row.status = DeviationStatus::kDeviates;
  EXPECT_EQ(deviation_summary(rows, 0.02), "5 elements checked (0 unobserved), 5 deviate beyond 2 cm: " + rows[0].name +
                                               " (+1.0 cm), " + rows[1].name + " (-5.0 cm), " + rows[2].name +
                                               " (+0.0 cm) and 2 more");
}

TEST(DeviationFilesTest, DatesAreXsDateTimesInUtc) {
  EXPECT_EQ(bcf_date_time(0.0), "1970-01-01T00:00:00Z");
  EXPECT_EQ(bcf_date_time(1772368205.75), "2026-03-01T12:30:05Z");
  EXPECT_NE(test::error_of([] { bcf_date_time(-1.0); }).find("between 1970 and 9999"), std::string::npos);
}

}  // namespace
}  // namespace plumb
