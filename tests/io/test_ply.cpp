#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/io/ply.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {
using test::read_text;
using test::TempDir;
using test::write_text;

using test::expect_error;

// Appends the bytes of v, reversed for big-endian files.
template <typename T>
void put(std::string& out, T v, bool big_endian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

PlyTable sample_table() {
  PlyTable t;
  t.add("x", {0.5f, -1.25f, 3e7f});
  t.add("y", {1e-9f, 2.0f, -0.0f});
  t.add("z", {-7.0f, 0.1f, 42.0f});
  t.add("opacity", {-3.5f, 0.0f, 12.0f});
  t.add("red", {0.0f, 254.6f, 300.0f});
  t.add("green", {-5.0f, 127.5f, 1.4f});
  t.add("blue", {255.0f, 12.0f, std::numeric_limits<float>::quiet_NaN()});
  return t;
}

TEST(Ply, BinaryRoundTripKeepsFloatsAndRoundsColours) {
  TempDir dir;
  const PlyTable t = sample_table();
  write_ply(dir / "t.ply", t);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
  const std::string file = read_text(dir / "t.ply");
  EXPECT_EQ(file.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(file.find("element vertex 3\n"), std::string::npos);
  EXPECT_NE(file.find("property float opacity\nproperty uchar red\n"), std::string::npos);
  const std::size_t body = file.find("end_header\n") + 11;
  EXPECT_EQ(file.size() - body, 3u * (4 * 4 + 3));

  const PlyTable back = read_ply(dir / "t.ply");
  EXPECT_EQ(back.count, 3u);
  EXPECT_EQ(back.names, t.names);
  for (const char* name : {"x", "y", "z", "opacity"}) EXPECT_EQ(back.column(name), t.column(name));
  EXPECT_EQ(back.column("red"), (std::vector<float>{0, 255, 255}));
  EXPECT_EQ(back.column("green"), (std::vector<float>{0, 128, 1}));
  EXPECT_EQ(back.column("blue"), (std::vector<float>{255, 12, 0}));
}

TEST(Ply, ReadsAsciiWithFaceListAfterVertex) {
  TempDir dir;
  write_text(dir / "a.ply",
             "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info nothing\r\n"
             "element vertex 3\r\nproperty float x\r\nproperty float y\r\nproperty double z\r\n"
             "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\n"
             "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
             "0 0 0 255 0 0\r\n1.5 -2 1e-3 0 51 255\r\n-0.25 3 7 10 20 30\r\n3 0 1 2\r\n");
  const PlyTable t = read_ply(dir / "a.ply");
  EXPECT_EQ(t.count, 3u);
  EXPECT_EQ(t.names, (std::vector<std::string>{"x", "y", "z", "red", "green", "blue"}));
  EXPECT_EQ(t.column("y"), (std::vector<float>{0, -2, 3}));
  EXPECT_EQ(t.column("z")[1], 1e-3f);
  const PointCloud p = read_points_ply(dir / "a.ply");
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p.xyz, (std::vector<float>{0, 0, 0, 1.5f, -2, 1e-3f, -0.25f, 3, 7}));
  ASSERT_EQ(p.rgb.size(), 9u);
  EXPECT_FLOAT_EQ(p.rgb[0], 1.0f);
  EXPECT_FLOAT_EQ(p.rgb[4], 0.2f);
  EXPECT_FLOAT_EQ(p.rgb[8], 30.0f / 255.0f);
}

TEST(Ply, SkipsElementsWithListsBeforeVertex) {
  TempDir dir;
  std::string file =
      "ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty float fx\n"
      "element face 2\nproperty list uchar int vertex_indices\nproperty short flags\n"
      "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "element edge 1\nproperty int a\nend_header\n";
  put(file, 500.0f);
  put<std::uint8_t>(file, 3);
  for (const std::int32_t i : {0, 1, 2}) put(file, i);
  put<std::int16_t>(file, 7);
  put<std::uint8_t>(file, 1);
  put<std::int32_t>(file, 1);
  put<std::int16_t>(file, 8);
  for (const float v : {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f}) put(file, v);
  put<std::int32_t>(file, 99);
  write_text(dir / "b.ply", file);
  const PointCloud p = read_points_ply(dir / "b.ply");
  EXPECT_EQ(p.xyz, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_TRUE(p.rgb.empty());

  write_text(dir / "c.ply",
             "ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int idx\n"
             "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
             "end_header\n3 0 1 2\n4 0 1 2 3\n9 8 7\n");
  EXPECT_EQ(read_points_ply(dir / "c.ply").xyz, (std::vector<float>{9, 8, 7}));
}

TEST(Ply, ReadsBigEndianEveryScalarType) {
  TempDir dir;
  std::string file =
      "ply\nformat binary_big_endian 1.0\nelement vertex 2\n"
      "property char a\nproperty uint8 b\nproperty int16 c\nproperty ushort d\n"
      "property int32 e\nproperty uint f\nproperty float32 g\nproperty float64 h\nend_header\n";
  for (int row = 0; row < 2; ++row) {
    const int s = row == 0 ? 1 : -1;
    put<std::int8_t>(file, std::int8_t(-5 * s), true);
    put<std::uint8_t>(file, 250, true);
    put<std::int16_t>(file, std::int16_t(-300 * s), true);
    put<std::uint16_t>(file, 60000, true);
    put<std::int32_t>(file, -70000 * s, true);
    put<std::uint32_t>(file, 4000000000u, true);
    put<float>(file, 1.5f * s, true);
    put<double>(file, -2.25 * s, true);
  }
  write_text(dir / "be.ply", file);
  const PlyTable t = read_ply(dir / "be.ply");
  ASSERT_EQ(t.count, 2u);
  const std::vector<std::vector<float>> expected = {{-5, 5},        {250, 250},      {-300, 300},
                                                    {60000, 60000}, {-70000, 70000}, {4e9f, 4e9f},
                                                    {1.5f, -1.5f},  {-2.25f, 2.25f}};
  EXPECT_EQ(t.columns, expected);
}

TEST(Ply, ReadsDoubleXyzAndFloatColours) {
  TempDir dir;
  std::string file =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
      "property double y\nproperty double z\nproperty float red\nproperty float green\n"
      "property float blue\nend_header\n";
  for (const double v : {0.1, -1e10, 1.0 / 3.0}) put(file, v);
  for (const float v : {0.25f, 0.5f, 1.0f}) put(file, v);
  write_text(dir / "d.ply", file);
  const PointCloud p = read_points_ply(dir / "d.ply");
  EXPECT_EQ(p.xyz, (std::vector<float>{0.1f, -1e10f, float(1.0 / 3.0)}));
  EXPECT_EQ(p.rgb, (std::vector<float>{0.25f, 0.5f, 1.0f}));
}

TEST(Ply, PointsRoundTripWithColours) {
  TempDir dir;
  PointCloud p;
  p.xyz = {1, 2, 3, -4, 5.5f, 6e-5f};
  p.rgb = {0.0f, 0.5f, 1.0f, 0.2f, 1.2f, -0.1f};
  write_points_ply(dir / "p.ply", p);
  const PointCloud back = read_points_ply(dir / "p.ply");
  EXPECT_EQ(back.xyz, p.xyz);
  const std::vector<float> rgb = {0, 128 / 255.0f, 1, 51 / 255.0f, 1, 0};
  ASSERT_EQ(back.rgb.size(), rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i) EXPECT_FLOAT_EQ(back.rgb[i], rgb[i]) << i;
  p.rgb.clear();
  write_points_ply(dir / "q.ply", p);
  EXPECT_TRUE(read_points_ply(dir / "q.ply").rgb.empty());
  EXPECT_EQ(read_ply(dir / "q.ply").names, (std::vector<std::string>{"x", "y", "z"}));
}

TEST(Ply, TruncatedBodyIsError) {
  TempDir dir;
  PointCloud p;
  p.xyz.assign(30, 1.0f);
  write_points_ply(dir / "p.ply", p);
  const std::string file = read_text(dir / "p.ply");
  write_text(dir / "cut.ply", file.substr(0, file.size() - 5));
  const std::string path = (dir / "cut.ply").string();
  expect_error([&] { read_ply(path); }, {path, "truncated PLY body (vertex 9 of 10)"});
  write_text(dir / "cut.txt",
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
             "end_header\n1 2\n3\n");
  expect_error([&] { read_ply(dir / "cut.txt"); },
               {"cut.txt", "element 'vertex' declares 2 rows, more than the 6 bytes"});
  write_text(dir / "cut2.txt",
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
             "end_header\n1 2\n3   \n");
  expect_error([&] { read_ply(dir / "cut2.txt"); },
               {"cut2.txt", "truncated PLY body (vertex 1 of 2)"});
}

// Counts declared in the header are checked against the file's size before anything is allocated
// or looped over (issue 26: a 62-byte PLY declaring 10^9 vertices allocated 3.9 GB; an element
// without properties looped 10^18 times).
TEST(Ply, DeclaredCountsBeyondTheFileAreRefusedNamingTheCount) {
  TempDir dir;
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  struct Case {
    const char* name;
    std::string text;
    const char* fragment;
  };
  const Case cases[] = {
      {"ascii_1e9",
       "ply\nformat ascii 1.0\nelement vertex 1000000000\n" + xyz + "end_header\n1 2 3\n",
       "element 'vertex' declares 1000000000 rows"},
      {"binary_1e9",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n" + xyz + "end_header\n",
       "truncated PLY body (vertex 0 of 1000000000)"},
      {"max_count",
       "ply\nformat binary_big_endian 1.0\nelement vertex 18446744073709551615\n" + xyz +
           "end_header\n0123456789ab",
       "truncated PLY body (vertex 1 of 18446744073709551615)"},
      {"face_before_vertex",
       "ply\nformat binary_little_endian 1.0\nelement face 1000000000\nproperty list uchar int "
       "vertex_index\nelement vertex 1\n" +
           xyz + "end_header\n",
       "element 'face' declares 1000000000 rows"},
      {"no_properties",
       "ply\nformat ascii 1.0\nelement edge 1000000000000000000\nelement vertex 1\n" + xyz +
           "end_header\n1 2 3\n",
       "element 'edge' declares 1000000000000000000 rows but no properties"},
      {"huge_list",
       "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uint float v\n"
       "element vertex 1\n" +
           xyz + "end_header\n\xff\xff\xff\xff",
       "invalid list length 4294967295"},
      {"float_list_length",
       "ply\nformat ascii 1.0\nelement face 1\nproperty list float float v\nelement vertex 1\n" +
           xyz + "end_header\n1e300 1\n1 2 3\n",
       "invalid list length 1e+300"},
      // fuzz/corpus/ply/empty_element.ply: an element of 0 rows without properties divided by 0.
      {"empty_element",
       "ply\nformat binary_big_endian 1.0\nelement face 0\nelement vertex 1000\n" + xyz +
           "end_header\n",
       "truncated PLY body (vertex 0 of 1000)"},
      {"header_at_eof", "ply\nformat ascii 1.0\nelement vertex 1\n" + xyz + "end_header",
       "element 'vertex' declares 1 rows, more than the 0 bytes"},
  };
  for (const Case& c : cases) {
    const auto path = dir / (std::string(c.name) + ".ply");
    write_text(path, c.text);
    SCOPED_TRACE(c.name);
    expect_error([&] { read_points_ply(path); }, {path.string(), c.fragment});
  }
}

// NaN or infinite colours are refused like coordinates (they became 0 silently).
TEST(Ply, NonFiniteColourIsError) {
  TempDir dir;
  for (const char* value : {"nan", "inf", "-inf"}) {
    write_text(dir / "c.ply",
               std::string("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty "
                           "float y\nproperty float z\nproperty float red\nproperty float "
                           "green\nproperty float blue\nend_header\n0 0 0 1 1 1\n1 1 1 0.5 ") +
                   value + " 0\n");
    SCOPED_TRACE(value);
    expect_error([&] { read_points_ply(dir / "c.ply"); },
                 {"c.ply", "non-finite colour 'green'", "vertex 1"});
  }
}

TEST(Ply, NanCoordinateIsError) {
  TempDir dir;
  PlyTable t;
  t.add("x", {0, 1, 2});
  t.add("y", {0, 1, std::numeric_limits<float>::quiet_NaN()});
  t.add("z", {0, 1, 2});
  write_ply(dir / "n.ply", t);
  EXPECT_TRUE(std::isnan(read_ply(dir / "n.ply").column("y")[2]));
  expect_error([&] { read_points_ply(dir / "n.ply"); }, {"n.ply", "non-finite", "vertex 2"});
}

TEST(Ply, MalformedHeadersAreErrors) {
  TempDir dir;
  write_text(dir / "list.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
             "property list uchar float extra\nend_header\n1 2 3 4\n");
  expect_error([&] { read_ply(dir / "list.ply"); }, {"list.ply", "list property 'extra'"});
  write_text(dir / "end.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n1\n");
  expect_error([&] { read_ply(dir / "end.ply"); }, {"end.ply", "unexpected PLY header line '1'"});
  write_text(dir / "end2.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  expect_error([&] { read_ply(dir / "end2.ply"); }, {"end2.ply", "end_header"});
  write_text(dir / "nov.ply", "ply\nformat ascii 1.0\nelement face 0\nend_header\n");
  expect_error([&] { read_ply(dir / "nov.ply"); }, {"nov.ply", "no vertex element"});
  write_text(dir / "type.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\nend_header\n1\n");
  expect_error([&] { read_ply(dir / "type.ply"); },
               {"type.ply", "unknown PLY property type 'half'"});
  write_text(dir / "noxyz.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
  expect_error([&] { read_points_ply(dir / "noxyz.ply"); }, {"noxyz.ply", "'y'"});
  write_text(dir / "obj.ply", "OFF\n");
  expect_error([&] { read_ply(dir / "obj.ply"); }, {"obj.ply", "not a PLY file"});
  expect_error([&] { read_ply(dir / "missing.ply"); }, {"missing.ply", "no such file"});
}

TEST(Ply, TableRejectsMismatchedColumns) {
  PlyTable t;
  t.add("x", {1, 2});
  expect_error([&] { t.add("y", {1}); }, {"'y'", "1 values", "2 rows"});
  expect_error([&] { t.add("x", {1, 2}); }, {"already", "'x'"});
  expect_error([&] { t.column("z"); }, {"no column 'z'"});
  TempDir dir;
  t.columns[0].pop_back();
  expect_error([&] { write_ply(dir / "bad.ply", t); }, {"bad.ply", "'x'"});
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace retimegs::io
