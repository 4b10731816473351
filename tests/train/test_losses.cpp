// The training losses' gradients against central differences. Images are float, so the renders
// hold multiples of 2^-8 and the steps are 2^-11: render ± step is exact in float, and every
// render value stays 2^-9 away from its target, off the kinks of the L1 terms. The losses sum in
// double, so the differences are accurate far below the tolerances.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/parallel.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/train/losses.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {

constexpr float kStep = 1.0f / 2048;

// d loss / d value by central differences of step kStep.
template <typename Loss>
double central_difference(float& value, const Loss& loss) {
  return test::central_difference(value, kStep, loss);
}

// RGB plus the flow channels, values k / 256 in [0.25, 0.75].
Image make_render(int width, int height, std::mt19937& rng) {
  Image render(width, height, 3 + model::kFlowChannels);
  std::uniform_int_distribution<int> level(64, 192);
  for (float& v : render.data) v = float(level(rng)) / 256;
  return render;
}

// (render value, target value) pairs differ by at least 2^-9.
Image make_target(const Image& render, std::mt19937& rng) {
  Image target(render.width, render.height, 3);
  std::uniform_int_distribution<int> offset(0, 8);
  std::bernoulli_distribution sign(0.5);
  for (std::size_t p = 0; p < render.pixels(); ++p)
    for (int c = 0; c < 3; ++c) {
      const float d = (float(offset(rng)) + 0.5f) / 256;
      target.data[3 * p + c] = render.data[render.channels * p + c] + (sign(rng) ? d : -d);
    }
  return target;
}

TEST(Losses, ImageLossGradientMatchesCentralDifferences) {
  std::mt19937 rng(4);
  Image render = make_render(23, 19, rng);
  const Image target = make_target(render, rng);
  constexpr double kLambda = 0.2, kWeight = 0.7;
  SsimTarget prepared;
  prepared.assign(target);
  Image v_render(render.width, render.height, render.channels);
  Image buffer;
  const double loss = image_loss(rgb_of(render, buffer), prepared, kLambda, kWeight, v_render);
  // The gradient accumulates (its L1 and SSIM parts are added one after the other: equal up to
  // rounding); the flow channels take none.
  Image twice = v_render;
  EXPECT_EQ(image_loss(rgb_of(render, buffer), prepared, kLambda, kWeight, twice), loss);
  EXPECT_EQ(&rgb_of(target, buffer), &target) << "an RGB image is its own RGB";
  float largest = 0;
  for (const float v : v_render.data) largest = std::max(largest, std::abs(v));
  for (std::size_t i = 0; i < render.data.size(); ++i) {
    ASSERT_NEAR(twice.data[i], 2 * v_render.data[i], 1e-6f * largest) << i;
    if (int(i % render.channels) >= 3) {
      ASSERT_EQ(v_render.data[i], 0.0f) << i;
    }
  }
  Image unused(render.width, render.height, render.channels);
  std::uniform_int_distribution<std::size_t> pixel(0, render.pixels() - 1);
  std::uniform_int_distribution<int> channel(0, 2);
  for (int trial = 0; trial < 60; ++trial) {
    const std::size_t i = render.channels * pixel(rng) + channel(rng);
    const double numeric =
        kWeight * central_difference(render.data[i], [&] {
          return image_loss(rgb_of(render, buffer), prepared, kLambda, kWeight, unused);
        });
    EXPECT_NEAR(v_render.data[i], numeric, 1e-4 * std::abs(numeric) + 1e-9) << "value " << i;
  }
}

TEST(Losses, FlowLossGradientMatchesCentralDifferencesAndSkipsUnknownPixels) {
  std::mt19937 rng(5);
  Image render = make_render(17, 13, rng);
  for (const int channel : {model::kForwardFlowChannel, model::kBackwardFlowChannel}) {
    // The target flow: render ± at least 2^-9 where known, every third pixel unknown.
    Flow target(render.width, render.height);
    std::uniform_int_distribution<int> offset(0, 8);
    std::bernoulli_distribution sign(0.5);
    for (std::size_t p = 0; p < render.pixels(); ++p) {
      target.valid[p] = p % 3 != 0;
      for (int k = 0; k < 2; ++k) {
        const float d = (float(offset(rng)) + 0.5f) / 256;
        target.uv[2 * p + k] =
            render.data[render.channels * p + channel + k] + (sign(rng) ? d : -d);
      }
    }
    constexpr double kWeight = 0.3;
    Image v_render(render.width, render.height, render.channels);
    flow_loss(render, channel, target, kWeight, v_render);
    Image unused(render.width, render.height, render.channels);
    for (std::size_t i = 0; i < render.data.size(); ++i) {
      const std::size_t p = i / render.channels;
      const int c = int(i % render.channels);
      if (c != channel && c != channel + 1) {
        ASSERT_EQ(v_render.data[i], 0.0f) << "channel " << c << " of pixel " << p;
        continue;
      }
      const double numeric = kWeight * central_difference(render.data[i], [&] {
                               return flow_loss(render, channel, target, kWeight, unused);
                             });
      if (!target.valid[p]) {
        ASSERT_EQ(numeric, 0.0) << p;
      }
      ASSERT_NEAR(v_render.data[i], numeric, 1e-6 * std::abs(numeric))
          << "channel " << channel << " value " << i;
    }
  }
}

