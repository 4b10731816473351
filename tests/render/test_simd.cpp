// The simd helpers whose lane bookkeeping is easy to get wrong (row <-> column transposes) and
// the vector elementary functions.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "render/simd.hpp"

namespace retimegs::render {
namespace {

template <int W>
void check_transpose() {
  constexpr int kLanes = simd::kLanes;
  std::vector<float> rows(kLanes * W);  // [16, W]
  std::iota(rows.begin(), rows.end(), 1.0f);
  simd::vf columns[W];
  simd::load_columns<W>(rows.data(), columns);
  for (int l = 0; l < kLanes; ++l)
    for (int k = 0; k < W; ++k)
      EXPECT_EQ(columns[k][l], rows[W * l + k]) << "W " << W << " row " << l << " component " << k;
  std::vector<float> back(rows.size(), -1.0f);
  simd::store_columns<W>(back.data(), columns);
  EXPECT_EQ(back, rows) << "W " << W;
}

TEST(RenderSimd, ColumnsOfRowsRoundTrip) {
  check_transpose<1>();
  check_transpose<2>();
  check_transpose<3>();
  check_transpose<4>();
}

// f applied 16 lanes at a time to xs: [xs.size()] results (the last vector padded with the last
// value).
template <typename F>
std::vector<float> map_lanes(const std::vector<float>& xs, F f) {
  std::vector<float> ys(xs.size());
  for (std::size_t first = 0; first < xs.size(); first += simd::kLanes) {
    simd::vf x{};
    for (int l = 0; l < simd::kLanes; ++l) x[l] = xs[std::min(first + l, xs.size() - 1)];
    const simd::vf y = f(x);
    for (int l = 0; l < simd::kLanes && first + l < xs.size(); ++l) ys[first + l] = y[l];
  }
  return ys;
}

// Every 997th float in (0, 1] (denormals included) and a sweep above 1, against log in double.
TEST(RenderSimd, LogIsWithinTwoUlps) {
  std::vector<float> xs;
  for (std::uint32_t bits = 1; bits <= 0x3f800000u; bits += 997)
    xs.push_back(std::bit_cast<float>(bits));
  for (float x = 1.0f; x < 1e6f; x *= 1.001f) xs.push_back(x);
  xs.push_back(1.0f);
  const std::vector<float> ys = map_lanes(xs, [](simd::vf x) { return simd::log_nonnegative(x); });
  double worst_ulps = 0;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const double want = std::log(double(xs[i]));
    const float magnitude = float(std::abs(want));
    const double ulp = std::nextafter(magnitude, INFINITY) - magnitude;
    worst_ulps = std::max(worst_ulps, std::abs(ys[i] - want) / ulp);
    if (xs[i] == 1.0f) {
      EXPECT_EQ(ys[i], 0.0f);
    }
  }
  EXPECT_LT(worst_ulps, 2.0);
  EXPECT_EQ(simd::log_nonnegative(simd::vf{})[0], -std::numeric_limits<float>::infinity());
}

// 2^y on a fine sweep of the range the blend and the projection use (alpha's log2 down to the
// flush level, log-scales up to ~2^50), against exp2 in double; 2^0 and whole powers exact.
TEST(RenderSimd, Exp2IsWithinItsBound) {
  std::vector<float> ys;
  for (float y = -126.0f; y < 50.0f; y += 0.000977f) ys.push_back(y);
  const std::vector<float> es = map_lanes(ys, [](simd::vf y) { return simd::exp2(y); });
  double worst = 0;
  for (std::size_t i = 0; i < ys.size(); ++i) {
    const double want = std::exp2(double(ys[i]));
    worst = std::max(worst, std::abs(es[i] - want) / want);
  }
  EXPECT_LT(worst, 3e-7);
  for (float whole : {-126.0f, -8.0f, -1.0f, 0.0f, 1.0f, 20.0f, 127.0f})
    EXPECT_EQ(simd::exp2(simd::splat(whole))[0], std::exp2(whole)) << whole;
}

}  // namespace
}  // namespace retimegs::render
