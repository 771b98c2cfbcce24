// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/pcd.hpp"

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

// ---- helpers ----------------------------------------------------------------------------------

PointCloud read_string(const std::string& bytes, const PcdReadSettings& settings = {}) {
  return read_pcd_buffer(bytes.data(), bytes.size(), "mem.pcd", settings);
}

PointCloud read_file(const std::string& path) { return read_pcd(path); }

template <class T>
void append_raw(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}


// A cloud with every optional field, awkward float values (NaN rows, -0, denormals, extremes).
PointCloud make_full_cloud(std::size_t n, unsigned seed) {
  PointCloud c = test::random_full_cloud(n, seed, 100.0f, 1e-3f);
  if (n >= 6) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    c.points[1] = Vector3f(nan, nan, nan);
    c.points[2] = Vector3f(-0.0f, std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::max());
    c.points[3] = Vector3f(std::numeric_limits<float>::lowest(), 1e-38f, 0.1f);
    c.intensities[4] = std::numeric_limits<float>::infinity();
    c.rings[5] = 65535;
    c.labels[5] = std::numeric_limits<std::int32_t>::min();
  }
  return c;
}

// ---- real data (counts from SOURCES.md and from each file's header) ----------------------------

struct RealFile {
  const char* path;
  std::size_t points;
  std::size_t finite;
  bool normals;
  bool intensity;
};

TEST(PcdTest, ReadsEveryRealFile) {
  const RealFile files[] = {
      {"cloud3d/pcl_room_scans/room_scan1.pcd", 112586, 112586, false, false},
      {"cloud3d/pcl_room_scans/room_scan2.pcd", 112624, 112624, false, false},
      {"cloud3d/hdl32_pair/251370668.pcd", 69088, 69088, false, true},
      {"cloud3d/hdl32_pair/251371071.pcd", 69792, 69792, false, true},
      {"cloud3d/pcl_test/table_scene_mug_stereo_textured.pcd", 307200, 209280, false, false},
      {"cloud3d/pcl_test/office1.pcd", 307200, 254456, false, false},
      {"cloud3d/isprs_terrain/samp11-utm.pcd", 38010, 38010, false, false},
      {"cloud3d/isprs_terrain/samp11-utm-ground.pcd", 21786, 21786, false, false},
      {"cloud3d/pcl_test/sac_plane_test.pcd", 3283, 3283, true, false},
      {"cloud3d/pcl_test/bunny.pcd", 397, 397, false, false},
      {"cloud3d/pcl_test/bun0.pcd", 397, 397, true, false},
      {"cloud3d/pcl_test/bun4.pcd", 361, 361, false, false},
      {"cloud3d/pcl_test/milk.pcd", 13704, 13704, false, false},
  };
  for (const RealFile& f : files) {
    PLUMB_REQUIRE_DATA(path, f.path);
    SCOPED_TRACE(f.path);
    const PointCloud c = read_pcd(path);
    EXPECT_EQ(c.size(), f.points);
    EXPECT_EQ(c.finite_indices().size(), f.finite);
    EXPECT_EQ(c.has_normals(), f.normals);
    EXPECT_EQ(c.has_intensities(), f.intensity);
    EXPECT_FALSE(c.has_rings() || c.has_times() || c.has_labels());
    EXPECT_NO_THROW(c.check_consistent());
    PcdReadSettings drop;
    drop.drop_non_finite = true;
    EXPECT_EQ(read_pcd(path, drop).size(), f.finite);
  }
}

// Reference numbers below were printed by a throwaway program calling PCL 1.13's
// pcl::io::loadPCDFile<pcl::PointXYZ / PointNormal / PointXYZI> on the same files (printf %.9g, so
// each literal is the exact float). Bounding boxes are over finite points.
struct Box {
  Vector3f min, max;
};

Box finite_box(const PointCloud& c) {
  Box b{Vector3f::Constant(std::numeric_limits<float>::max()), Vector3f::Constant(std::numeric_limits<float>::lowest())};
  for (const auto& p : c.points) {
    if (!p.allFinite()) continue;
    b.min = b.min.cwiseMin(p);
    b.max = b.max.cwiseMax(p);
  }
  return b;
}