TEST(Losses, FlowLossWithoutKnownPixelsIsZero) {
  Image render(4, 3, 3 + model::kFlowChannels, 0.5f);
  Flow target(4, 3);
  std::fill(target.valid.begin(), target.valid.end(), 0);
  Image v_render(4, 3, render.channels);
  EXPECT_EQ(flow_loss(render, model::kForwardFlowChannel, target, 1.0, v_render), 0.0);
  for (const float v : v_render.data) EXPECT_EQ(v, 0.0f);
}

model::Primitives regularised_primitives() {
  model::Primitives p;
  p.resize(6);
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> logit(-4, 4), log_scale(-5, 0.5f);
  for (float& v : p.opacity_logit) v = logit(rng);
  for (float& v : p.log_scale) v = log_scale(rng);
  return p;
}

TEST(Losses, RegularizerIsTheMeanOpacityAndScaleSummedOverTheRows) {
  model::Primitives p;
  p.resize(3);
  p.opacity_logit = {0.0f, 5.0f, std::log(3.0f)};  // σ = 1/2, -, 3/4
  p.log_scale = {0.0f, 0.0f,           0.0f,           1.0f,          1.0f,
                 1.0f, std::log(2.0f), std::log(2.0f), std::log(5.0f)};
  EXPECT_NEAR(regularizer(p, {0, 2}, 0.1, 0.01),
              0.1 * (0.5 + 0.75) / 3 + 0.01 * (3 + 2 + 2 + 5) / 9.0, 1e-7);
  EXPECT_EQ(regularizer(model::Primitives{}, {}, 0.1, 0.01), 0.0);
}

// Over many rows the sum runs on all threads, split the same way for any thread count.
TEST(Losses, RegularizerIsTheSameForAnyThreadCount) {
  model::Primitives p;
  p.resize(20000);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-3, 3);
  for (float& v : p.opacity_logit) v = u(rng);
  for (float& v : p.log_scale) v = u(rng);
  std::vector<std::int32_t> rows;
  for (std::int32_t r = 0; r < 20000; r += 2) rows.push_back(r);
  double serial = 0;
  for (const std::int32_t r : rows) {
    serial += 0.01 / 20000 / (1 + std::exp(-double(p.opacity_logit[r])));
    for (int a = 0; a < 3; ++a) serial += 0.1 / 60000 * std::exp(double(p.log_scale[3 * r + a]));
  }
  const int threads_before = max_threads();
  std::vector<double> values;
  for (const int threads : {1, 2, 3}) {
    set_threads(threads);
    values.push_back(regularizer(p, rows, 0.01, 0.1));
  }
  set_threads(threads_before);
  EXPECT_NEAR(values[0], serial, 1e-12 * serial);
  EXPECT_EQ(values[1], values[0]);
  EXPECT_EQ(values[2], values[0]);
}

// Rows 1 and 4 are not in the set: they get no gradient, and the loss does not depend on them.
TEST(Losses, RegularizerGradientMatchesCentralDifferences) {
  model::Primitives p = regularised_primitives();
  const std::vector<std::int32_t> rows = {0, 2, 3, 5};
  constexpr double kOpacity = 0.01, kScale = 0.1;
  model::PrimitiveGrads grads(p.size());
  regularizer_backward(p, rows, kOpacity, kScale, grads);
  // The gradient accumulates, and only opacity and scale have one.
  model::PrimitiveGrads twice = grads;
  regularizer_backward(p, rows, kOpacity, kScale, twice);
  for (std::size_t i = 0; i < p.size(); ++i)
    ASSERT_EQ(twice.v_opacity_logit[i], 2 * grads.v_opacity_logit[i]) << i;
  for (std::size_t i = 0; i < 3 * p.size(); ++i)
    ASSERT_EQ(twice.v_log_scale[i], 2 * grads.v_log_scale[i]) << i;
  for (const auto* other : {&grads.v_mu, &grads.v_velocity, &grads.v_q0, &grads.v_q1, &grads.v_sh,
                            &grads.v_mu_tau, &grads.v_temporal_log_scale})
    for (const float v : *other) ASSERT_EQ(v, 0.0f);
  const auto check = [&](std::vector<float>& values, const std::vector<float>& analytic,
                         const char* field) {
    for (std::size_t i = 0; i < values.size(); ++i) {
      const float value = values[i];
      const float above = value + 1.0f / 1024, below = value - 1.0f / 1024;
      values[i] = above;
      const double plus = regularizer(p, rows, kOpacity, kScale);
      values[i] = below;
      const double minus = regularizer(p, rows, kOpacity, kScale);
      values[i] = value;
      const double numeric = (plus - minus) / (double(above) - double(below));
      EXPECT_NEAR(analytic[i], numeric, 1e-5 * std::abs(numeric)) << field << " " << i;
    }
  };
  check(p.opacity_logit, grads.v_opacity_logit, "opacity_logit");
  check(p.log_scale, grads.v_log_scale, "log_scale");
  for (const std::size_t r : {1, 4}) {
    EXPECT_EQ(grads.v_opacity_logit[r], 0.0f) << r;
    for (int a = 0; a < 3; ++a) EXPECT_EQ(grads.v_log_scale[3 * r + a], 0.0f) << r;
  }
}

}  // namespace
}  // namespace retimegs::train
