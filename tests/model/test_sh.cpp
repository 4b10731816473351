#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "retimegs/model/sh.hpp"

namespace retimegs::model {
namespace {

TEST(Sh, BasisAtPoleAndOrthonormality) {
  const double z[3] = {0, 0, 1};
  double b[kMaxShCoeffs] = {};
  sh_basis(3, z, b);
  EXPECT_DOUBLE_EQ(b[0], kShC0);
  EXPECT_DOUBLE_EQ(b[2], 0.4886025119029199);       // sqrt(3 / 4pi)
  EXPECT_DOUBLE_EQ(b[6], 2 * 0.31539156525252005);  // sqrt(5 / 16pi) * 2
  EXPECT_DOUBLE_EQ(b[12], 2 * 0.3731763325901154);  // sqrt(7 / 16pi) * 2
  for (int k : {1, 3, 4, 5, 7, 8, 9, 10, 11, 13, 14, 15}) EXPECT_EQ(b[k], 0.0) << k;

  // Real SH are orthonormal on the sphere: (4pi / M) sum_i b_j(d_i) b_k(d_i) -> delta_jk.
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  constexpr int kSamples = 200000;
  double gram[16][16] = {};
  for (int s = 0; s < kSamples; ++s) {
    double d[3] = {normal(rng), normal(rng), normal(rng)};
    const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (double& v : d) v /= n;
    sh_basis(3, d, b);
    for (int j = 0; j < 16; ++j)
      for (int k = 0; k < 16; ++k) gram[j][k] += b[j] * b[k];
  }
  for (int j = 0; j < 16; ++j)
    for (int k = 0; k < 16; ++k)
      EXPECT_NEAR(gram[j][k] * 4 * M_PI / kSamples, j == k ? 1.0 : 0.0, 0.02) << j << "," << k;
}

TEST(Sh, ColorVjpMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0, 0.4);
  for (int degree = 0; degree <= 3; ++degree) {
    const int k = sh_coeffs(degree);
    std::vector<double> h(3 * k);
    for (double& v : h) v = normal(rng);
    h[0] = 1.0;  // keep red away from the clamp
    double dir[3] = {0.3, -1.2, 2.0};
    const double v_rgb[3] = {0.7, -0.4, 1.3};
    std::vector<double> v_h(3 * k, 0.0);
    double v_dir[3] = {0, 0, 0};
    sh_color_vjp(degree, h.data(), dir, v_rgb, v_h.data(), v_dir);
    auto loss = [&] {
      double rgb[3];
      sh_color(degree, h.data(), dir, rgb);
      return rgb[0] * v_rgb[0] + rgb[1] * v_rgb[1] + rgb[2] * v_rgb[2];
    };
    constexpr double eps = 1e-6;
    for (int i = 0; i < 3 * k; ++i) {
      const double keep = h[i];
      h[i] = keep + eps;
      const double up = loss();
      h[i] = keep - eps;
      const double down = loss();
      h[i] = keep;
      EXPECT_NEAR(v_h[i], (up - down) / (2 * eps), 1e-7) << "degree " << degree << " h " << i;
    }
    for (int a = 0; a < 3; ++a) {
      const double keep = dir[a];
      dir[a] = keep + eps;
      const double up = loss();
      dir[a] = keep - eps;
      const double down = loss();
      dir[a] = keep;
      EXPECT_NEAR(v_dir[a], (up - down) / (2 * eps), 1e-7) << "degree " << degree << " dir " << a;
    }
  }
}

TEST(Sh, ClampedChannelHasNoGradient) {
  const double h[3] = {-5.0, 1.0, 1.0};  // red far below zero
  const double dir[3] = {0, 0, 1}, v_rgb[3] = {1, 1, 1};
  double rgb[3], v_h[3] = {0, 0, 0}, v_dir[3] = {0, 0, 0};
  sh_color(0, h, dir, rgb);
  EXPECT_EQ(rgb[0], 0.0);
  EXPECT_NEAR(rgb[1], 0.5 + kShC0, 1e-15);
  sh_color_vjp(0, h, dir, v_rgb, v_h, v_dir);
  EXPECT_EQ(v_h[0], 0.0);
  EXPECT_NEAR(v_h[1], kShC0, 1e-15);
}

}  // namespace
}  // namespace retimegs::model