TEST(PcdTest, RoomScan1MatchesPcl) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_room_scans/room_scan1.pcd");
  const PointCloud c = read_pcd(path);
  ASSERT_EQ(c.size(), 112586u);
  EXPECT_EQ(c.points[0], Vector3f(0.107181899f, 0.0529458188f, 1.68576598f));
  EXPECT_EQ(c.points[1], Vector3f(0.133593306f, 0.0659925714f, 1.69345701f));
  EXPECT_EQ(c.points[1000], Vector3f(1.567801f, 0.775126576f, -1.25047195f));
  EXPECT_EQ(c.points[56293], Vector3f(-2.39878511f, -1.21466804f, 0.527266979f));
  EXPECT_EQ(c.points[112585], Vector3f(0.00167598703f, 0.000821849273f, -0.109984197f));
  const Box b = finite_box(c);
  EXPECT_EQ(b.min, Vector3f(-13.7997799f, -6.49281979f, -1.35170496f));
  EXPECT_EQ(b.max, Vector3f(15.4471102f, 7.97956514f, 1.70909297f));
}

TEST(PcdTest, Bun0NormalsMatchPcl) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bun0.pcd");
  const PointCloud c = read_pcd(path);
  ASSERT_EQ(c.size(), 397u);
  ASSERT_TRUE(c.has_normals());
  EXPECT_EQ(c.points[0], Vector3f(0.00542159984f, 0.11349f, 0.0407489985f));
  EXPECT_EQ(c.normals[0], Vector3f(-0.168847233f, -0.451597452f, -0.876099467f));
  EXPECT_EQ(c.points[200], Vector3f(0.0560790002f, 0.0663350001f, 0.0241219997f));
  EXPECT_EQ(c.normals[200], Vector3f(-0.520205259f, -0.443203807f, -0.730039001f));
  EXPECT_EQ(c.points[396], Vector3f(-0.0779300034f, 0.175160006f, -0.0443999991f));
  EXPECT_EQ(c.normals[396], Vector3f(-0.18629308f, -0.852933168f, -0.487647355f));
  const Box b = finite_box(c);
  EXPECT_EQ(b.min, Vector3f(-0.0939380005f, 0.0374200009f, -0.0550259985f));
  EXPECT_EQ(b.max, Vector3f(0.0595620014f, 0.184499994f, 0.0578030013f));
}

TEST(PcdTest, Hdl32MatchesPcl) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/hdl32_pair/251370668.pcd");
  const PointCloud c = read_pcd(path);
  ASSERT_EQ(c.size(), 69088u);
  ASSERT_TRUE(c.has_intensities());
  EXPECT_EQ(c.points[0], Vector3f(0.00313989166f, 2.57003498f, -1.52415681f));
  EXPECT_EQ(c.intensities[0], 68.0f);
  EXPECT_EQ(c.points[34544], Vector3f(-0.0189263821f, -4.33757973f, -1.57876503f));
  EXPECT_EQ(c.intensities[34544], 16.0f);
  EXPECT_EQ(c.points[69087], Vector3f(-0.00437020417f, 1.92610645f, 0.362898111f));
  EXPECT_EQ(c.intensities[69087], 36.0f);
  const Box b = finite_box(c);
  EXPECT_EQ(b.min, Vector3f(-23.3374786f, -74.6816101f, -2.95733595f));
  EXPECT_EQ(b.max, Vector3f(19.0246964f, 8.91950989f, 10.7959356f));
}

