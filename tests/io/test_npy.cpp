#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/io/npy.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {
using test::read_text;
using test::shared_data;
using test::TempDir;
using test::write_text;

constexpr const char* kCase = "gsplat-reference/case1_n500_128x96";

using test::expect_error;

// Independent parse: v1.0 header length at bytes 8-9, raw values after it.
template <typename T>
std::vector<T> raw_values(const std::string& file) {
  const std::size_t start = 10 + std::uint8_t(file[8]) + 256 * std::uint8_t(file[9]);
  std::vector<T> values((file.size() - start) / sizeof(T));
  std::memcpy(values.data(), file.data() + start, values.size() * sizeof(T));
  return values;
}

// A v1.0 file with the given header dict (padded) and raw body.
std::string npy_file(std::string dict, const std::string& body, char major = 1) {
  const std::size_t prefix = major == 1 ? 10 : 12;
  dict.append(63 - (prefix + dict.size()) % 64, ' ');
  dict += '\n';
  std::string file = std::string("\x93NUMPY", 6) + major + '\0';
  const std::uint32_t len = std::uint32_t(dict.size());
  file.append(reinterpret_cast<const char*>(&len), prefix - 8);
  return file + dict + body;
}

template <typename T>
std::string raw_bytes(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

TEST(Npy, ReadsGsplatMeansLikeRawBytes) {
  RETIMEGS_REQUIRE_DATA(kCase);
  const auto path = shared_data() / kCase / "means.npy";
  const NpyArray a = read_npy(path);
  EXPECT_EQ(a.type, NpyArray::Type::kFloat32);
  EXPECT_EQ(a.shape, (std::vector<std::size_t>{500, 3}));
  const std::vector<float> raw = raw_values<float>(read_text(path));
  ASSERT_EQ(raw.size(), 1500u);
  ASSERT_EQ(a.size(), 1500u);
  for (std::size_t i = 0; i < raw.size(); ++i) ASSERT_EQ(float(a.values[i]), raw[i]) << i;
  EXPECT_EQ(a.to_float(), raw);
}

TEST(Npy, ReadsGsplatRadiiAsInt32) {
  RETIMEGS_REQUIRE_DATA(kCase);
  const auto path = shared_data() / kCase / "radii.npy";
  const NpyArray a = read_npy(path);
  EXPECT_EQ(a.type, NpyArray::Type::kInt32);
  EXPECT_EQ(a.shape, (std::vector<std::size_t>{500}));
  const std::vector<std::int32_t> raw = raw_values<std::int32_t>(read_text(path));
  ASSERT_EQ(raw.size(), 500u);
  EXPECT_EQ(a.to_int(), raw);
}

TEST(Npy, WriteReadRoundTripWithAlignedHeader) {
  TempDir dir;
  const std::vector<float> values = {0.1f, -2.5f, 3e-8f, 1e20f, 0.0f, -0.0f};
  write_npy(dir / "a.npy", {2, 3}, values);
  const std::string file = read_text(dir / "a.npy");
  const std::size_t start = 10 + std::uint8_t(file[8]) + 256 * std::uint8_t(file[9]);
  EXPECT_EQ(start % 64, 0u);
  EXPECT_EQ(file[start - 1], '\n');
  EXPECT_EQ(file.size(), start + 24);
  EXPECT_NE(file.find("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }"),
            std::string::npos);
  EXPECT_EQ(raw_values<float>(file), values);
  const NpyArray a = read_npy(dir / "a.npy");
  EXPECT_EQ(a.shape, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(a.to_float(), values);

  write_npy(dir / "b.npy", {3}, {1, 2, 3});
  EXPECT_NE(read_text(dir / "b.npy").find("'shape': (3,)"), std::string::npos);
  EXPECT_EQ(read_npy(dir / "b.npy").shape, (std::vector<std::size_t>{3}));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 2);
}

TEST(Npy, ReadsFloat64BuiltByHand) {
  TempDir dir;
  const std::vector<double> values = {0.1, -1e300, 5e-324, 42.0};
  write_text(dir / "d.npy", npy_file("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 2), }",
                                     raw_bytes(values)));
  const NpyArray a = read_npy(dir / "d.npy");
  EXPECT_EQ(a.type, NpyArray::Type::kFloat64);
  EXPECT_EQ(a.shape, (std::vector<std::size_t>{2, 2}));
  EXPECT_EQ(a.values, values);
}

TEST(Npy, ReadsVersion2HeaderAndScalar) {
  TempDir dir;
  write_text(dir / "v2.npy", npy_file("{'descr': '<i4', 'fortran_order': False, 'shape': (), }",
                                      raw_bytes(std::vector<std::int32_t>{-7}), 2));
  const NpyArray a = read_npy(dir / "v2.npy");
  EXPECT_TRUE(a.shape.empty());
  EXPECT_EQ(a.to_int(), (std::vector<std::int32_t>{-7}));
}

TEST(Npy, TruncatedBodyIsError) {
  TempDir dir;
  write_npy(dir / "a.npy", {2, 3}, std::vector<float>(6, 1.0f));
  const std::string file = read_text(dir / "a.npy");
  write_text(dir / "cut.npy", file.substr(0, file.size() - 4));
  const auto path = (dir / "cut.npy").string();
  expect_error([&] { read_npy(path); }, {path, "truncated", "expected 24 bytes, found 20"});
  write_text(dir / "head.npy", file.substr(0, 40));
  expect_error([&] { read_npy(dir / "head.npy"); }, {"head.npy", "truncated .npy header"});
}

TEST(Npy, HeaderProblemsAreErrors) {
  TempDir dir;
  const std::string body = raw_bytes(std::vector<float>(4, 0.0f));
  write_text(dir / "f.npy",
             npy_file("{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2), }", body));
  expect_error([&] { read_npy(dir / "f.npy"); }, {"f.npy", "Fortran"});
  write_text(dir / "be.npy",
             npy_file("{'descr': '>f4', 'fortran_order': False, 'shape': (4,), }", body));
  expect_error([&] { read_npy(dir / "be.npy"); }, {"be.npy", "big-endian"});
  write_text(dir / "i8.npy",
             npy_file("{'descr': '<i8', 'fortran_order': False, 'shape': (2,), }", body));
  expect_error([&] { read_npy(dir / "i8.npy"); }, {"i8.npy", "unsupported dtype '<i8'"});
  write_text(dir / "noshape.npy", npy_file("{'descr': '<f4', 'fortran_order': False, }", body));
  expect_error([&] { read_npy(dir / "noshape.npy"); }, {"noshape.npy", "shape"});
  std::string magic = npy_file("{'descr': '<f4', 'fortran_order': False, 'shape': (4,), }", body);
  magic[1] = 'M';
  write_text(dir / "magic.npy", magic);
  expect_error([&] { read_npy(dir / "magic.npy"); }, {"magic.npy", "bad magic"});
  expect_error([&] { read_npy(dir / "missing.npy"); }, {"missing.npy", "no such file"});
}

TEST(Npy, WriteRejectsShapeMismatchAndLeavesNothing) {
  TempDir dir;
  expect_error(
      [&] {
        write_npy(dir / "a.npy", {2, 3}, std::vector<float>(5));
      },
      {"a.npy", "6 values, not 5"});
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(Npy, ToIntRejectsFractions) {
  NpyArray a;
  a.values = {1.0, 2.5};
  expect_error([&] { a.to_int(); }, {"2.5", "index 1"});
}

// The declared shape is checked against the file's size before allocating (issue 26).
TEST(Npy, DeclaredShapeBeyondTheFileIsRefusedNamingIt) {
  TempDir dir;
  const std::string body = raw_bytes(std::vector<float>(4, 0.0f));
  struct Case {
    const char* name;
    const char* dict;
    const char* fragment;
  };
  const Case cases[] = {
      {"billion", "{'descr': '<f4', 'fortran_order': False, 'shape': (1000000000, 17), }",
       "truncated .npy body (expected 68000000000 bytes, found 16)"},
      {"overflow",
       "{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, 4294967296, 8), }",
       ".npy shape is too large"},
      {"max", "{'descr': '<i4', 'fortran_order': False, 'shape': (18446744073709551615,), }",
       ".npy shape is too large"},
      {"negative", "{'descr': '<f4', 'fortran_order': False, 'shape': (-4,), }", "bad shape"},
  };
  for (const Case& c : cases) {
    const auto path = dir / (std::string(c.name) + ".npy");
    write_text(path, npy_file(c.dict, body));
    SCOPED_TRACE(c.name);
    expect_error([&] { read_npy(path); }, {path.string(), c.fragment});
  }
}

}  // namespace
}  // namespace retimegs::io
