// The losses on the device (cuda/losses.hpp) against the CPU: the SSIM side against core's
// SsimTarget / ssim_backward_add (double), the rest against train::image_loss's, train::flow_loss's
// and model::apply_camera_color's loops over the same formulas (train/loss_formulas.hpp,
// model/camera_color.hpp). Image sizes are not multiples of the 16-pixel tiles; device outputs are
// poisoned (NaN) first, accumulated ones start from random values, and every value is checked.
#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/random_arrays.hpp"
#include "cuda/require_gpu.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/ssim.hpp"
#include "retimegs/cuda/losses.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/train/loss_formulas.hpp"

namespace retimegs::cuda {
namespace {

constexpr unsigned char kNaN = 0xff;  // every float and double of all-ones bytes is a NaN

struct Size {
  int width, height;
};
// Smaller than a tile and the window, and larger ones that end in partial tiles.
constexpr Size kSizes[] = {{13, 9}, {37, 23}, {70, 45}, {129, 67}};

// A training view as training holds it: random RGB, packed to 16 bits; `image` is its unpacked
// value (what the CPU loss compares with).
struct View {
  PackedImage packed;
  Image image;
};

View random_view(Size s, std::uint64_t seed) {
  Image rgb(s.width, s.height, 3);
  rgb.data = test::random_floats(rgb.data.size(), 0.0f, 1.0f, seed);
  View view{pack(rgb, "random view"), {}};
  unpack(view.packed, view.image);
  return view;
}

// A render of `channels` channels near the view (its RGB = the view + noise in [-0.2, 0.2)).
Image random_render(const Image& view, int channels, std::uint64_t seed) {
  Image render(view.width, view.height, channels);
  render.data = test::random_floats(render.data.size(), -0.5f, 1.5f, seed);
  const std::vector<float> noise = test::random_floats(view.data.size(), -0.2f, 0.2f, seed + 1);
  for (std::size_t p = 0; p < view.pixels(); ++p)
    for (int c = 0; c < 3; ++c)
      render.data[p * channels + c] = view.data[3 * p + c] + noise[3 * p + c];
  return render;
}

// train::image_loss on the host: the L1 part as its loop, the SSIM part core's own.
double host_image_loss(const Image& rgb, const SsimTarget& target, double lambda, double weight,
                       Image& v_render) {
  const std::size_t n = rgb.data.size();
  const float l1_grad = float((1 - lambda) * weight / double(n));
  double l1 = 0;
  for (std::size_t p = 0; p < rgb.pixels(); ++p)
    for (int c = 0; c < 3; ++c) {
      const float diff = rgb.data[3 * p + c] - target.image->data[3 * p + c];
      l1 += std::abs(diff);
      v_render.data[p * v_render.channels + c] += train::l1_gradient(diff, l1_grad);
    }
  const double s = ssim_backward_add(rgb, target, -lambda * weight, v_render);
  return train::mix_image_loss(l1 / double(n), s, lambda);
}

// A loss's device arrays: the render and the gradient's start uploaded, the loss poisoned.
struct LossCall {
  DeviceBuffer<float> render, v;
  DeviceBuffer<double> loss;
  LossScratch scratch;

