// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/ply.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "io/io_test_util.hpp"
#include "test_data.hpp"

namespace plumb::io {
namespace {

using plumb::test::temp_path;

PointCloud parse_ply(const std::string& bytes) { return read_ply_buffer(bytes.data(), bytes.size(), "mem.ply"); }

PointCloud make_full_ply_cloud(std::size_t n, unsigned seed) {
  PointCloud c = test::random_full_cloud(n, seed, 50.0f, 1e-4f);
  if (n >= 3) {
    c.points[1] = Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
    c.points[2] = Vector3f(-0.0f, std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::lowest());
  }
  return c;
}

// ---- a hand-built fixture, encoded here in code in every PLY format ------------------------------

enum class Enc { kAscii, kLittle, kBig };

// One PLY scalar to emit: its PLY type name and value.
struct Val {
  const char* type;
  double v;
};

void emit(std::string& out, const Val& val, Enc enc) {
  const std::string t = val.type;
  if (enc == Enc::kAscii) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.17g ", val.v);
    out += buf;
    return;
  }
  char b[8];
  std::size_t n = 0;
  auto put = [&](auto x) {
    n = sizeof(x);
    std::memcpy(b, &x, n);
  };
  if (t == "char") put(static_cast<std::int8_t>(val.v));
  if (t == "uchar") put(static_cast<std::uint8_t>(val.v));
  if (t == "short") put(static_cast<std::int16_t>(val.v));
  if (t == "ushort") put(static_cast<std::uint16_t>(val.v));
  if (t == "int") put(static_cast<std::int32_t>(val.v));
  if (t == "uint") put(static_cast<std::uint32_t>(val.v));
  if (t == "float") put(static_cast<float>(val.v));
  if (t == "double") put(val.v);
  if (enc == Enc::kBig) {
    for (std::size_t k = 0; k < n / 2; ++k) std::swap(b[k], b[n - 1 - k]);
  }
  out.append(b, n);
}

struct FixtureVertex {
  double x;
  float y;
  std::int16_t z;
  std::uint8_t red;
  float nx, ny, nz;
  std::vector<int> extra;
  std::uint16_t intensity;
  std::int32_t label;
};

const std::vector<FixtureVertex> kVertices = {
    {1.25, -2.5f, 3, 255, 0.0f, 0.0f, 1.0f, {}, 100, -5},
    {-0.125, 1e-3f, -32768, 0, 0.6f, 0.8f, 0.0f, {1, 2, 3}, 65535, 2147483647},
    {1e10, 0.1f, 7, 1, 1.0f, 0.0f, 0.0f, {-1}, 0, 0},
};

std::string fixture_header(Enc enc, std::size_t num_vertices) {
  const char* fmt = enc == Enc::kAscii ? "ascii" : enc == Enc::kLittle ? "binary_little_endian" : "binary_big_endian";
  return std::string("ply\nformat ") + fmt +
         " 1.0\ncomment hand-made fixture\nobj_info for plumb tests\n"
         "element camera 1\nproperty float view_px\nproperty uchar flag\n"
         "element vertex " + std::to_string(num_vertices) + "\n"
         "property double x\nproperty float y\nproperty short z\nproperty uchar red\n"
         "property float nx\nproperty float ny\nproperty float nz\n"
         "property list uchar int extra_list\nproperty ushort intensity\nproperty int label\n"
         "element face 2\nproperty list uchar int vertex_indices\nproperty uchar material\n"
         "element empty_element 1000000000000\n"
         "end_header\n";
}

std::string fixture(Enc enc) {
  std::string s = fixture_header(enc, kVertices.size());
  const auto line_end = [&] {
    if (enc == Enc::kAscii) s += "\n";
  };
  emit(s, {"float", 1.5}, enc);
  emit(s, {"uchar", 7}, enc);
  line_end();
  for (const FixtureVertex& v : kVertices) {
    emit(s, {"double", v.x}, enc);
    emit(s, {"float", v.y}, enc);
    emit(s, {"short", static_cast<double>(v.z)}, enc);
    emit(s, {"uchar", static_cast<double>(v.red)}, enc);
    emit(s, {"float", v.nx}, enc);
    emit(s, {"float", v.ny}, enc);
    emit(s, {"float", v.nz}, enc);
    emit(s, {"uchar", static_cast<double>(v.extra.size())}, enc);
    for (int e : v.extra) emit(s, {"int", static_cast<double>(e)}, enc);
    emit(s, {"ushort", static_cast<double>(v.intensity)}, enc);
    emit(s, {"int", static_cast<double>(v.label)}, enc);
    line_end();
  }
  for (int f = 0; f < 2; ++f) {
    emit(s, {"uchar", 3}, enc);
    for (int k = 0; k < 3; ++k) emit(s, {"int", static_cast<double>((f + k) % 3)}, enc);
    emit(s, {"uchar", static_cast<double>(f)}, enc);
    line_end();
  }
  return s;
}

void check_fixture(const PointCloud& c) {
  ASSERT_EQ(c.size(), kVertices.size());
  ASSERT_TRUE(c.has_normals());
  ASSERT_TRUE(c.has_intensities());
  ASSERT_TRUE(c.has_labels());
  EXPECT_FALSE(c.has_rings() || c.has_times());
  for (std::size_t i = 0; i < kVertices.size(); ++i) {
    const FixtureVertex& v = kVertices[i];
    EXPECT_EQ(c.points[i], Vector3f(static_cast<float>(v.x), v.y, static_cast<float>(v.z))) << i;
    EXPECT_EQ(c.normals[i], Vector3f(v.nx, v.ny, v.nz)) << i;
    EXPECT_EQ(c.intensities[i], static_cast<float>(v.intensity)) << i;
    EXPECT_EQ(c.labels[i], v.label) << i;
  }
}

TEST(PlyTest, ReadsHandBuiltFixtureInEveryFormat) {
  check_fixture(parse_ply(fixture(Enc::kAscii)));
  check_fixture(parse_ply(fixture(Enc::kLittle)));
  check_fixture(parse_ply(fixture(Enc::kBig)));
}

TEST(PlyTest, ReadsFromFileAndToleratesCrlfHeader) {
  std::string s = fixture(Enc::kLittle);
  const std::string end = "end_header\n";
  std::string header = s.substr(0, s.find(end) + end.size());
  const std::string body = s.substr(header.size());
  std::string crlf;
  for (char ch : header) {
    if (ch == '\n') crlf += '\r';
    crlf += ch;
  }
  const std::string file = temp_path("ply_fixture.ply");
  std::FILE* f = std::fopen(file.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  std::fwrite(crlf.data(), 1, crlf.size(), f);
  std::fwrite(body.data(), 1, body.size(), f);
  std::fclose(f);
  check_fixture(read_ply(file));
  std::remove(file.c_str());
}

TEST(PlyTest, MinimalXyzAndAliases) {
  const PointCloud c = parse_ply(
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float32 x\nproperty float32 y\nproperty float32 z\n"
      "property float normal_x\nproperty float normal_y\nproperty float normal_z\nend_header\n"
      "1 2 3 0 0 1\n  4   5\t6 1 0 0");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Vector3f(4, 5, 6));
  EXPECT_EQ(c.normals[1], Vector3f(1, 0, 0));
  // A lone nx is not a normal.
  const PointCloud d = parse_ply(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nend_header\n1 2 3 4\n");
  EXPECT_FALSE(d.has_normals());
}

TEST(PlyTest, RoundTripIsExactInBothEncodings) {
  const PointCloud c = make_full_ply_cloud(300, 4);
  for (PlyEncoding e : {PlyEncoding::kAscii, PlyEncoding::kBinaryLittleEndian}) {
    SCOPED_TRACE(static_cast<int>(e));
    PlyWriteSettings ws;
    ws.encoding = e;
    expect_file_round_trip(c, ws, "ply_roundtrip.ply", write_ply, read_ply);
    PointCloud xyz;
    xyz.points = c.points;
    expect_same_cloud(xyz, parse_ply(write_ply_buffer(xyz, ws)));
    expect_same_cloud(PointCloud{}, parse_ply(write_ply_buffer(PointCloud{}, ws)));
  }
}

TEST(PlyTest, WriteRejectsInconsistentCloudAndBadPath) {
  PointCloud c = make_full_ply_cloud(5, 1);
  c.rings.pop_back();
  expect_error([&] { write_ply(temp_path("ply_bad.ply"), c); }, {"ply_bad.ply", "rings"});
  expect_error([] { write_ply("/nonexistent_dir/a.ply", make_full_ply_cloud(2, 1)); }, {"/nonexistent_dir/a.ply"});
}

// ---- bad input ---------------------------------------------------------------------------------

TEST(PlyTest, NonexistentAndEmptyInputThrow) {
  expect_error([] { read_ply("/nonexistent/x.ply"); }, {"/nonexistent/x.ply"});
  expect_error([] { read_ply_buffer(nullptr, 0, "e.ply"); }, {"e.ply", "empty"});
  expect_error([] { parse_ply("plx\n"); }, {"mem.ply:1", "not a PLY"});
}

TEST(PlyTest, MalformedHeaderThrows) {
  const std::string xyz = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n";
  expect_error([&] { parse_ply("ply\n" + xyz + "end_header\n1 2 3\n"); }, {"format"});
  expect_error([&] { parse_ply("ply\nformat binary_middle_endian 1.0\n" + xyz + "end_header\n"); },
               {"mem.ply:2", "binary_middle_endian"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\n" + xyz); }, {"no end_header"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n"); },
               {"mem.ply:4", "quad"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\nend_header\n"); },
               {"mem.ply:4"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nproperty float x\nend_header\n"); }, {"mem.ply:3"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nelement vertex -1\nend_header\n"); }, {"mem.ply:3"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nelement face 1\nproperty uchar a\nend_header\n1\n"); },
               {"no 'element vertex'"});
  expect_error(
      [&] { parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n"); },
      {"mem.ply:3", "x, y or z"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nbogus line\n" + xyz + "end_header\n"); }, {"mem.ply:3", "bogus"});
}

TEST(PlyTest, TruncatedDataThrowsInEveryFormat) {
  for (Enc enc : {Enc::kLittle, Enc::kBig}) {
    const std::string full = fixture(enc);
    const std::size_t data_start = full.find("end_header\n") + 11;
    for (std::size_t cut = data_start; cut < full.size(); ++cut) {
      EXPECT_THROW(parse_ply(full.substr(0, cut)), Error) << "cut at " << cut;
    }
  }
  // ascii: cut at line starts (a cut inside the last number can still be a number).
  const std::string full = fixture(Enc::kAscii);
  const std::size_t data_start = full.find("end_header\n") + 11;
  for (std::size_t at = data_start; at < full.size(); at = full.find('\n', at) + 1) {
    EXPECT_THROW(parse_ply(full.substr(0, at)), Error) << "cut at " << at;
  }
  expect_error([&] { parse_ply(full.substr(0, full.find('\n', data_start) + 1)); }, {"mem.ply:24", "truncated"});
  const std::string bin = fixture(Enc::kLittle);
  expect_error([&] { parse_ply(bin.substr(0, bin.size() - 3)); }, {"mem.ply", "byte"});
}

TEST(PlyTest, LyingCountsThrowWithoutHugeAllocation) {
  const std::string props = "property float x\nproperty float y\nproperty float z\nend_header\n";
  for (const char* count : {"1000000000000", "18446744073709551615", "4294967296"}) {
    SCOPED_TRACE(count);
    for (const char* fmt : {"ascii", "binary_little_endian", "binary_big_endian"}) {
      expect_error([&] { parse_ply(std::string("ply\nformat ") + fmt + " 1.0\nelement vertex " + count + "\n" + props + "1 2 3\n"); },
                   {"mem.ply", "vertex"});
    }
  }
  // A list length far beyond the data.
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                  "property float z\nproperty list uint float junk\nend_header\n";
  for (float v : {1.0f, 2.0f, 3.0f}) s.append(reinterpret_cast<const char*>(&v), 4);
  const std::uint32_t huge = 0xffffffffu;
  s.append(reinterpret_cast<const char*>(&huge), 4);
  expect_error([&] { parse_ply(s); }, {"mem.ply", "byte", "junk"});
  // Negative list length.
  std::string n = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                  "property float z\nproperty list char float junk\nend_header\n";
  for (float v : {1.0f, 2.0f, 3.0f}) n.append(reinterpret_cast<const char*>(&v), 4);
  n += static_cast<char>(-3);
  expect_error([&] { parse_ply(n); }, {"negative"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                 "property float z\nproperty list int float junk\nend_header\n1 2 3 -1\n"); },
               {"mem.ply:9", "junk"});
  expect_error([&] { parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                 "property float z\nproperty list int float junk\nend_header\n1 2 3 1000000 4 5\n"); },
               {"truncated inside list"});
}

TEST(PlyTest, BadValuesThrowWithLine) {
  const std::string h = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                        "property float ring\nend_header\n";
  expect_error([&] { parse_ply(h + "1 2 3 4\n1 y 3 4\n"); }, {"mem.ply:10", "'y'"});
  expect_error([&] { parse_ply(h + "1 2 3 4\n1 2 3 -4\n"); }, {"mem.ply:10", "ring"});
  expect_error([&] { parse_ply(h + "1 2 3 4.5\n1 2 3 4\n"); }, {"mem.ply:9", "ring"});
  EXPECT_EQ(parse_ply(h + "1 2 3 4\n1 2 3 65535\n").rings[1], 65535);
}

}  // namespace
}  // namespace plumb::io