TEST(PcdTest, OrganizedCloudKeepsNaNPointsInRowMajorOrder) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/table_scene_mug_stereo_textured.pcd");
  const PointCloud c = read_pcd(path);
  ASSERT_EQ(c.size(), 640u * 480u);
  EXPECT_FALSE(c.points[0].allFinite());
  // PCL: organized point (row 240, column 320) = index 153920.
  EXPECT_EQ(c.points[153920], Vector3f(0.00018884f, 0.0162860006f, 0.944079995f));
  const Box b = finite_box(c);
  EXPECT_EQ(b.min, Vector3f(-0.456429988f, -0.510739982f, 0.690010011f));
  EXPECT_EQ(b.max, Vector3f(0.71517998f, 0.179230005f, 2.5927f));
  PcdReadSettings drop;
  drop.drop_non_finite = true;
  const PointCloud f = read_pcd(path, drop);
  EXPECT_EQ(f.size(), 209280u);
  for (const auto& p : f.points) ASSERT_TRUE(p.allFinite());
}

TEST(PcdTest, Office1MatchesPcl) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/office1.pcd");
  const PointCloud c = read_pcd(path);
  ASSERT_EQ(c.size(), 307200u);
  EXPECT_EQ(c.points[153920], Vector3f(0.0f, 0.0f, 5.05000019f));
  const Box b = finite_box(c);
  EXPECT_EQ(b.min, Vector3f(-2.6454761f, -2.19642901f, 1.83299994f));
  EXPECT_EQ(b.max, Vector3f(1.50435996f, 1.58124602f, 5.36399984f));
}

TEST(PcdTest, RealFileRoundTripsInEveryEncoding) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/hdl32_pair/251371071.pcd");
  const PointCloud c = read_pcd(path);
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    PcdWriteSettings ws;
    ws.encoding = e;
    expect_file_round_trip(c, ws, "pcd_real_roundtrip.pcd", write_pcd, read_file);
  }
}

// ---- round trips -------------------------------------------------------------------------------

TEST(PcdTest, RoundTripIsExactInEveryEncoding) {
  const PointCloud c = make_full_cloud(500, 7);
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    SCOPED_TRACE(static_cast<int>(e));
    PcdWriteSettings ws;
    ws.encoding = e;
    expect_file_round_trip(c, ws, "pcd_roundtrip.pcd", write_pcd, read_file);
    expect_same_cloud(c, read_string(write_pcd_buffer(c, ws)));
  }
}

TEST(PcdTest, RoundTripOfSubsetsOfFields) {
  PointCloud c = make_full_cloud(50, 3);
  c.normals.clear();
  c.rings.clear();
  PointCloud xyz;
  xyz.points = c.points;
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    PcdWriteSettings ws;
    ws.encoding = e;
    expect_same_cloud(c, read_string(write_pcd_buffer(c, ws)));
    expect_same_cloud(xyz, read_string(write_pcd_buffer(xyz, ws)));
  }
}

TEST(PcdTest, EmptyCloudRoundTrips) {
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    PcdWriteSettings ws;
    ws.encoding = e;
    EXPECT_TRUE(read_string(write_pcd_buffer(PointCloud{}, ws)).empty());
  }
}

TEST(PcdTest, WriteRejectsInconsistentCloud) {
  PointCloud c = make_full_cloud(10, 1);
  c.intensities.pop_back();
  expect_error([&] { write_pcd(temp_path("pcd_bad.pcd"), c); }, {"pcd_bad.pcd", "intensities"});
}

TEST(PcdTest, WriteToBadPathThrows) {
  expect_error([] { write_pcd("/nonexistent_dir/x.pcd", make_full_cloud(3, 1)); }, {"/nonexistent_dir/x.pcd"});
}

// ---- hand-built files: types, skipped fields, header variants ----------------------------------

const char* kMixedHeader =
    "# hand-built\n"
    "VERSION 0.7\n"
    "FIELDS x y z rgb _ intensity hist ring label time normal_x normal_y normal_z curvature\n"
    "SIZE 8 2 1 4 1 2 4 1 8 4 4 4 4 4\n"
    "TYPE F I U U U U F U I F F F F F\n"
    "COUNT 1 1 1 1 3 1 2 1 1 1 1 1 1 1\n"
    "WIDTH 2\n"
    "HEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 2\n";

