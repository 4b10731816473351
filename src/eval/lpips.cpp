#include "retimegs/eval/lpips.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/ranges.h>
#include <Eigen/Core>

#include "retimegs/core/error.hpp"
#include "retimegs/io/npy.hpp"

namespace retimegs::eval {
namespace fs = std::filesystem;
namespace {

// LPIPS ScalingLayer, float32 constants in the official code: x = (2v − 1 − shift) / scale.
constexpr std::array<float, 3> kShift = {-0.030f, -0.088f, -0.188f};
constexpr std::array<float, 3> kScale = {0.458f, 0.448f, 0.450f};
constexpr double kNormEps = 1e-10;  // lpips.normalize_tensor: added to the norm, outside the sqrt
constexpr int kConv0Stride = 2;     // SqueezeNet 1.1 features.0: conv 3→64, k3, s2, no padding
constexpr int kPoolKernel = 3, kPoolStride = 2;  // its max pools (ceil_mode)
// Below this many values moved, waking the threads costs more than the copy loops.
constexpr std::size_t kParallelMin = std::size_t(1) << 16;

// The Fire modules of SqueezeNet 1.1 (torchvision), by state-dict index: input, squeeze and expand
// channels (expand1x1 and expand3x3 have the same count; the output has twice it).
struct FireSpec {
  int index, in, squeeze, expand;
};
constexpr std::array<FireSpec, 8> kFires = {{{3, 64, 16, 64},
                                             {4, 128, 16, 64},
                                             {6, 128, 32, 128},
                                             {7, 256, 32, 128},
                                             {9, 256, 48, 192},
                                             {10, 384, 48, 192},
                                             {11, 384, 64, 256},
                                             {12, 512, 64, 256}}};
constexpr std::array<int, Lpips::kTaps> kTapChannels = {64, 128, 256, 384, 384, 512, 512};

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

int conv_size(int length, int kernel, int stride, int pad) {
  return (length + 2 * pad - kernel) / stride + 1;
}

// PyTorch ceil_mode: ceil((L − k) / s) + 1, less one if the last window would start past the input.
int pool_size(int length) {
  int out = (length - kPoolKernel + kPoolStride - 1) / kPoolStride + 1;
  if ((out - 1) * kPoolStride >= length) --out;
  return out;
}

// Max over 3×3 windows with stride 2, clipped at the far borders (ceil_mode).
FeatureMap max_pool(const FeatureMap& x) {
  FeatureMap out{x.channels, pool_size(x.height), pool_size(x.width), {}};
  out.data.resize(std::size_t(out.channels) * out.height * out.width);
#pragma omp parallel for schedule(static) if (out.data.size() >= kParallelMin)
  for (int c = 0; c < x.channels; ++c) {
    const float* in = x.data.data() + std::size_t(c) * x.height * x.width;
    float* o = out.data.data() + std::size_t(c) * out.height * out.width;
    for (int y = 0; y < out.height; ++y)
      for (int xo = 0; xo < out.width; ++xo) {
        const int y0 = y * kPoolStride, x0 = xo * kPoolStride;
        const int y1 = std::min(y0 + kPoolKernel, x.height),
                  x1 = std::min(x0 + kPoolKernel, x.width);
        float m = in[std::size_t(y0) * x.width + x0];
        for (int yy = y0; yy < y1; ++yy)
          for (int xx = x0; xx < x1; ++xx) m = std::max(m, in[std::size_t(yy) * x.width + xx]);
        o[std::size_t(y) * out.width + xo] = m;
      }
  }
  return out;
}

// The LPIPS input [3, H, W] of an RGB image in [0, 1].
FeatureMap scaled_input(const Image& image) {
  FeatureMap x{3, image.height, image.width, {}};
  x.data.resize(3 * image.pixels());
  for (int c = 0; c < 3; ++c)
    for (std::size_t p = 0; p < image.pixels(); ++p)
      x.data[c * image.pixels() + p] =
          float((2.0 * image.data[p * 3 + c] - 1.0 - kShift[c]) / double(kScale[c]));
  return x;
}

// f / (‖f‖₂ + 1e-10), the norm over channels per pixel, in double.  // [C, H·W]
std::vector<double> unit_normalised(const FeatureMap& f) {
  const std::size_t hw = std::size_t(f.height) * f.width;
  std::vector<double> inv_norm(hw, 0.0);  // [H·W]
  for (int c = 0; c < f.channels; ++c)
    for (std::size_t p = 0; p < hw; ++p)
      inv_norm[p] += double(f.data[c * hw + p]) * f.data[c * hw + p];
  for (double& v : inv_norm) v = 1.0 / (std::sqrt(v) + kNormEps);
  std::vector<double> out(f.data.size());
  for (int c = 0; c < f.channels; ++c)
    for (std::size_t p = 0; p < hw; ++p) out[c * hw + p] = f.data[c * hw + p] * inv_norm[p];
  return out;
}

// mean over pixels of Σ_c lin_c · (f̂0 − f̂1)². The normalised maps are formed first (as the
// official code does), so identical images give exactly 0 whatever the compiler contracts.
double tap_distance(const FeatureMap& f0, const FeatureMap& f1, const std::vector<float>& lin) {
  const std::size_t hw = std::size_t(f0.height) * f0.width;
  const std::vector<double> n0 = unit_normalised(f0), n1 = unit_normalised(f1);
  std::vector<double> d(hw, 0.0);  // [H·W]
  for (int c = 0; c < f0.channels; ++c)
    for (std::size_t p = 0; p < hw; ++p) {
      const double diff = n0[c * hw + p] - n1[c * hw + p];
      d[p] += lin[c] * diff * diff;
    }
  double sum = 0;
  for (const double v : d) sum += v;
  return sum / double(hw);
}

void check_image(const Image& image, const char* which) {
  if (image.channels != 3)
    fail("lpips: the {} image has {} channels, RGB expected", which, image.channels);
  if (image.width < Lpips::kMinSide || image.height < Lpips::kMinSide)
    fail("lpips: the {} image is {}x{}, too small for the SqueezeNet trunk (each side >= {})",
         which, image.width, image.height, Lpips::kMinSide);
  const auto bad =
      std::find_if(image.data.begin(), image.data.end(), [](float v) { return !std::isfinite(v); });
  if (bad != image.data.end()) {
    const std::size_t pixel = (bad - image.data.begin()) / 3;
    fail("lpips: the {} image has a non-finite value ({}) at pixel ({}, {})", which, *bad,
         pixel % image.width, pixel / image.width);
  }
}

}  // namespace

void Lpips::conv_relu(const Conv& conv, const FeatureMap& x, int stride, int pad, float* out) {
  const int k = conv.kernel;
  const int height = conv_size(x.height, k, stride, pad),
            width = conv_size(x.width, k, stride, pad);
  const Eigen::Index pixels = Eigen::Index(height) * width;
  const Eigen::Index depth = Eigen::Index(conv.in) * k * k;
  std::vector<float> columns;  // [in·k·k, H'·W'] im2col; a 1×1 conv reads x directly
  const float* input = x.data.data();
  if (k != 1 || stride != 1 || pad != 0) {
    columns.resize(depth * pixels);
#pragma omp parallel for schedule(static) if (columns.size() >= kParallelMin)
    for (Eigen::Index row = 0; row < depth; ++row) {
      const int c = int(row / (k * k)), ky = int(row / k % k), kx = int(row % k);
      const float* plane = x.data.data() + std::size_t(c) * x.height * x.width;
      float* col = columns.data() + row * pixels;
      for (int y = 0; y < height; ++y) {
        const int sy = y * stride + ky - pad;
        for (int xo = 0; xo < width; ++xo) {
          const int sx = xo * stride + kx - pad;
          const bool in = sy >= 0 && sy < x.height && sx >= 0 && sx < x.width;
          col[std::size_t(y) * width + xo] = in ? plane[std::size_t(sy) * x.width + sx] : 0.0f;
        }
      }
    }
    input = columns.data();
  }
  const Eigen::Map<const RowMatrix> weight(conv.weight.data(), conv.out, depth);
  const Eigen::Map<const RowMatrix> cols(input, depth, pixels);
  const Eigen::Map<const Eigen::VectorXf> bias(conv.bias.data(), conv.out);
  Eigen::Map<RowMatrix> y(out, conv.out, pixels);
  y.colwise() = bias;
  y.noalias() += weight * cols;
  y = y.cwiseMax(0.0f);
}

FeatureMap Lpips::fire(const Fire& fire, const FeatureMap& x) {
  FeatureMap squeezed{fire.squeeze.out, x.height, x.width, {}};
  squeezed.data.resize(std::size_t(squeezed.channels) * x.height * x.width);
  conv_relu(fire.squeeze, x, 1, 0, squeezed.data.data());
  FeatureMap out{fire.expand1x1.out + fire.expand3x3.out, x.height, x.width, {}};
  out.data.resize(std::size_t(out.channels) * x.height * x.width);
  conv_relu(fire.expand1x1, squeezed, 1, 0, out.data.data());
  conv_relu(fire.expand3x3, squeezed, 1, 1,
            out.data.data() + std::size_t(fire.expand1x1.out) * x.height * x.width);
  return out;
}

Lpips Lpips::load(const fs::path& dir) {
  if (!fs::is_directory(dir)) fail("{}: LPIPS weights folder not found", dir.string());
  const auto tensor = [&dir](const std::string& key, std::vector<std::size_t> shape) {
    const fs::path file = dir / (key + ".npy");
    const io::NpyArray array = io::read_npy(file);  // names the file when missing or malformed
    if (array.shape != shape)
      fail("{}: shape [{}], expected [{}]", file.string(), fmt::join(array.shape, ", "),
           fmt::join(shape, ", "));
    return array.to_float();
  };
  const auto conv = [&tensor](const std::string& key, int out, int in, int k) {
    Conv c;
    c.out = out, c.in = in, c.kernel = k;
    const std::size_t o = out, i = in, kk = k;
    c.weight = tensor(key + ".weight", {o, i, kk, kk});
    c.bias = tensor(key + ".bias", {o});
    return c;
  };
  Lpips lpips;
  lpips.conv0_ = conv("features.0", kTapChannels[0], 3, 3);
  for (std::size_t i = 0; i < kFires.size(); ++i) {
    const FireSpec& f = kFires[i];
    const std::string key = fmt::format("features.{}.", f.index);
    lpips.fires_[i] = {conv(key + "squeeze", f.squeeze, f.in, 1),
                       conv(key + "expand1x1", f.expand, f.squeeze, 1),
                       conv(key + "expand3x3", f.expand, f.squeeze, 3)};
  }
  for (int t = 0; t < kTaps; ++t)
    lpips.lin_[t] =
        tensor(fmt::format("lin{}.model.1.weight", t), {1, std::size_t(kTapChannels[t]), 1, 1});
  return lpips;
}

std::array<FeatureMap, Lpips::kTaps> Lpips::features(const Image& image) const {
  check_image(image, "input");
  const FeatureMap x = scaled_input(image);
  std::array<FeatureMap, kTaps> taps;
  FeatureMap& t0 = taps[0];
  t0 = {conv0_.out,
        conv_size(x.height, 3, kConv0Stride, 0),
        conv_size(x.width, 3, kConv0Stride, 0),
        {}};
  t0.data.resize(std::size_t(t0.channels) * t0.height * t0.width);
  conv_relu(conv0_, x, kConv0Stride, 0, t0.data.data());
  taps[1] = fire(fires_[1], fire(fires_[0], max_pool(taps[0])));
  taps[2] = fire(fires_[3], fire(fires_[2], max_pool(taps[1])));
  taps[3] = fire(fires_[4], max_pool(taps[2]));
  for (int t = 4; t < kTaps; ++t) taps[t] = fire(fires_[t + 1], taps[t - 1]);
  return taps;
}

std::array<double, Lpips::kTaps> Lpips::tap_distances(const Image& a, const Image& b) const {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    fail("lpips: images differ in size ({}x{}x{} vs {}x{}x{})", a.width, a.height, a.channels,
         b.width, b.height, b.channels);
  check_image(a, "first");
  check_image(b, "second");
  const auto fa = features(a), fb = features(b);
  std::array<double, kTaps> d;
  for (int t = 0; t < kTaps; ++t) d[t] = tap_distance(fa[t], fb[t], lin_[t]);
  return d;
}

double Lpips::distance(const Image& a, const Image& b) const {
  double sum = 0;
  for (const double d : tap_distances(a, b)) sum += d;
  return sum;
}

}  // namespace retimegs::eval
