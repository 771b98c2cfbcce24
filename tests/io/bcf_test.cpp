// SPDX-License-Identifier: BSD-3-Clause
// write_bcf(): the archive reads with Python's zipfile and unzip, every XML in it validates against
// buildingSMART's BCF 2.1 schemas (xmllint), and text with XML's special characters reads back as
// written (Python's XML parser).
#include "plumb/io/bcf.hpp"

#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bcf_check.hpp"
#include "cli_runner.hpp"
#include "io/xml_text.hpp"
#include "plumb/core/error.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb::io {
namespace {

namespace fs = std::filesystem;

std::string bcf_dir(const std::string& name) {
  const std::string dir = test::temp_path("bcf_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

using test::program_path;

BcfTopic topic(const std::string& title, const std::vector<BcfComponent>& components) {
  BcfTopic t;
  t.title = title;
  t.description = "Wall stands 12 mm off its design position; \"check\" <here> & 'there'";
  t.author = "plumb@example.org";
  t.date = "2026-03-01T12:30:05Z";
  t.type = "Issue";
  t.status = "Open";
  t.camera.viewpoint = Vector3d(4.25, -1.5, 1.6);
  t.camera.direction = Vector3d(0.0, 2.0, -0.5);
  t.camera.up = Vector3d::UnitZ();
  t.camera.field_of_view_deg = 55.0;
  t.components = components;
  return t;
}

const std::vector<std::string> kTitles = {"Wall <W-12> & \"north\" face 'leans'", "Slab > 5 mm low",
                                          "Column \xc3\xa9tage 2 &amp; not an entity"};

BcfProject some_project() {
  BcfProject p;
  p.name = "Office <as built> & co";
  p.seed = 42;
  p.topics.push_back(topic(kTitles[0], {{"2O2Fr$t4X7Zf8NOew3FLOH", "FF0000"}, {"1hOSvn6df7F8_7GcBWlRGQ", ""}}));
  p.topics.push_back(topic(kTitles[1], {{"3cUkl32yn9qRSPvBJVyWYp", "00FF0080"}}));
  p.topics.push_back(topic(kTitles[2], {}));
  p.topics[2].guid = "0f1e2d3c-4b5a-4968-8776-a5b4c3d2e1f0";
  p.topics[2].type.clear();
  return p;
}

// Python's zipfile reads the archive (CRCs checked), unzip -t tests it, and it holds exactly the
// documented entries; writing the same project again gives the same bytes.
TEST(BcfTest, TheArchiveReadsWithZipTools) {
  const std::string python = program_path("python3");
  if (python.empty()) GTEST_SKIP() << "python3 not found";
  const std::string dir = bcf_dir("zip");
  const std::string path = dir + "/issues.bcf";
  const BcfProject project = some_project();
  write_bcf(path, project);
  const test::RunResult r = test::run_program(
      python, "-c 'import sys, zipfile\nz = zipfile.ZipFile(sys.argv[1])\nassert z.testzip() is None\n"
              "print(\"\\n\".join(sorted(z.namelist())))' '" + path + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::set<std::string> names;
  std::size_t start = 0;
  for (std::size_t end; (end = r.out.find('\n', start)) != std::string::npos; start = end + 1) {
    names.insert(r.out.substr(start, end - start));
  }
  std::set<std::string> expected = {"bcf.version", "project.bcfp"};
  std::set<std::string> guids;
  for (std::size_t i = 0; i < project.topics.size(); ++i) {
    const std::string guid = i == 2 ? project.topics[2].guid : bcf_guid(42, "topic\n" + std::to_string(i) + "\n" + kTitles[i]);
    guids.insert(guid);
    expected.insert(guid + "/markup.bcf");
    expected.insert(guid + "/viewpoint.bcfv");
  }
  EXPECT_EQ(guids.size(), 3u);
  EXPECT_EQ(names, expected);
  const std::string unzip = program_path("unzip");
  if (!unzip.empty()) {
    const test::RunResult t = test::run_program(unzip, "-t '" + path + "'");
    EXPECT_EQ(t.exit_code, 0) << t.out << t.err;
    EXPECT_NE(t.out.find("No errors detected"), std::string::npos) << t.out;
  }
  const std::string first = test::read_text(path);
  write_bcf(path, project);
  EXPECT_EQ(test::read_text(path), first);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);  // no temporary left
  fs::remove_all(dir);
}

// Every XML of the archive validates against its BCF 2.1 schema.
TEST(BcfTest, EveryFileValidatesAgainstTheBcf21Schemas) {
  const std::string unavailable = test::bcf_check_unavailable();
  if (!unavailable.empty()) GTEST_SKIP() << unavailable;
  const std::string dir = bcf_dir("schema");
  write_bcf(dir + "/issues.bcf", some_project());
  test::extract_bcf(dir + "/issues.bcf", dir + "/x");
  EXPECT_EQ(test::expect_valid_bcf_files(dir + "/x"), 2u + 2u * 3u);
  fs::remove_all(dir);
}

// Titles, descriptions and the project name with & < > " ' read back as written, and the
// viewpoint holds the components, colours and camera given.
TEST(BcfTest, SpecialCharactersAndViewpointReadBack) {
  const std::string python = program_path("python3");
  if (python.empty()) GTEST_SKIP() << "python3 not found";
  const std::string dir = bcf_dir("text");
  const BcfProject project = some_project();
  write_bcf(dir + "/issues.bcf", project);
  // One line per topic: title, description, the selected IfcGuids, colour:guid pairs, camera numbers.
  const std::string script =
      "import sys, zipfile, xml.etree.ElementTree as ET\n"
      "z = zipfile.ZipFile(sys.argv[1])\n"
      "out = open(sys.argv[2], \"w\", encoding=\"utf-8\")\n"
      "out.write(ET.fromstring(z.read(\"project.bcfp\")).find(\"Project/Name\").text + \"\\n\")\n"
      "for n in sorted(n for n in z.namelist() if n.endswith(\"markup.bcf\")):\n"
      "  t = ET.fromstring(z.read(n)).find(\"Topic\")\n"
      "  v = ET.fromstring(z.read(n.replace(\"markup.bcf\", \"viewpoint.bcfv\")))\n"
      "  sel = \",\".join(c.get(\"IfcGuid\") for c in v.findall(\"Components/Selection/Component\"))\n"
      "  col = \",\".join(c.get(\"Color\") + \":\" + x.get(\"IfcGuid\") for c in v.iter(\"Color\") for x in c)\n"
      "  cam = \" \".join(e.text for e in v.find(\"PerspectiveCamera\").iter() if e.text and e.text.strip())\n"
      "  out.write(\"|\".join([t.get(\"Guid\"), t.find(\"Title\").text, t.find(\"Description\").text, sel, col, cam]) + \"\\n\")\n";
  test::write_text(dir + "/read.py", script);
  const test::RunResult r = test::run_program(python, "'" + dir + "/read.py' '" + dir + "/issues.bcf' '" + dir + "/out.txt'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = test::read_text(dir + "/out.txt");
  std::vector<std::string> lines;
  std::size_t start = 0;
  for (std::size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1) {
    lines.push_back(text.substr(start, end - start));
  }
  ASSERT_EQ(lines.size(), 4u) << text;
  EXPECT_EQ(lines[0], project.name);
  std::set<std::string> titles;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    const std::size_t a = line.find('|'), b = line.find('|', a + 1);
    const std::string title = line.substr(a + 1, b - a - 1);
    titles.insert(title);
    EXPECT_NE(line.find("|" + project.topics[0].description + "|"), std::string::npos) << line;
    if (title == kTitles[0]) {
      EXPECT_NE(line.find("|2O2Fr$t4X7Zf8NOew3FLOH,1hOSvn6df7F8_7GcBWlRGQ|FF0000:2O2Fr$t4X7Zf8NOew3FLOH|"),
                std::string::npos) << line;
      // The direction and up vector are written as unit vectors.
      EXPECT_NE(line.find("4.25 -1.5 1.6 0 0.9701425001453319 -0.24253562503633297 0 0 1 55"), std::string::npos)
          << line;
    }
    if (title == kTitles[2]) {
      EXPECT_EQ(line.rfind(project.topics[2].guid + "|", 0), 0u) << line;
    }
  }
  EXPECT_EQ(titles, std::set<std::string>(kTitles.begin(), kTitles.end()));
  fs::remove_all(dir);
}

// Bad content is refused naming the file and the topic, before anything is written; an existing
// file is left as it was, and no temporary file stays behind.
TEST(BcfTest, BadContentIsRefusedAndLeavesTheFileAlone) {
  const std::string dir = bcf_dir("bad");
  const std::string path = dir + "/issues.bcf";
  test::write_text(path, "earlier");
  struct Case {
    void (*spoil)(BcfProject&);
    std::string expected;
  };
  const Case cases[] = {
      {[](BcfProject& p) { p.topics[1].components[0].ifc_guid = "too-short"; }, "is not an IfcGuid"},
      {[](BcfProject& p) { p.topics[1].components[0].color = "ff0000"; }, "is not RRGGBB or RRGGBBAA"},
      {[](BcfProject& p) { p.topics[1].camera.field_of_view_deg = 70.0; }, "outside [45, 60]"},
      {[](BcfProject& p) { p.topics[1].camera.up = Vector3d(0.0, 4.0, -1.0); }, "along the direction"},
      {[](BcfProject& p) { p.topics[1].camera.direction = Vector3d::Zero(); }, "camera direction must be finite and not zero"},
      {[](BcfProject& p) { p.topics[1].date = "2026-13-01T00:00:00Z"; }, "is not an xs:dateTime"},
      {[](BcfProject& p) { p.topics[1].date = "1 March 2026"; }, "is not an xs:dateTime"},
      {[](BcfProject& p) { p.topics[1].guid = "not-a-uuid"; }, "is not a UUID"},
      {[](BcfProject& p) { p.topics[1].guid = p.topics[2].guid; }, "used by an earlier topic"},
      {[](BcfProject& p) { p.topics[1].author.clear(); }, "empty author"},
      {[](BcfProject& p) { p.topics[1].description = "bell \x07"; }, "control character 7"},
  };
  for (const Case& c : cases) {
    BcfProject p = some_project();
    c.spoil(p);
    const std::string msg = test::error_of([&] { write_bcf(path, p); });
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos) << c.expected << " -> " << msg;
    EXPECT_NE(msg.find("topic "), std::string::npos) << msg;
  }
  EXPECT_EQ(test::read_text(path), "earlier");
  const std::string missing = dir + "/no/such/dir/issues.bcf";
  const std::string msg = test::error_of([&] { write_bcf(missing, some_project()); });
  EXPECT_NE(msg.find(missing), std::string::npos) << msg;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  fs::remove_all(dir);
}

// Derived GUIDs are UUIDs of version 8 and variant 10, fixed by seed and content.
TEST(BcfTest, DerivedGuidsAreDeterministicUuids) {
  const std::string a = bcf_guid(1, "topic"), b = bcf_guid(2, "topic"), c = bcf_guid(1, "topic!");
  EXPECT_EQ(a, bcf_guid(1, "topic"));
  EXPECT_NE(a, b);
  EXPECT_NE(a, c);
  for (const std::string& g : {a, b, c}) {
    ASSERT_EQ(g.size(), 36u) << g;
    EXPECT_EQ(g[14], '8') << g;
    EXPECT_NE(std::string("89ab").find(g[19]), std::string::npos) << g;
  }
  EXPECT_EQ(detail::xml_escape("a&b<c>d\"e'f"), "a&amp;b&lt;c&gt;d&quot;e'f");
}

}  // namespace
}  // namespace plumb::io