struct MixedPoint {
  double x;
  std::int16_t y;
  std::uint8_t z;
  std::uint32_t rgb;
  std::uint8_t pad[3];
  std::uint16_t intensity;
  float hist[2];
  std::uint8_t ring;
  std::int64_t label;
  float time, nx, ny, nz, curvature;
};

const MixedPoint kMixed[2] = {
    {1.5, -7, 200, 0xff00ff, {1, 2, 3}, 1000, {9.5f, -9.5f}, 31, -123456789, 0.05f, 0.0f, 0.6f, 0.8f, 0.01f},
    {-2.25, 32767, 0, 0, {0, 0, 0}, 65535, {0.0f, 1.0f}, 0, 2147483647, -0.1f, 1.0f, 0.0f, 0.0f, 0.5f},
};

template <class Emit>
void for_each_mixed_value(const MixedPoint& p, Emit&& emit) {
  emit(p.x);
  emit(p.y);
  emit(p.z);
  emit(p.rgb);
  for (auto v : p.pad) emit(v);
  emit(p.intensity);
  for (auto v : p.hist) emit(v);
  emit(p.ring);
  emit(p.label);
  emit(p.time);
  emit(p.nx);
  emit(p.ny);
  emit(p.nz);
  emit(p.curvature);
}

void check_mixed(const PointCloud& c) {
  ASSERT_EQ(c.size(), 2u);
  ASSERT_TRUE(c.has_normals() && c.has_intensities() && c.has_rings() && c.has_labels() && c.has_times());
  for (int i = 0; i < 2; ++i) {
    const MixedPoint& p = kMixed[i];
    EXPECT_EQ(c.points[i], Vector3f(static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)));
    EXPECT_EQ(c.normals[i], Vector3f(p.nx, p.ny, p.nz));
    EXPECT_EQ(c.intensities[i], static_cast<float>(p.intensity));
    EXPECT_EQ(c.rings[i], p.ring);
    EXPECT_EQ(c.labels[i], p.label);
    EXPECT_EQ(c.times[i], p.time);
  }
}

std::string mixed_ascii() {
  std::string s = std::string(kMixedHeader) + "DATA ascii\n";
  for (const MixedPoint& p : kMixed) {
    for_each_mixed_value(p, [&](auto v) {
      if constexpr (sizeof(v) == 1) {
        s += std::to_string(static_cast<int>(v));
      } else {
        s += std::to_string(v);
      }
      s += ' ';
    });
    s += "\n";
  }
  return s;
}

std::string mixed_binary() {
  std::string s = std::string(kMixedHeader) + "DATA binary\n";
  for (const MixedPoint& p : kMixed) for_each_mixed_value(p, [&](auto v) { append_raw(s, v); });
  return s;
}

std::string mixed_compressed_payload() {
  // Structure of arrays: every field's values for both points, field after field.
  std::vector<std::string> per_point(2);
  for (int i = 0; i < 2; ++i) for_each_mixed_value(kMixed[i], [&](auto v) { append_raw(per_point[i], v); });
  const int sizes[] = {8, 2, 1, 4, 3, 2, 8, 1, 8, 4, 4, 4, 4, 4};  // SIZE * COUNT
  std::string soa;
  int offset = 0;
  for (int s : sizes) {
    for (int i = 0; i < 2; ++i) soa += per_point[i].substr(static_cast<std::size_t>(offset), static_cast<std::size_t>(s));
    offset += s;
  }
  return soa;
}

// LZF stream with only literal runs (control byte L-1 then L bytes, L <= 32): a valid stream that
// any LZF decoder accepts, written here by hand so the test does not use our writer.
std::string lzf_literals(const std::string& raw) {
  std::string out;
  for (std::size_t i = 0; i < raw.size(); i += 32) {
    const std::size_t len = std::min<std::size_t>(32, raw.size() - i);
    out += static_cast<char>(len - 1);
    out += raw.substr(i, len);
  }
  return out;
}

std::string compressed_file(const std::string& header, const std::string& raw, std::uint32_t declared_raw_size) {
  const std::string lz = lzf_literals(raw);
  std::string s = header + "DATA binary_compressed\n";
  append_raw(s, static_cast<std::uint32_t>(lz.size()));
  append_raw(s, declared_raw_size);
  return s + lz;
}

