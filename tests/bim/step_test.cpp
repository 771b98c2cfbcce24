// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "plumb/bim/ifc.hpp"
#include "plumb/bim/step.hpp"
#include "plumb/core/error.hpp"
#include "test_data.hpp"

using plumb::bim::StepFile;
using plumb::bim::StepValue;

namespace {

std::string wrap(const std::string& data, const std::string& schema = "IFC4") {
  return "ISO-10303-21;\r\nHEADER;\r\nFILE_DESCRIPTION(('x'),'2;1');\r\nFILE_SCHEMA (('" + schema +
         "'));\r\nENDSEC;\r\nDATA;\r\n" + data + "ENDSEC;\r\nEND-ISO-10303-21;\r\n";
}

std::string error_of(const std::string& text, const std::string& name = "t.ifc") {
  try {
    StepFile::parse(text, name);
  } catch (const plumb::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(StepFileTest, ParsesInstancesAndValues) {
  const std::string text = wrap(
      "/* comment with ; and ' */\r\n"
      "#1= IFCCARTESIANPOINT((1.,-2.5E-1,+3));\r\n"
      "#2=IFCX ('it''s', \"0F\", .T., $, *, #1, (1, (2, 3)), IFCLENGTHMEASURE(2.), 'A\\X2\\00E400DF\\X0\\B\\X\\E9');\n"
      "#10 = IFCY\n(/* inner */ 7);\n");
  const StepFile f = StepFile::parse(text, "mem.ifc");
  EXPECT_EQ(f.schema(), plumb::bim::StepSchema::kIfc4);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f.type_of(2), "IFCX");
  EXPECT_EQ(f.type_of(10), "IFCY");
  EXPECT_FALSE(f.contains(3));
  const auto p = f.args(1);
  ASSERT_EQ(p.size(), 1u);
  ASSERT_TRUE(p[0].is_list());
  EXPECT_DOUBLE_EQ(p[0].items[0].number(), 1.0);
  EXPECT_DOUBLE_EQ(p[0].items[1].number(), -0.25);
  EXPECT_EQ(p[0].items[2].kind, StepValue::Kind::kInteger);
  EXPECT_EQ(p[0].items[2].integer, 3);
  const auto a = f.args(2);
  ASSERT_EQ(a.size(), 9u);
  EXPECT_EQ(a[0].kind, StepValue::Kind::kString);
  EXPECT_EQ(a[0].text, "it's");
  EXPECT_EQ(a[1].kind, StepValue::Kind::kBinary);
  EXPECT_EQ(a[2].kind, StepValue::Kind::kEnum);
  EXPECT_EQ(a[2].text, "T");
  EXPECT_EQ(a[3].kind, StepValue::Kind::kNull);
  EXPECT_EQ(a[4].kind, StepValue::Kind::kDerived);
  EXPECT_EQ(a[5].kind, StepValue::Kind::kRef);
  EXPECT_EQ(a[5].ref, 1u);
  ASSERT_EQ(a[6].items.size(), 2u);
  EXPECT_EQ(a[6].items[1].items[1].integer, 3);
  EXPECT_EQ(a[7].kind, StepValue::Kind::kTyped);
  EXPECT_EQ(a[7].text, "IFCLENGTHMEASURE");
  EXPECT_DOUBLE_EQ(a[7].number(), 2.0);
  EXPECT_EQ(a[8].text, "A\xC3\xA4\xC3\x9F" "B\xC3\xA9");  // UTF-8 of U+00E4 U+00DF, U+00E9
  EXPECT_EQ(f.args(10)[0].integer, 7);
  EXPECT_EQ(f.entity(10).line, 10u);  // CRLF lines counted once each
}

TEST(StepFileTest, StringEscapes) {
  std::string out;
  EXPECT_TRUE(plumb::bim::decode_step_string("a''b\\\\c", out));
  EXPECT_EQ(out, "a'b\\c");
  EXPECT_TRUE(plumb::bim::decode_step_string("\\X2\\D83DDE00\\X0\\", out));  // surrogate pair
  EXPECT_EQ(out, "\xF0\x9F\x98\x80");
  EXPECT_TRUE(plumb::bim::decode_step_string("\\X4\\0001F600\\X0\\", out));
  EXPECT_EQ(out, "\xF0\x9F\x98\x80");
  EXPECT_FALSE(plumb::bim::decode_step_string("\\X2\\00E", out));
  EXPECT_FALSE(plumb::bim::decode_step_string("\\X\\G1", out));
}

TEST(StepFileTest, BadInputThrowsWithFileAndLine) {
  EXPECT_NE(error_of("hello").find("t.ifc:1: not a STEP file"), std::string::npos);
  const std::string good = wrap("#1=IFCA(1);\n#2=IFCB('x');\n");
  // Truncated in the middle of an instance.
  const std::string truncated = good.substr(0, good.find("#2=IFCB(") + 9);
  EXPECT_NE(error_of(truncated).find("t.ifc:8:"), std::string::npos) << error_of(truncated);
  // Truncated between instances.
  const std::string cut = good.substr(0, good.find("#2="));
  EXPECT_NE(error_of(cut).find("truncated"), std::string::npos);
  EXPECT_NE(error_of(wrap("#1=IFCA(1);\n#1=IFCB(2);\n")).find("t.ifc:8: duplicate instance #1"), std::string::npos);
  EXPECT_NE(error_of(wrap("#1=IFCA('abc);\n")).find("unterminated string"), std::string::npos);
  EXPECT_NE(error_of(wrap("#1=IFCA(1;\n#2=IFCB(2);\n")).find("t.ifc:7:"), std::string::npos);
  EXPECT_NE(error_of(wrap("#1=IFCA(1);\n/* open comment")).find("unterminated comment"), std::string::npos);
  // Lazily decoded arguments report the line of the bad token.
  const StepFile f = StepFile::parse(wrap("#5=IFCA(1,\n2,\n3 4);\n"), "lazy.ifc");
  try {
    f.args(5);
    FAIL() << "no exception";
  } catch (const plumb::Error& e) {
    EXPECT_NE(std::string(e.what()).find("lazy.ifc:9:"), std::string::npos) << e.what();
  }
  EXPECT_THROW(f.args(6), plumb::Error);
  // Deep nesting is refused, not a stack overflow.
  EXPECT_NE(error_of(wrap("#1=IFCA(" + std::string(200, '(') + std::string(200, ')') + ");\n")).find("nested"),
            std::string::npos);
  // Absurd numbers do not crash.
  const StepFile g = StepFile::parse(wrap("#1=IFCA(1E999999,99999999999999999999999,-1.E-400);\n"));
  const auto a = g.args(1);
  EXPECT_TRUE(std::isinf(a[0].number()));
  EXPECT_TRUE(std::isfinite(a[1].number()));
}

TEST(StepFileTest, UnknownSchemaRejectedByIfcReader) {
  EXPECT_THROW(plumb::bim::parse_ifc(wrap("#1=IFCA(1);\n", "AP214"), "x.stp"), plumb::Error);
  EXPECT_NO_THROW(plumb::bim::parse_ifc(wrap("#1=IFCA(1);\n", "IFC2X3"), "x.ifc"));
}

TEST(StepFileTest, SparseIdsUseHashIndex) {
  const StepFile f = StepFile::parse(wrap("#5=IFCA(1);\n#2000000000=IFCB(#5);\n"));
  EXPECT_EQ(f.type_of(2000000000u), "IFCB");
  EXPECT_EQ(f.args(2000000000u)[0].ref, 5u);
  EXPECT_FALSE(f.contains(7));
}

TEST(IfcUnitsTest, SiPrefixesAndConversionBasedUnits) {
  const auto mm = plumb::bim::parse_ifc(wrap(
      "#1=IFCUNITASSIGNMENT((#2,#3));\n#2=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);\n"
      "#3=IFCCONVERSIONBASEDUNIT(#4,.PLANEANGLEUNIT.,'degree',#5);\n#4=IFCDIMENSIONALEXPONENTS(0,0,0,0,0,0,0);\n"
      "#5=IFCMEASUREWITHUNIT(IFCPLANEANGLEMEASURE(0.0174532925199433),#6);\n#6=IFCSIUNIT(*,.PLANEANGLEUNIT.,$,.RADIAN.);\n"));
  EXPECT_DOUBLE_EQ(mm.units.length_to_m, 1e-3);
  EXPECT_NEAR(mm.units.angle_to_rad, M_PI / 180.0, 1e-15);
  const auto ft = plumb::bim::parse_ifc(wrap(
      "#1=IFCUNITASSIGNMENT((#2));\n#2=IFCCONVERSIONBASEDUNIT(#4,.LENGTHUNIT.,'FOOT',#5);\n"
      "#4=IFCDIMENSIONALEXPONENTS(1,0,0,0,0,0,0);\n#5=IFCMEASUREWITHUNIT(IFCLENGTHMEASURE(304.8),#6);\n"
      "#6=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);\n"));
  EXPECT_NEAR(ft.units.length_to_m, 0.3048, 1e-15);
  const auto cm = plumb::bim::parse_ifc(wrap("#1=IFCUNITASSIGNMENT((#2));\n#2=IFCSIUNIT(*,.LENGTHUNIT.,.CENTI.,.METRE.);\n"));
  EXPECT_DOUBLE_EQ(cm.units.length_to_m, 0.01);
  const auto none = plumb::bim::parse_ifc(wrap("#1=IFCA(1);\n"));
  EXPECT_DOUBLE_EQ(none.units.length_to_m, 1.0);
  EXPECT_FALSE(none.warnings.empty());
}

TEST(StepFileTest, RealFilesIndexEveryInstance) {
  PLUMB_REQUIRE_DATA(fzk, "ifc/buildings/AC20-FZK-Haus.ifc");
  PLUMB_REQUIRE_DATA(duplex, "ifc/buildings/duplex.ifc");
  // Independent reference: count '#N=' line starts in the raw text.
  for (const auto& path : {fzk, duplex}) {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    std::size_t instances = 0, walls = 0;
    while (std::getline(in, line)) {
      if (!line.empty() && line[0] == '#') ++instances;
      if (line.find("= IFCWALLSTANDARDCASE(") != std::string::npos || line.find("=IFCWALLSTANDARDCASE(") != std::string::npos) ++walls;
    }
    const auto m = plumb::bim::read_ifc(path);
    EXPECT_EQ(m.step.size(), instances) << path;
    EXPECT_EQ(m.step.ids_of_type("IFCWALLSTANDARDCASE").size(), walls) << path;
    EXPECT_DOUBLE_EQ(m.units.length_to_m, 1.0);
  }
  const auto f = plumb::bim::read_ifc(fzk);
  EXPECT_EQ(f.step.schema(), plumb::bim::StepSchema::kIfc4);
  EXPECT_EQ(f.step.ids_of_type("IFCWALLSTANDARDCASE").size(), 13u);
  EXPECT_EQ(f.step.ids_of_type("IFCRELVOIDSELEMENT").size(), 17u);
  const auto d = plumb::bim::read_ifc(duplex);
  EXPECT_EQ(d.step.schema(), plumb::bim::StepSchema::kIfc2x3);
  EXPECT_EQ(d.step.ids_of_type("IFCWINDOW").size(), 24u);
  // Every instance decodes.
  for (const auto& e : d.step.entities()) ASSERT_NO_THROW(d.step.args(e)) << e.id;
}