  LossCall(const Image& render_in, const Image& v_start) : loss(1) {
    render.upload(render_in.data);
    v.upload(v_start.data);
    loss.fill_bytes(kNaN);
  }
};

// The device's result of image_loss for one case, from poisoned outputs.
struct DeviceImageLoss {
  double loss;
  Image v_render;
  std::vector<float> target_image, mu, e_sq;
};

DeviceImageLoss device_image_loss(const View& view, const Image& render, double lambda,
                                  double weight, const Image& v_start) {
  DevicePackedImage packed;
  packed.upload(view.packed);
  DeviceSsimTarget target;
  for (DeviceBuffer<float>* b : {&target.image, &target.mu, &target.e_sq}) {
    b->resize(view.image.data.size());  // assign() keeps these allocations
    b->fill_bytes(kNaN);
  }
  target.assign(packed);
  LossCall call(render, v_start);
  image_loss(call.render.data(), render.channels, target, lambda, weight, call.v.data(),
             v_start.channels, call.loss.data(), call.scratch);
  DeviceImageLoss out{call.loss.download()[0], v_start, target.image.download(),
                      target.mu.download(), target.e_sq.download()};
  call.v.download(out.v_render.data.data());
  return out;
}

// Gradient tolerance: of the largest value the CPU's gradient takes (float SSIM against double).
constexpr double kGradientTolerance = 1e-4;
constexpr double kLossTolerance = 1e-5;    // relative
constexpr double kMomentTolerance = 1e-5;  // absolute, moments of values in [0, 1]

TEST(ImageLossCuda, MatchesTheCpuOnEverySizeAndLayout) {
  RETIMEGS_REQUIRE_GPU();
  struct Layout {
    int render_channels, v_channels;
  };
  // An RGB render; a render with its 4 flow channels; the colour-mapped RGB with such a gradient.
  constexpr Layout kLayouts[] = {{3, 3}, {7, 7}, {3, 7}};
  const double lambda = 0.2, weight = 0.7;
  double worst_loss = 0, worst_gradient = 0;
  std::uint64_t seed = 100;
  for (const Size size : kSizes)
    for (const Layout layout : kLayouts) {
      SCOPED_TRACE(testing::Message()
                   << size.width << "x" << size.height << ", render " << layout.render_channels
                   << " channels, gradient " << layout.v_channels);
      const View view = random_view(size, seed++);
      const Image render = random_render(view.image, layout.render_channels, seed++);
      Image v_start(size.width, size.height, layout.v_channels);
      const double n = 3.0 * size.width * size.height;
      v_start.data = test::random_floats(v_start.data.size(), float(-1 / n), float(1 / n), seed++);

      SsimTarget cpu_target;
      cpu_target.assign(view.image);
      Image cpu_v = v_start;
      const double cpu_loss =
          host_image_loss(test::first_channels(render, 3), cpu_target, lambda, weight, cpu_v);
      const DeviceImageLoss gpu = device_image_loss(view, render, lambda, weight, v_start);

      ASSERT_EQ(gpu.target_image, view.image.data) << "the device's unpacking";
      for (std::size_t i = 0; i < gpu.mu.size(); ++i) {
        ASSERT_NEAR(gpu.mu[i], cpu_target.mu[i], kMomentTolerance) << "mu_b at " << i;
        ASSERT_NEAR(gpu.e_sq[i], cpu_target.e_sq[i], kMomentTolerance) << "E[b^2] at " << i;
      }
      const double loss_error = std::abs(gpu.loss - cpu_loss) / std::abs(cpu_loss);
      EXPECT_LE(loss_error, kLossTolerance) << gpu.loss << " vs " << cpu_loss;
      worst_loss = std::max(worst_loss, loss_error);

      double largest = 0;
      for (std::size_t i = 0; i < cpu_v.data.size(); ++i)
        largest = std::max(largest, std::abs(double(cpu_v.data[i]) - v_start.data[i]));
      ASSERT_GT(largest, 0);
      double gradient_error = 0;
      for (std::size_t i = 0; i < cpu_v.data.size(); ++i) {
        if (int(i % layout.v_channels) >= 3) {
          ASSERT_EQ(test::ulps(gpu.v_render.data[i], v_start.data[i]), 0)
              << "value " << i << " outside RGB changed";
          continue;
        }
        const double error = std::abs(double(gpu.v_render.data[i]) - cpu_v.data[i]) / largest;
        ASSERT_FALSE(std::isnan(error)) << "value " << i << " not written";
        gradient_error = std::max(gradient_error, error);
      }
      EXPECT_LE(gradient_error, kGradientTolerance);
      worst_gradient = std::max(worst_gradient, gradient_error);
    }
  std::printf("[ measured ] image loss: loss %.2e relative, gradient %.2e of its largest value\n",
              worst_loss, worst_gradient);
}

TEST(ImageLossCuda, L1AloneIsTheCpusBitForBit) {
  RETIMEGS_REQUIRE_GPU();
  const Size size{45, 31};
  const View view = random_view(size, 7);
  const Image render = random_render(view.image, 7, 8);
  Image v_start(size.width, size.height, 7);
  v_start.data = test::random_floats(v_start.data.size(), -1e-3f, 1e-3f, 9);
  SsimTarget cpu_target;
  cpu_target.assign(view.image);
  Image cpu_v = v_start;
  const double cpu_loss =
      host_image_loss(test::first_channels(render, 3), cpu_target, 0.0, 1.3, cpu_v);
  const DeviceImageLoss gpu = device_image_loss(view, render, 0.0, 1.3, v_start);
  EXPECT_NEAR(gpu.loss, cpu_loss, 1e-12 * cpu_loss);
  for (std::size_t i = 0; i < cpu_v.data.size(); ++i)
    ASSERT_EQ(test::ulps(gpu.v_render.data[i], cpu_v.data[i]), 0)
        << "value " << i << ": " << gpu.v_render.data[i] << " vs " << cpu_v.data[i];
}

TEST(ImageLossCuda, IsTheSameOnEveryRun) {
  RETIMEGS_REQUIRE_GPU();
  const Size size{70, 45};
  const View view = random_view(size, 17);
  const Image render = random_render(view.image, 7, 18);
  const Image v_start(size.width, size.height, 7, 0.0f);
  const DeviceImageLoss first = device_image_loss(view, render, 0.2, 1.0, v_start);
  const DeviceImageLoss second = device_image_loss(view, render, 0.2, 1.0, v_start);
  EXPECT_EQ(first.loss, second.loss);
  for (std::size_t i = 0; i < first.v_render.data.size(); ++i)
    ASSERT_EQ(test::ulps(first.v_render.data[i], second.v_render.data[i]), 0) << "value " << i;
}

// A flow with about `known` of its pixels known, motions of a few pixels.
Flow random_flow(Size s, double known, std::uint64_t seed) {
  Flow flow(s.width, s.height);
  flow.uv = test::random_floats(flow.uv.size(), -4.0f, 4.0f, seed);
  std::mt19937_64 rng(seed + 1);
  std::bernoulli_distribution is_known(known);
  for (unsigned char& v : flow.valid) v = is_known(rng) ? 1 : 0;
  return flow;
}

// train::flow_loss's loop on the host.
double host_flow_loss(const Image& render, int channel, const Flow& target, double weight,
                      Image& v_render) {
  std::size_t known = 0;
  for (const unsigned char v : target.valid) known += v;
  if (known == 0) return 0;
  const float grad = float(weight / double(known));
  double sum = 0;
  for (std::size_t p = 0; p < render.pixels(); ++p) {
    if (!target.valid[p]) continue;
    for (int k = 0; k < 2; ++k) {
      const std::size_t i = render.channels * p + channel + k;
      const float diff = render.data[i] - target.uv[2 * p + k];
      sum += std::abs(diff);
      v_render.data[i] += train::l1_gradient(diff, grad);
    }
  }
  return sum / double(known);
}

TEST(FlowLossCuda, MatchesTheCpuBitForBitInItsGradient) {
  RETIMEGS_REQUIRE_GPU();
  constexpr int kChannels = 7;  // RGB, forward flow at 3, backward flow at 5
  std::uint64_t seed = 300;
  for (const Size size : kSizes)
    for (const double known : {0.0, 0.7, 1.0})
      for (const int channel : {3, 5}) {
        SCOPED_TRACE(testing::Message() << size.width << "x" << size.height << ", known " << known
                                        << ", channel " << channel);
        Image render(size.width, size.height, kChannels);
        render.data = test::random_floats(render.data.size(), -5.0f, 5.0f, seed++);
        const Flow flow = random_flow(size, known, seed++);
        Image v_start(size.width, size.height, kChannels);
        v_start.data = test::random_floats(v_start.data.size(), -1e-3f, 1e-3f, seed++);
        Image cpu_v = v_start;
        const double cpu_loss = host_flow_loss(render, channel, flow, 0.5, cpu_v);

        DeviceFlow d_flow;
        d_flow.upload(flow);
        LossCall call(render, v_start);
        flow_loss(call.render.data(), kChannels, channel, d_flow, 0.5, call.v.data(),
                  call.loss.data(), call.scratch);
        const double gpu_loss = call.loss.download()[0];
        const std::vector<float> gpu_v = call.v.download();

        if (known == 0.0) {
          EXPECT_EQ(cpu_loss, 0.0);
        }
        EXPECT_NEAR(gpu_loss, cpu_loss, 1e-12 * std::abs(cpu_loss)) << gpu_loss;
        for (std::size_t i = 0; i < gpu_v.size(); ++i)
          ASSERT_EQ(test::ulps(gpu_v[i], cpu_v.data[i]), 0)
              << "value " << i << ": " << gpu_v[i] << " vs " << cpu_v.data[i];
      }
}

// The views' flows as FlowUploads brings them, in an order that returns to earlier views, with a
// flow loss launched on them before the next view's copies start: each view's flows equal the
// host's, and so does the loss read through them. The small flows share heap pages, whose locking
// is refused (the pageable path); the large ones, allocations of their own, are locked.
TEST(FlowUploadsCuda, BringEachViewsFlowsAsTheHostHoldsThem) {
  RETIMEGS_REQUIRE_GPU();
  constexpr int kChannels = 7;
  const Size sizes[] = {{13, 9}, {37, 23}, {640, 360}, {1024, 512}};
  std::vector<Flow> flows;  // forward then backward, per view
  std::uint64_t seed = 700;
  for (const Size size : sizes)
    for (int direction = 0; direction < 2; ++direction)
      flows.push_back(random_flow(size, 0.7, seed++));
  std::vector<const Flow*> pointers{nullptr};
  for (const Flow& flow : flows) pointers.push_back(&flow);
  FlowUploads uploads(pointers);
  EXPECT_GE(uploads.locked_bytes(), 2 * flows.back().uv.size() * sizeof(float));

  for (const int view : {2, 0, 3, 3, 1, 2}) {
    SCOPED_TRACE(testing::Message() << "view " << view);
    const Flow& forward = flows[2 * view];
    const Flow& backward = flows[2 * view + 1];
    uploads.start(&forward, &backward);
    const Size size = sizes[view];
    Image render(size.width, size.height, kChannels);
    render.data = test::random_floats(render.data.size(), -5.0f, 5.0f, seed++);
    Image cpu_v(size.width, size.height, kChannels);
    const double cpu_loss = host_flow_loss(render, 3, forward, 0.5, cpu_v);
    LossCall call(render, Image(size.width, size.height, kChannels));
    flow_loss(call.render.data(), kChannels, 3, uploads.forward(), 0.5, call.v.data(),
              call.loss.data(), call.scratch);
    uploads.start(&flows[2 * ((view + 1) % 4)], nullptr);  // waits for that loss's kernels
    EXPECT_NEAR(call.loss.download()[0], cpu_loss, 1e-12 * std::abs(cpu_loss));

    uploads.start(&forward, &backward);
    const DeviceFlow& f = uploads.forward();
    const DeviceFlow& b = uploads.backward();
    EXPECT_EQ(f.width, size.width);
    EXPECT_EQ(b.height, size.height);
    EXPECT_TRUE(f.uv.download() == forward.uv);
    EXPECT_TRUE(f.valid.download() == forward.valid);
    EXPECT_TRUE(b.uv.download() == backward.uv);
    EXPECT_TRUE(b.valid.download() == backward.valid);
  }
}

// A camera's colour parameters: m (log gains) then c (offsets), as the step stores them.
std::vector<float> random_color(std::uint64_t seed) {
  std::vector<float> color = test::random_floats(6, -0.3f, 0.3f, seed);
  for (int k = 3; k < 6; ++k) color[k] *= 0.3f;
  return color;
}

std::array<float, 3> host_gains(const std::vector<float>& color) {
  return {std::exp(color[0]), std::exp(color[1]), std::exp(color[2])};
}

// The device's exp(m) may round differently from the host's expf in rare cases (one ulp of the
// gain, about one ulp of a product), and one device may fuse gain · value + offset into one
// rounding: a scaled gradient within kColorUlps, a mapped value within kColorRoundings of its
// terms.
constexpr std::int64_t kColorUlps = 2;
constexpr double kColorRoundings = 4;

TEST(CameraColorCuda, ForwardMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  std::uint64_t seed = 500;
  for (const Size size : kSizes)
    for (const int channels : {3, 7}) {
      SCOPED_TRACE(testing::Message() << size.width << "x" << size.height << "x" << channels);
      Image rgb(size.width, size.height, channels);
      rgb.data = test::random_floats(rgb.data.size(), -0.1f, 1.1f, seed++);
      const std::vector<float> color = random_color(seed++);
      const std::array<float, 3> gain = host_gains(color);

      DeviceBuffer<float> d_rgb, d_color, d_out(3 * rgb.pixels());
      d_rgb.upload(rgb.data);
      d_color.upload(color);
      d_out.fill_bytes(kNaN);
      apply_camera_color(d_rgb.data(), channels, size.width, size.height, d_color.data(),
                         d_out.data());
      const std::vector<float> out = d_out.download();
      for (std::size_t p = 0; p < rgb.pixels(); ++p)
        for (int k = 0; k < 3; ++k) {
          const float value = rgb.data[p * channels + k];
          const float cpu = model::camera_color_value(gain[k], value, color[3 + k]);
          const double tolerance =
              kColorRoundings * FLT_EPSILON * (std::abs(gain[k] * value) + std::abs(color[3 + k]));
          ASSERT_NEAR(out[3 * p + k], cpu, tolerance) << "pixel " << p << " channel " << k;
        }
    }
}

TEST(CameraColorCuda, BackwardMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  std::uint64_t seed = 700;
  for (const Size size : kSizes)
    for (const int v_channels : {3, 7}) {
      SCOPED_TRACE(testing::Message() << size.width << "x" << size.height << ", gradient of "
                                      << v_channels << " channels");
      Image rgb(size.width, size.height, 3);
      rgb.data = test::random_floats(rgb.data.size(), 0.0f, 1.0f, seed++);
      const std::vector<float> color = random_color(seed++);
      Image v_start(size.width, size.height, v_channels);
      v_start.data = test::random_floats(v_start.data.size(), -1e-3f, 1e-3f, seed++);
      const std::vector<float> v_color_start = test::random_floats(6, -1.0f, 1.0f, seed++);

      // model::apply_camera_color_backward's loop, summed in double; `scale` bounds each sum's
      // rounding.
      const std::array<float, 3> gain = host_gains(color);
      Image cpu_v = v_start;
      double sums[6] = {}, scale[6] = {};
      for (std::size_t p = 0; p < rgb.pixels(); ++p)
        for (int k = 0; k < 3; ++k) {
          float& v = cpu_v.data[p * v_channels + k];
          sums[k] += double(v) * gain[k] * rgb.data[3 * p + k];
          sums[3 + k] += v;
          scale[k] += std::abs(double(v) * gain[k] * rgb.data[3 * p + k]);
          scale[3 + k] += std::abs(v);
          v *= gain[k];
        }

      DeviceBuffer<float> d_rgb, d_color, d_v, d_v_color;
      d_rgb.upload(rgb.data);
      d_color.upload(color);
      d_v.upload(v_start.data);
      d_v_color.upload(v_color_start);
      LossScratch scratch;
      apply_camera_color_backward(d_rgb.data(), 3, size.width, size.height, d_color.data(),
                                  d_v.data(), v_channels, d_v_color.data(), scratch);
      const std::vector<float> v = d_v.download();
      const std::vector<float> v_color = d_v_color.download();
      for (std::size_t i = 0; i < v.size(); ++i) {
        const bool rgb_value = int(i % v_channels) < 3;
        ASSERT_LE(test::ulps(v[i], cpu_v.data[i]), rgb_value ? kColorUlps : std::int64_t{0})
            << "value " << i << ": " << v[i] << " vs " << cpu_v.data[i];
      }
      for (int k = 0; k < 6; ++k) {
        const float cpu = v_color_start[k] + float(sums[k]);
        const double tolerance =
            kColorRoundings * FLT_EPSILON * (std::abs(v_color_start[k]) + scale[k]);
        EXPECT_NEAR(v_color[k], cpu, tolerance) << "d (m, c)[" << k << "]";
      }
    }
}

// The camera pose correction's sums (model::add_pose_moment over the Gaussians) against the CPU's
// loop in double, added onto what the buffer held; sizes around the block size.
TEST(CameraPoseSumsCuda, MatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  std::uint64_t seed = 900;
  for (const std::size_t n : {std::size_t(1), std::size_t(255), std::size_t(4097)}) {
    SCOPED_TRACE(testing::Message() << n << " Gaussians");
    Gaussians g(n, 3);
    g.means = test::random_floats(3 * n, -3.0f, 3.0f, seed++);
    g.quats = test::random_floats(4 * n, -1.0f, 1.0f, seed++);
    const std::vector<float> v_means = test::random_floats(3 * n, -1e-2f, 1e-2f, seed++);
    const std::vector<float> v_quats = test::random_floats(4 * n, -1e-2f, 1e-2f, seed++);
    const std::vector<double> start = {0.5, -0.25, 1.0, 0.0, 2.0, -1.0};
    double cpu[6], scale[6] = {};
    std::copy(start.begin(), start.end(), cpu);
    for (std::size_t i = 0; i < n; ++i) {
      double moment[3] = {}, force[3] = {};
      model::add_pose_moment(&g.means[3 * i], &g.quats[4 * i], &v_means[3 * i], &v_quats[4 * i],
                             moment, force);
      for (int k = 0; k < 3; ++k) {
        cpu[k] += moment[k], cpu[3 + k] += force[k];
        scale[k] += std::abs(moment[k]), scale[3 + k] += std::abs(force[k]);
      }
    }
    DeviceGaussians d_g;
    d_g.upload(g);
    DeviceGaussianGrads d_v;
    d_v.v_means.upload(v_means);
    d_v.v_quats.upload(v_quats);
    d_v.v_opacities.resize(n);
    DeviceBuffer<double> sums;
    sums.upload(start);
    LossScratch scratch;
    camera_pose_sums(d_g, d_v, sums.data(), scratch);
    const std::vector<double> out = sums.download();
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(out[k], cpu[k], 1e-12 * (scale[k] + 1)) << "sum " << k;
  }
}

}  // namespace
}  // namespace retimegs::cuda