TEST(PcdTest, ConvertsTypesAndSkipsUnknownFieldsInEveryEncoding) {
  check_mixed(read_string(mixed_ascii()));
  check_mixed(read_string(mixed_binary()));
  const std::string raw = mixed_compressed_payload();
  check_mixed(read_string(compressed_file(kMixedHeader, raw, static_cast<std::uint32_t>(raw.size()))));
}

TEST(PcdTest, ToleratesCrlfCommentsAndOldHeaders) {
  // PCD v.5 style: no VIEWPOINT, no COUNT, no POINTS; CRLF line ends; comments and blank lines.
  const std::string s =
      "# .PCD v.5 - Point Cloud Data file format\r\n# another comment\r\nVERSION .5\r\nFIELDS x y z\r\n"
      "SIZE 4 4 4\r\nTYPE F F F\r\n\r\nWIDTH 2\r\nHEIGHT 1\r\nDATA ascii\r\n1 2 3\r\n\r\n4.5 -5e-1 nan\r\n";
  const PointCloud c = read_string(s);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Vector3f(1, 2, 3));
  EXPECT_EQ(c.points[1].x(), 4.5f);
  EXPECT_EQ(c.points[1].y(), -0.5f);
  EXPECT_TRUE(std::isnan(c.points[1].z()));
  // POINTS without WIDTH.
  EXPECT_EQ(read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 1 1\n").size(), 1u);
}

TEST(PcdTest, LoneNormalComponentIsIgnored) {
  const PointCloud c = read_string("FIELDS x y z normal_x\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n1 2 3 4\n");
  ASSERT_EQ(c.size(), 1u);
  EXPECT_FALSE(c.has_normals());
}

TEST(PcdTest, DropNonFiniteDropsWholePointsWithTheirFields) {
  PointCloud c = make_full_cloud(20, 5);  // point 1 is NaN
  c.points[7].y() = std::numeric_limits<float>::infinity();
  PcdReadSettings drop;
  drop.drop_non_finite = true;
  const PointCloud r = read_string(write_pcd_buffer(c), drop);
  ASSERT_EQ(r.size(), 18u);
  EXPECT_EQ(r.labels[1], c.labels[2]);
  EXPECT_EQ(r.labels[6], c.labels[8]);
  EXPECT_EQ(read_string(write_pcd_buffer(c)).size(), 20u);
}

// ---- bad input ---------------------------------------------------------------------------------

const std::string kXyzHeader = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\n";

TEST(PcdTest, NonexistentAndEmptyFilesThrow) {
  expect_error([] { read_pcd("/nonexistent/none.pcd"); }, {"/nonexistent/none.pcd"});
  const std::string file = temp_path("pcd_empty.pcd");
  std::fclose(std::fopen(file.c_str(), "wb"));
  expect_error([&] { read_pcd(file); }, {file, "empty"});
  std::remove(file.c_str());
  expect_error([] { read_pcd_buffer(nullptr, 0, "null.pcd"); }, {"null.pcd"});
}

