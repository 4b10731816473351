// The regulariser and the squared error of the log's PSNR on the device (cuda/losses.hpp) against
// the CPU's loops over the same formulas: train::regularizer and regularizer_backward run
// train/loss_formulas.hpp's regularizer_add and regularizer_row_backward per row, and core's psnr()
// sums (a − b)² in double. Sums are compared at the bound of adding positive doubles in another
// order; per-row gradients at the last bit of exp. Device outputs are poisoned (NaN) first;
// accumulated gradients start from random values.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/random_arrays.hpp"
#include "cuda/require_gpu.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/cuda/losses.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "retimegs/model/primitives.hpp"
#include "retimegs/train/loss_formulas.hpp"

namespace retimegs::cuda {
namespace {

constexpr unsigned char kNaN = 0xff;  // every float and double of all-ones bytes is a NaN

// Two sums of the same `count` positive terms in different orders differ by at most
// 2 (count − 1) ε of the sum; a term's exp may differ in its last bit: 4 (count + 4) ε, with
// margin.
double positive_sum_bound(double sum, std::size_t count) {
  return 4.0 * double(count + 4) * DBL_EPSILON * std::abs(sum);
}

struct RegularizerCase {
  std::size_t n;
  double fraction;  // of the rows regularised
  double opacity_weight, scale_weight;
  std::uint64_t seed;
};

TEST(RegularizerCuda, ValueAndGradientMatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const RegularizerCase cases[] = {{1, 1.0, 0.01, 0.01, 1},
                                   {777, 0.5, 0.01, 0.0, 2},
                                   {20011, 0.4, 0.02, 0.005, 3},
                                   {100003, 0.9, 0.0, 0.01, 4}};
  for (const RegularizerCase& c : cases) {
    SCOPED_TRACE(testing::Message() << "n " << c.n);
    model::Primitives p;
    p.resize(c.n);
    p.opacity_logit = test::random_floats(c.n, -6.0f, 6.0f, c.seed);
    p.log_scale = test::random_floats(3 * c.n, -6.0f, 1.0f, c.seed + 1);
    std::vector<std::int32_t> rows = test::random_rows(c.n, c.fraction, c.seed + 2);
    if (rows.empty()) rows = {0};

    // The value: the CPU's order (train::regularizer's runs) is one order among many.
    double host = 0;
    for (const std::int32_t r : rows)
      host = train::regularizer_add(host, c.opacity_weight, c.scale_weight, c.n, p.opacity_logit[r],
                                    &p.log_scale[3 * r]);
    DevicePrimitives dp;
    dp.upload(p);
    DeviceBuffer<std::int32_t> d_rows;
    d_rows.upload(rows);
    DeviceBuffer<double> value(1);
    value.fill_bytes(kNaN);
    LossScratch scratch;
    regularizer(dp, d_rows.data(), rows.size(), c.opacity_weight, c.scale_weight, value.data(),
                scratch);
    const double device = value.download()[0];
    EXPECT_GT(host, 0);
    EXPECT_NEAR(device, host, positive_sum_bound(host, 4 * rows.size()));

    // The gradient, into random starting values.
    model::PrimitiveGrads hg(c.n);
    hg.v_opacity_logit = test::random_floats(c.n, -1e-3f, 1e-3f, c.seed + 3);
    hg.v_log_scale = test::random_floats(3 * c.n, -1e-3f, 1e-3f, c.seed + 4);
    DevicePrimitiveGrads dg;
    dg.resize_zero(c.n);
    dg.v_opacity_logit.upload(hg.v_opacity_logit);
    dg.v_log_scale.upload(hg.v_log_scale);
    const model::PrimitiveGrads start = hg;
    for (const std::int32_t r : rows)
      train::regularizer_row_backward(c.opacity_weight, c.scale_weight, c.n, p.opacity_logit[r],
                                      &p.log_scale[3 * r], hg.v_opacity_logit[r],
                                      &hg.v_log_scale[3 * r]);
    regularizer_backward(dp, d_rows.data(), rows.size(), c.opacity_weight, c.scale_weight, dg);
    model::PrimitiveGrads got;
    dg.download(got);
    // An increment may differ in its last bit (exp's last bit in double, rarely reaching the
    // float): the sums differ by at most an ulp of the increment and one of the result.
    std::size_t identical = 0, values = 0;
    const auto expect_close = [&](const char* what, const std::vector<float>& g,
                                  const std::vector<float>& h, const std::vector<float>& s) {
      for (std::size_t i = 0; i < h.size(); ++i) {
        const double bound = 2 * FLT_EPSILON * (std::abs(h[i]) + std::abs(h[i] - s[i]));
        ASSERT_LE(std::abs(double(g[i]) - h[i]), bound)
            << what << " " << i << ": " << g[i] << " vs " << h[i];
        identical += test::ulps(g[i], h[i]) == 0;
        ++values;
      }
    };
    expect_close("v_opacity_logit", got.v_opacity_logit, hg.v_opacity_logit, start.v_opacity_logit);
    expect_close("v_log_scale", got.v_log_scale, hg.v_log_scale, start.v_log_scale);
    // The other fields are not touched: still zero.
    EXPECT_EQ(got.v_mu, std::vector<float>(3 * c.n, 0.0f));
    EXPECT_EQ(got.v_sh, std::vector<float>(model::Primitives::kShWidth * c.n, 0.0f));
    std::printf(
        "[ measured ] regulariser, %zu rows: value off by %.3g relative, %zu of %zu "
        "gradient values bit-identical\n",
        rows.size(), std::abs(device - host) / host, identical, values);
  }
}

TEST(RegularizerCuda, NoRowsIsZero) {
  RETIMEGS_REQUIRE_GPU();
  model::Primitives p;
  p.resize(10);
  p.opacity_logit = test::random_floats(10, -1.0f, 1.0f, 1);
  DevicePrimitives dp;
  dp.upload(p);
  DeviceBuffer<double> value(1);
  value.fill_bytes(kNaN);
  LossScratch scratch;
  regularizer(dp, nullptr, 0, 0.01, 0.01, value.data(), scratch);
  EXPECT_EQ(value.download()[0], 0.0);
}

// core's psnr() sum: Σ (a − b)² over the RGB of every pixel, in double, in pixel order.
double host_squared_error(const Image& rgb, const Image& target) {
  double sum = 0;
  for (std::size_t p = 0; p < rgb.pixels(); ++p)
    for (int c = 0; c < 3; ++c) {
      const double d = double(rgb.data[p * rgb.channels + c]) - double(target.data[3 * p + c]);
      sum += d * d;
    }
  return sum;
}

TEST(SquaredErrorCuda, MatchesTheCpuAndGivesItsPsnr) {
  RETIMEGS_REQUIRE_GPU();
  struct Case {
    int width, height, channels;
  };
  const Case cases[] = {{13, 9, 3}, {70, 45, 4}, {129, 67, 7}, {640, 360, 3}};
  std::uint64_t seed = 10;
  for (const Case& c : cases) {
    SCOPED_TRACE(testing::Message() << c.width << "x" << c.height << "x" << c.channels);
    Image view(c.width, c.height, 3);
    view.data = test::random_floats(view.data.size(), 0.0f, 1.0f, ++seed);
    DevicePackedImage packed;
    packed.upload(pack(view, "random view"));
    unpack(pack(view, "random view"), view);  // the target as training holds it
    Image render(c.width, c.height, c.channels);
    render.data = test::random_floats(render.data.size(), -0.2f, 1.2f, ++seed);

    DeviceSsimTarget target;
    target.assign(packed);
    DeviceBuffer<float> d_render;
    d_render.upload(render.data);
    DeviceBuffer<double> out(2);
    out.fill_bytes(kNaN);
    LossScratch scratch;
    squared_error(d_render.data(), c.channels, target, out.data(), scratch);
    DeviceBuffer<float> d_view;
    d_view.upload(view.data);
    squared_error(d_render.data(), c.channels, d_view.data(), c.width, c.height, out.data() + 1,
                  scratch);
    const std::vector<double> got = out.download();

    const double host = host_squared_error(render, view);
    const std::size_t count = 3 * view.pixels();
    EXPECT_GT(host, 0);
    EXPECT_NEAR(got[0], host, positive_sum_bound(host, count));
    EXPECT_EQ(got[1], got[0]);  // the same sum, from the prepared view or a plain array
    // The log's PSNR: core's own function on the host images, and its rule on the device's sum.
    const double psnr_host = psnr(test::first_channels(render, 3), view);
    // d psnr = 10 / ln 10 · (relative difference of the sums).
    EXPECT_NEAR(psnr_from_squared_error(got[0], count), psnr_host,
                10 / std::log(10.0) * positive_sum_bound(host, count) / host + 1e-12);
  }
}

TEST(SquaredErrorCuda, PerfectMatchIsInfinitePsnr) {
  RETIMEGS_REQUIRE_GPU();
  Image view(37, 23, 3);
  view.data = test::random_floats(view.data.size(), 0.0f, 1.0f, 5);
  DeviceBuffer<float> d_view;
  d_view.upload(view.data);
  DeviceBuffer<double> out(1);
  out.fill_bytes(kNaN);
  LossScratch scratch;
  squared_error(d_view.data(), 3, d_view.data(), view.width, view.height, out.data(), scratch);
  const double sum = out.download()[0];
  EXPECT_EQ(sum, 0.0);
  EXPECT_EQ(psnr_from_squared_error(sum, 3 * view.pixels()), psnr(view, view));
}

}  // namespace
}  // namespace retimegs::cuda
