#include <random>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {

Splats random_splats(std::size_t n, int degree, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal;
  Splats s;
  s.sh_degree = degree;
  s.means.resize(3 * n);
  s.log_scales.resize(3 * n);
  s.quats.resize(4 * n);
  s.opacity_logits.resize(n);
  s.sh.resize(n * s.sh_coeffs() * 3);
  for (auto* v : {&s.means, &s.log_scales, &s.quats, &s.opacity_logits, &s.sh})
    for (float& x : *v) x = normal(rng);
  return s;
}

TEST(SplatPly, ExactInriaPropertyList) {
  test::TempDir dir;
  write_splat_ply(dir / "a.ply", random_splats(5, 1, 1));
  const PlyTable table = read_ply(dir / "a.ply");
  std::vector<std::string> expected = {"x",  "y",      "z",      "nx",    "ny",
                                       "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int i = 0; i < 45; ++i) expected.push_back("f_rest_" + std::to_string(i));
  for (const char* name :
       {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    expected.push_back(name);
  EXPECT_EQ(table.names, expected);
  EXPECT_EQ(table.count, 5u);
  // Header: binary little-endian float32 properties, as viewers expect.
  const std::string text = test::read_text(dir / "a.ply");
  EXPECT_NE(text.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(text.find("property float f_rest_44"), std::string::npos);
}

TEST(SplatPly, RoundTripEveryDegreeAndChannelMajorRest) {
  test::TempDir dir;
  for (int degree = 0; degree <= 3; ++degree) {
    const Splats s = random_splats(7, degree, 10 + degree);
    write_splat_ply(dir / "s.ply", s);
    const Splats r = read_splat_ply(dir / "s.ply");
    // Written with 45 f_rest: read back as degree 3 with zeros above the original degree.
    ASSERT_EQ(r.sh_degree, 3);
    EXPECT_EQ(r.means, s.means);
    EXPECT_EQ(r.log_scales, s.log_scales);
    EXPECT_EQ(r.quats, s.quats);
    EXPECT_EQ(r.opacity_logits, s.opacity_logits);
    for (std::size_t i = 0; i < 7; ++i)
      for (int k = 0; k < 16; ++k)
        for (int c = 0; c < 3; ++c)
          EXPECT_EQ(r.sh[(i * 16 + k) * 3 + c],
                    k < s.sh_coeffs() ? s.sh[(i * s.sh_coeffs() + k) * 3 + c] : 0.0f);
  }
  // Channel-major f_rest: f_rest_15 is the first *green* coefficient (k = 1, channel 1).
  const Splats s = random_splats(2, 3, 99);
  write_splat_ply(dir / "t.ply", s);
  const PlyTable table = read_ply(dir / "t.ply");
  EXPECT_EQ(table.column("f_rest_15")[1], s.sh[(1 * 16 + 1) * 3 + 1]);
  EXPECT_EQ(table.column("f_rest_0")[1], s.sh[(1 * 16 + 1) * 3 + 0]);
  EXPECT_EQ(table.column("f_dc_2")[0], s.sh[2]);
}

TEST(SplatPly, RefusesFilesThatAreNotSplats) {
  test::TempDir dir;
  PointCloud points;
  points.xyz = {0, 0, 0, 1, 1, 1};
  write_points_ply(dir / "p.ply", points);
  try {
    read_splat_ply(dir / "p.ply");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("p.ply"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("missing property"), std::string::npos);
  }
  Splats s = random_splats(3, 0, 5);
  s.log_scales[4] = std::numeric_limits<float>::infinity();
  write_splat_ply(dir / "inf.ply", s);
  EXPECT_THROW(read_splat_ply(dir / "inf.ply"), Error);
}

}  // namespace
}  // namespace retimegs::io