TEST(PcdTest, TruncatedDataThrowsInEveryEncoding) {
  PointCloud c = make_full_cloud(40, 9);
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    SCOPED_TRACE(static_cast<int>(e));
    PcdWriteSettings ws;
    ws.encoding = e;
    const std::string full = write_pcd_buffer(c, ws);
    // Cut inside the data (keep the DATA line): always an Error, never a crash. An ascii file
    // cut inside its last line may still parse (a shorter number is a number), so cut ascii
    // files at line starts, which always loses points.
    const std::size_t data_start = full.find('\n', full.find("DATA")) + 1;
    for (std::size_t cut = full.size() - 1; cut > data_start; cut -= 37) {
      std::size_t at = cut;
      if (e == PcdEncoding::kAscii) at = full.rfind('\n', cut - 1) + 1;
      EXPECT_THROW(read_string(full.substr(0, at)), Error) << "cut at " << at;
    }
  }
  expect_error([&] { read_string(kXyzHeader + "DATA binary\n" + std::string(35, '\0')); },
               {"mem.pcd", "byte", "truncated"});
  expect_error([&] { read_string(kXyzHeader + "DATA ascii\n1 2 3\n4 5 6\n"); }, {"mem.pcd:12", "truncated"});
  expect_error([&] { read_string(kXyzHeader + "DATA ascii\n1 2 3\n4 5\n7 8 9\n"); }, {"mem.pcd:11"});
  expect_error([&] { read_string(kXyzHeader + "DATA ascii\n1 2 3\n4 5 6 7\n7 8 9\n"); }, {"mem.pcd:11"});
  expect_error([&] { read_string(kXyzHeader + "DATA ascii\n1 2 3\n4 x 6\n7 8 9\n"); }, {"mem.pcd:11", "'x'"});
  expect_error([&] { read_string(kXyzHeader + "DATA binary_compressed\n" + std::string(5, '\0')); },
               {"mem.pcd", "byte", "truncated"});
  expect_error([&] { read_string(kXyzHeader + "DATA binary_compressed\n"); }, {"truncated"});
}

TEST(PcdTest, TruncatedHeaderThrows) {
  expect_error([&] { read_string(kXyzHeader); }, {"mem.pcd", "DATA"});
  expect_error([&] { read_string("VERSION 0.7\nFIEL"); }, {"mem.pcd:2"});
  expect_error([] { read_string(std::string("\x00\x01\x02\x03", 4)); }, {"mem.pcd:1"});
}

TEST(PcdTest, MissingCoordinateThrows) {
  expect_error([] { read_string("FIELDS x y intensity\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n"); },
               {"mem.pcd:1", "x, y or z"});
}

TEST(PcdTest, UnknownDataKindAndKeywordThrow) {
  expect_error([&] { read_string(kXyzHeader + "DATA binary_zstd\n"); }, {"mem.pcd:9", "binary_zstd"});
  expect_error([&] { read_string("VERSION 0.7\nFOO 1\n"); }, {"mem.pcd:2", "FOO"});
}

