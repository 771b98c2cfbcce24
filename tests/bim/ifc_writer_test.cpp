// SPDX-License-Identifier: BSD-3-Clause
// The STEP/IFC writer: what it writes must decode, through our own STEP reader, to exactly the
// values written; escapes follow ISO 10303-21; GUIDs follow the IFC base-64 encoding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "plumb/bim/ifc_writer.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/step.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::bim {
namespace {

using Kind = StepValue::Kind;

StepValue read_back_single(const StepArg& arg) {
  IfcWriter w;
  const std::uint32_t id = w.add("IFCLABELHOLDER", {arg});
  const StepFile f = StepFile::parse(w.str(), "roundtrip");
  const auto args = f.args(id);
  EXPECT_EQ(args.size(), 1u);
  return args.empty() ? StepValue{} : args[0];
}

TEST(IfcWriterTest, StringsReadBackUnchanged) {
  const std::vector<std::string> texts = {
      "",
      "plain text 123",
      "it's",
      "''",
      "back\\slash and \\\\ double",
      "\\X2\\00E9\\X0\\ looks like an escape",
      "\\S\\a and \\P A\\",
      "Gr\xC3\xBC\xC3\x9F" "e aus K\xC3\xB6ln",           // Grüße aus Köln
      "\xE4\xB8\xAD\xE6\x96\x87 mixed \xCE\xA9 text",    // 中文 mixed Ω text
      "emoji \xF0\x9F\x98\x80 and \xF0\x9F\x8F\xA2 end",  // beyond the BMP
      "line\nbreak\ttab\r",
      "\x7F del and \xC2\xA0 nbsp",
  };
  for (const std::string& t : texts) {
    const StepValue v = read_back_single(StepArg::string(t));
    EXPECT_EQ(v.kind, Kind::kString) << t;
    EXPECT_EQ(v.text, t);
    // ISO 10303-21: a string literal holds printable ASCII only.
    const std::string encoded = step_string(t);
    for (char c : encoded) {
      EXPECT_TRUE(c >= 0x20 && c <= 0x7E) << "byte " << static_cast<int>(static_cast<unsigned char>(c)) << " in "
                                          << encoded;
    }
  }
}

TEST(IfcWriterTest, StringEscapesAreTheStandardOnes) {
  // ISO 10303-21 section 6.4.3: apostrophe doubled, reverse solidus doubled, \X2\ UCS-2 hex (upper
  // case digits) closed by \X0\, \X4\ for code points beyond the basic multilingual plane.
  EXPECT_EQ(step_string("it's"), "'it''s'");
  EXPECT_EQ(step_string("a\\b"), "'a\\\\b'");
  EXPECT_EQ(step_string("\xC3\xA9t\xC3\xA9"), "'\\X2\\00E9\\X0\\t\\X2\\00E9\\X0\\'");
  EXPECT_EQ(step_string("\xE6\x96\x87\xE5\xAD\x97"), "'\\X2\\65875B57\\X0\\'");
  EXPECT_EQ(step_string("\xF0\x9F\x98\x80"), "'\\X4\\0001F600\\X0\\'");
  EXPECT_EQ(step_string("\n"), "'\\X2\\000A\\X0\\'");
}

TEST(IfcWriterTest, InvalidUtf8Throws) {
  const std::vector<std::string> bad = {"\xC3", "ab\xC3", "\xC0\x80", "\xE0\x80\x80", "\xED\xA0\x80",
                                        "\xF4\x90\x80\x80", "\xFF", "\x80", "\xE4\xB8"};
  for (const std::string& b : bad) EXPECT_THROW(step_string(b), Error) << "bytes of length " << b.size();
}

/// ISO 10303-21 REAL: [-] digits "." [digits] [E [-] digits] (std::regex is avoided: GCC 12 warns
/// inside it under -O1 with sanitizers).
bool is_step_real(const std::string& t) {
  std::size_t i = 0;
  auto digits = [&]() {
    const std::size_t start = i;
    while (i < t.size() && t[i] >= '0' && t[i] <= '9') ++i;
    return i - start;
  };
  if (i < t.size() && t[i] == '-') ++i;
  if (digits() == 0 || i >= t.size() || t[i] != '.') return false;
  ++i;
  digits();
  if (i == t.size()) return true;
  if (t[i] != 'E') return false;
  ++i;
  if (i < t.size() && t[i] == '-') ++i;
  return digits() > 0 && i == t.size();
}

TEST(IfcWriterTest, RealsReadBackBitExactly) {
  std::vector<double> values = {0.0, 1.0, -1.0, 0.1, 2.5, 1e-5, -3.75e-12, 1e20, 123456789012345678.0,
                                std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
                                std::numeric_limits<double>::denorm_min(), 7.41, 1.0 / 3.0};
  Rng rng(7);
  for (int k = 0; k < 300; ++k) {
    const double mag = std::pow(10.0, rng.uniform(-30.0, 30.0));
    values.push_back(rng.uniform(-1.0, 1.0) * mag);
  }
  for (double x : values) {
    const std::string text = step_real(x);
    EXPECT_TRUE(is_step_real(text)) << text;
    const StepValue v = read_back_single(StepArg::real(x));
    EXPECT_EQ(v.kind, Kind::kReal) << text;
    EXPECT_EQ(v.real, x) << text;
  }
  EXPECT_EQ(step_real(1.0), "1.");
  EXPECT_EQ(step_real(-0.0), "0.");
  EXPECT_EQ(step_real(0.25), "0.25");
  EXPECT_EQ(step_real(1e-5), "1.E-05");
  EXPECT_THROW(step_real(std::nan("")), Error);
  EXPECT_THROW(StepArg::real(std::numeric_limits<double>::infinity()), Error);
}

TEST(IfcWriterTest, EveryArgumentKindReadsBack) {
  IfcWriter w;
  const std::uint32_t a = w.add("IFCDUMMY", {StepArg::integer(5)});
  const std::uint32_t b = w.add("IfcMixedCase", {
                                                    StepArg::null(),
                                                    StepArg::derived(),
                                                    StepArg::integer(-42),
                                                    StepArg::real(2.5),
                                                    StepArg::string("x"),
                                                    StepArg::enumeration("notdefined"),
                                                    StepArg::boolean(true),
                                                    StepArg::boolean(false),
                                                    StepArg::ref(a),
                                                    StepArg::refs({a, a}),
                                                    StepArg::list({StepArg::reals({1.0, 2.0}), StepArg::list({})}),
                                                    StepArg::typed("IfcLabel", StepArg::string("lbl")),
                                                });
  EXPECT_EQ(a, 1u);
  EXPECT_EQ(b, 2u);
  EXPECT_EQ(w.size(), 2u);
  const StepFile f = StepFile::parse(w.str(), "kinds");
  EXPECT_EQ(f.schema(), StepSchema::kIfc4);
  EXPECT_EQ(f.size(), 2u);
  EXPECT_EQ(f.type_of(b), "IFCMIXEDCASE");
  const auto v = f.args(b);
  ASSERT_EQ(v.size(), 12u);
  EXPECT_EQ(v[0].kind, Kind::kNull);
  EXPECT_EQ(v[1].kind, Kind::kDerived);
  EXPECT_EQ(v[2].kind, Kind::kInteger);
  EXPECT_EQ(v[2].number(), -42.0);
  EXPECT_EQ(v[3].kind, Kind::kReal);
  EXPECT_EQ(v[3].real, 2.5);
  EXPECT_EQ(v[4].text, "x");
  EXPECT_EQ(v[5].kind, Kind::kEnum);
  EXPECT_EQ(v[5].text, "NOTDEFINED");
  EXPECT_EQ(v[6].text, "T");
  EXPECT_EQ(v[7].text, "F");
  EXPECT_EQ(v[8].kind, Kind::kRef);
  EXPECT_EQ(v[8].ref, a);
  ASSERT_TRUE(v[9].is_list());
  ASSERT_EQ(v[9].items.size(), 2u);
  EXPECT_EQ(v[9].items[1].ref, a);
  ASSERT_EQ(v[10].items.size(), 2u);
  EXPECT_EQ(v[10].items[0].items[1].real, 2.0);
  EXPECT_TRUE(v[10].items[1].is_list());
  EXPECT_TRUE(v[10].items[1].items.empty());
  EXPECT_EQ(v[11].kind, Kind::kTyped);
  EXPECT_EQ(v[11].text, "IFCLABEL");
  ASSERT_EQ(v[11].items.size(), 1u);
  EXPECT_EQ(v[11].items[0].text, "lbl");
}

TEST(IfcWriterTest, BadNamesAndReferencesThrow) {
  IfcWriter w;
  EXPECT_THROW(w.add("", {}), Error);
  EXPECT_THROW(w.add("IFC WALL", {}), Error);
  EXPECT_THROW(w.add("IFCWALL(", {}), Error);
  EXPECT_THROW(StepArg::ref(0), Error);
  EXPECT_THROW(StepArg::enumeration("A.B"), Error);
  EXPECT_THROW(StepArg::enumeration(""), Error);
  EXPECT_THROW(StepArg::typed("IFC LABEL", StepArg::null()), Error);
  EXPECT_THROW(w.point({1.0}), Error);
  EXPECT_THROW(w.direction({0.0, 0.0, 0.0}), Error);
  EXPECT_THROW(w.axis2_placement_3d(Vector3d::Zero(), Vector3d::UnitX(), Vector3d::UnitX()), Error);
  IfcWriterSettings s;
  s.schema = "IFC4'";
  EXPECT_THROW(IfcWriter{s}, Error);
  EXPECT_THROW(w.write("/nonexistent-dir/x.ifc"), Error);
}

/// Independent decoder of the IFC base-64 GUID: 22 digits, most significant first.
bool decode_guid(const std::string& g, std::uint64_t& hi, std::uint64_t& lo) {
  const std::string alphabet = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$";
  if (g.size() != 22) return false;
  hi = lo = 0;
  for (char c : g) {
    const std::size_t d = alphabet.find(c);
    if (d == std::string::npos) return false;
    if ((hi >> 58) != 0) return false;  // would overflow 128 bits
    hi = (hi << 6) | (lo >> 58);
    lo = (lo << 6) | d;
  }
  return true;
}

TEST(IfcWriterTest, GuidEncodingMatchesTheIfcAlphabet) {
  EXPECT_EQ(ifc_guid(0, 0), "0000000000000000000000");
  EXPECT_EQ(ifc_guid(~0ULL, ~0ULL), "3$$$$$$$$$$$$$$$$$$$$$");
  EXPECT_EQ(ifc_guid(0, 1), "0000000000000000000001");
  EXPECT_EQ(ifc_guid(0, 64), "0000000000000000000010");
  EXPECT_EQ(ifc_guid(1ULL << 62, 0), "1000000000000000000000");
  Rng rng(3);
  for (int k = 0; k < 200; ++k) {
    const std::uint64_t hi = rng.engine()(), lo = rng.engine()();
    std::uint64_t h2 = 0, l2 = 0;
    ASSERT_TRUE(decode_guid(ifc_guid(hi, lo), h2, l2));
    EXPECT_EQ(h2, hi);
    EXPECT_EQ(l2, lo);
  }
}

TEST(IfcWriterTest, GuidsAreDeterministicUniqueVersion4) {
  IfcGuidGenerator a(11), b(11), c(12);
  std::set<std::string> seen;
  bool all_same_as_c = true;
  for (int k = 0; k < 5000; ++k) {
    const std::string g = a.next();
    EXPECT_EQ(g, b.next());
    all_same_as_c = all_same_as_c && g == c.next();
    EXPECT_TRUE(seen.insert(g).second) << g;
    std::uint64_t hi = 0, lo = 0;
    ASSERT_TRUE(decode_guid(g, hi, lo)) << g;
    EXPECT_EQ((hi >> 12) & 0xF, 4u) << g;  // UUID version nibble
    EXPECT_EQ(lo >> 62, 2u) << g;          // RFC 4122 variant
  }
  EXPECT_FALSE(all_same_as_c);
}

TEST(IfcWriterTest, SameCallsGiveIdenticalBytes) {
  auto build = [](std::uint64_t seed) {
    IfcWriterSettings s;
    s.guid_seed = seed;
    s.file_name = "o'brien.ifc";
    IfcWriter w(s);
    const auto pl = w.local_placement(0, Vector3d(1, 2, 3), Vector3d::UnitZ(), Vector3d::UnitY());
    w.add("IFCWALL", {w.new_guid(), StepArg::null(), StepArg::string("W"), StepArg::ref(pl)});
    return w.str();
  };
  EXPECT_EQ(build(5), build(5));
  EXPECT_NE(build(5), build(6));
  const StepFile f = StepFile::parse(build(5), "header");
  EXPECT_EQ(f.schema_name(), "IFC4");
}

TEST(IfcWriterTest, PointsAndDirectionsAreShared) {
  IfcWriter w;
  const auto p = w.point({1.0, 2.0, 3.0});
  EXPECT_EQ(w.point({1.0, 2.0, 3.0}), p);
  EXPECT_NE(w.point({1.0, 2.0}), p);
  EXPECT_NE(w.point({1.0, 2.0, 3.5}), p);
  const auto d = w.direction({0.0, 0.0, 1.0});
  EXPECT_EQ(w.direction({0.0, 0.0, 1.0}), d);
  EXPECT_NE(d, p);
  const StepFile f = StepFile::parse(w.str());
  EXPECT_EQ(f.ids_of_type("IFCCARTESIANPOINT").size(), 3u);
  EXPECT_EQ(f.type_of(d), "IFCDIRECTION");
}

// A one-box model written with the helpers: its SI units and its rotated placement chain must come
// back through read_ifc + build_mesh as the box computed by hand.
TEST(IfcWriterTest, MinimalModelMeshesWhereExpected) {
  IfcWriter w;
  const auto units = w.si_units();
  const auto wcs = w.axis2_placement_3d(Vector3d::Zero());
  const auto ctx = w.add("IFCGEOMETRICREPRESENTATIONCONTEXT",
                         {StepArg::null(), StepArg::string("Model"), StepArg::integer(3), StepArg::real(1e-5),
                          StepArg::ref(wcs), StepArg::null()});
  w.add("IFCPROJECT", {w.new_guid(), StepArg::null(), StepArg::string("P"), StepArg::null(), StepArg::null(),
                       StepArg::null(), StepArg::null(), StepArg::refs({ctx}), StepArg::ref(units)});
  // Parent at (10, 0, 1); child rotated so that its x axis is world +y, origin (2, 0, 0) in the parent.
  const auto parent = w.local_placement(0, Vector3d(10, 0, 1));
  const auto child = w.local_placement(parent, Vector3d(2, 0, 0), Vector3d::UnitZ(), Vector3d::UnitY());
  const auto profile = w.add("IFCRECTANGLEPROFILEDEF",
                             {StepArg::enumeration("AREA"), StepArg::null(),
                              StepArg::ref(w.axis2_placement_2d(Vector2d(2.0, 0.1))), StepArg::real(4.0),
                              StepArg::real(0.2)});
  const auto solid = w.add("IFCEXTRUDEDAREASOLID", {StepArg::ref(profile), StepArg::ref(w.axis2_placement_3d(Vector3d::Zero())),
                                                    StepArg::ref(w.direction({0, 0, 1})), StepArg::real(3.0)});
  const auto rep = w.add("IFCSHAPEREPRESENTATION", {StepArg::ref(ctx), StepArg::string("Body"),
                                                    StepArg::string("SweptSolid"), StepArg::refs({solid})});
  const auto shape = w.add("IFCPRODUCTDEFINITIONSHAPE", {StepArg::null(), StepArg::null(), StepArg::refs({rep})});
  const auto wall = w.add("IFCWALL", {w.new_guid(), StepArg::null(), StepArg::string("Wand \xC3\xBC"), StepArg::null(),
                                      StepArg::null(), StepArg::ref(child), StepArg::ref(shape), StepArg::null(),
                                      StepArg::enumeration("STANDARD")});
  const IfcModel model = parse_ifc(w.str(), "minimal");
  EXPECT_TRUE(model.warnings.empty());
  EXPECT_EQ(model.units.length_to_m, 1.0);
  EXPECT_EQ(model.units.angle_to_rad, 1.0);
  const BimMesh mesh = build_mesh(model);
  EXPECT_TRUE(mesh.warnings.empty()) << mesh.warnings.front();
  const int e = mesh.find_element(wall);
  ASSERT_GE(e, 0);
  const BimElement& el = mesh.elements[static_cast<std::size_t>(e)];
  EXPECT_EQ(el.name, "Wand \xC3\xBC");
  EXPECT_EQ(el.num_triangles, 12u);
  // Local x (4 m) along world +y from (12, 0), local y (0.2 m) along world -x, z from 1 to 4.
  const Vector3d lo(11.8, 0.0, 1.0), hi(12.0, 4.0, 4.0);
  EXPECT_LT((el.bbox_min - lo).norm(), 1e-12) << el.bbox_min.transpose();
  EXPECT_LT((el.bbox_max - hi).norm(), 1e-12) << el.bbox_max.transpose();
}

}  // namespace
}  // namespace plumb::bim