TEST(PcdTest, BadSizeTypeCombinationsThrow) {
  const char* bad[][2] = {{"2 4 4", "F F F"}, {"3 4 4", "U F F"}, {"4 4 4", "X F F"},
                          {"16 4 4", "I F F"}, {"4 4", "F F F"}, {"4 4 4", "F F"},
                          {"0 4 4", "U F F"}, {"-4 4 4", "F F F"}, {"4 4 4", "FF F F"}};
  for (const auto& b : bad) {
    SCOPED_TRACE(std::string(b[0]) + " / " + b[1]);
    const std::string s = std::string("FIELDS x y z\nSIZE ") + b[0] + "\nTYPE " + b[1] +
                          "\nWIDTH 1\nDATA binary\n" + std::string(64, '\0');
    expect_error([&] { read_string(s); }, {"mem.pcd:"});
  }
  expect_error([] { read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1\nWIDTH 1\nDATA ascii\n1 2 3\n"); },
               {"mem.pcd:4", "COUNT"});
  expect_error([] { read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 2 1 1\nWIDTH 1\nDATA ascii\n1 2 3 4\n"); },
               {"mem.pcd:4", "COUNT 1"});
  expect_error([] { read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 0 1 1\nWIDTH 1\nDATA ascii\n1 2 3\n"); },
               {"mem.pcd:4"});
  expect_error([] { read_string("FIELDS x y z x\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n1 2 3 4\n"); },
               {"twice"});
}

TEST(PcdTest, LyingPointCountsThrowWithoutHugeAllocation) {
  const std::string data(36, '\0');
  // Huge POINTS / WIDTH against 36 bytes of data: every encoding rejects before allocating.
  for (const char* dims : {"WIDTH 1000000000000\nHEIGHT 1\n", "WIDTH 4294967295\nHEIGHT 4294967295\n",
                           "WIDTH 18446744073709551615\nHEIGHT 1\n"}) {
    SCOPED_TRACE(dims);
    const std::string h = std::string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n") + dims;
    EXPECT_THROW(read_string(h + "DATA binary\n" + data), Error);
    EXPECT_THROW(read_string(h + "DATA ascii\n1 2 3\n"), Error);
    std::string comp = h + "DATA binary_compressed\n";
    append_raw(comp, std::uint32_t{4});
    append_raw(comp, std::uint32_t{0xffffffffu});
    EXPECT_THROW(read_string(comp + "abcd"), Error);
  }
  expect_error([] { read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\nHEIGHT 4294967296\nDATA ascii\n"); },
               {"overflows"});
  // POINTS disagreeing with WIDTH x HEIGHT.
  expect_error([&] { read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA binary\n" + data); },
               {"mem.pcd:6", "POINTS 3"});
  // Smaller POINTS than data: reads only what is declared.
  EXPECT_EQ(read_string(kXyzHeader + "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n10 11 12\n").size(), 3u);
  expect_error([] { read_string("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH -3\nDATA ascii\n"); }, {"mem.pcd:4", "WIDTH"});
}

TEST(PcdTest, CorruptCompressedDataThrows) {
  PointCloud c = make_full_cloud(100, 11);
  PcdWriteSettings ws;
  ws.encoding = PcdEncoding::kBinaryCompressed;
  const std::string good = write_pcd_buffer(c, ws);
  const std::size_t payload = good.find("binary_compressed\n") + 18;
  // Uncompressed size in the prefix disagreeing with the header.
  std::string bad = good;
  bad[payload + 4] = static_cast<char>(bad[payload + 4] + 1);
  expect_error([&] { read_string(bad); }, {"mem.pcd", "byte", "uncompressed size"});
  // Compressed size claiming more than the file has.
  bad = good;
  bad[payload + 3] = 0x7f;
  expect_error([&] { read_string(bad); }, {"truncated"});
  // A back reference before the start of the output is corrupt LZF (control 0xE0 = long match).
  const std::string raw(36, '\0');
  std::string lz = std::string("\xe0\xff\xff", 3);
  std::string s = kXyzHeader + "DATA binary_compressed\n";
  append_raw(s, static_cast<std::uint32_t>(lz.size()));
  append_raw(s, std::uint32_t{36});
  expect_error([&] { read_string(s + lz); }, {"mem.pcd", "corrupt LZF"});
  // A stream that decodes to fewer bytes than declared.
  expect_error([&] { read_string(compressed_file(kXyzHeader, raw.substr(0, 30), 36)); }, {"corrupt LZF"});
  // Flipped bytes in the stream: Error or a cloud, never a crash.
  for (std::size_t k = payload + 8; k < good.size(); k += 13) {
    bad = good;
    bad[k] = static_cast<char>(bad[k] ^ 0x5a);
    try {
      read_string(bad);
    } catch (const Error&) {
    }
  }
}

TEST(PcdTest, OutOfRangeIntegerDestinationThrows) {
  const std::string h = "FIELDS x y z ring\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\n";
  expect_error([&] { read_string(h + "DATA ascii\n1 2 3 70000\n"); }, {"mem.pcd:6", "ring"});
  expect_error([&] { read_string(h + "DATA ascii\n1 2 3 nan\n"); }, {"mem.pcd:6", "ring"});
  std::string b = h + "DATA binary\n";
  for (float v : {1.0f, 2.0f, 3.0f, -1.0f}) append_raw(b, v);
  expect_error([&] { read_string(b); }, {"mem.pcd", "byte", "ring"});
  const std::string hl = "FIELDS x y z label\nSIZE 4 4 4 4\nTYPE F F F U\nWIDTH 1\n";
  std::string bl = hl + "DATA binary\n";
  for (float v : {1.0f, 2.0f, 3.0f}) append_raw(bl, v);
  append_raw(bl, std::uint32_t{0x80000000u});
  expect_error([&] { read_string(bl); }, {"label"});
}

}  // namespace
}  // namespace plumb::io
