// The image loss (L1 + SSIM), the flow loss and the per-camera colour map on the device
// (include/retimegs/cuda/losses.hpp). SSIM is separable: every 16×16 block of pixels stages its
// tile and a 5-pixel halo in shared memory, filters along x, then along y, as core/ssim.cpp's two
// passes do; the backward filters the three derivative maps dS/d(μ_a, E[a²], E[ab]) the same way
// (the window is symmetric, so the transpose is the same filter), as gsplat's fused-ssim does.
#include <cuda_runtime.h>

#include "reduce.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/ssim_formulas.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/losses.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/train/loss_formulas.hpp"

namespace retimegs::cuda {
namespace {

constexpr int kTile = 16;                       // pixels per side of a block
constexpr int kSpan = kTile + 2 * kSsimRadius;  // the tile with its halo
constexpr int kPixelThreads = 256;              // threads of the per-pixel 1-D kernels
constexpr int kRgb = 3;                         // the channels SSIM and L1 compare
constexpr int kImageSums = 2;                   // image loss: Σ|diff|, Σ SSIM
constexpr int kFlowSums = 2;                    // flow loss: known pixels, Σ|diff|
constexpr int kColorSums = 6;                   // colour backward: d m (3), d c (3)
constexpr int kOneSum = 1;                      // squared error, regulariser

// The SSIM window in float, passed to the kernels by value.
struct Window {
  float w[kSsimTaps];
};

Window float_window() {
  const SsimWindow w = ssim_window();
  Window out;
  for (int k = 0; k < kSsimTaps; ++k) out.w[k] = float(w[k]);
  return out;
}

// Blocks of kTile × kTile pixels over the image, one z layer per RGB channel.
dim3 tile_grid(int width, int height) {
  return dim3((width + kTile - 1) / kTile, (height + kTile - 1) / kTile, kRgb);
}

int pixel_blocks(std::size_t pixels) {
  return int((pixels + kPixelThreads - 1) / kPixelThreads);
}

__device__ int block_index() {
  return blockIdx.x + gridDim.x * (blockIdx.y + gridDim.y * blockIdx.z);
}

// Stages one channel of an [H, W, stride] image over the block's tile and halo: span[y][x] is the
// value at (tile origin − r + (y, x)), 0 outside the image (the zero padding).
template <typename Load>
__device__ void stage(float (&span)[kSpan][kSpan], int width, int height, Load load) {
  const int x0 = blockIdx.x * kTile - kSsimRadius, y0 = blockIdx.y * kTile - kSsimRadius;
  for (int i = threadIdx.y * kTile + threadIdx.x; i < kSpan * kSpan; i += kTile * kTile) {
    const int y = y0 + i / kSpan, x = x0 + i % kSpan;
    span[i / kSpan][i % kSpan] =
        (x >= 0 && x < width && y >= 0 && y < height) ? load(std::size_t(y) * width + x) : 0.0f;
  }
}

// Along x: rows[m][y][x] = Σ_k w[k]·value_m(y, x + k) over the span's kSpan rows and the tile's
// kTile columns, for the M values that value(y, x, out) gives at a span position.
template <int M, typename Value>
__device__ void filter_x(const Window& w, float (&rows)[M][kSpan][kTile], Value value) {
  for (int i = threadIdx.y * kTile + threadIdx.x; i < kSpan * kTile; i += kTile * kTile) {
    const int y = i / kTile, x = i % kTile;
    float sums[M] = {};
    for (int k = 0; k < kSsimTaps; ++k) {
      float v[M];
      value(y, x + k, v);
      for (int m = 0; m < M; ++m) sums[m] += w.w[k] * v[m];
    }
    for (int m = 0; m < M; ++m) rows[m][y][x] = sums[m];
  }
}

// Along y at the thread's pixel: out[m] = Σ_k w[k]·rows[m][ty + k][tx].
template <int M>
__device__ void filter_y(const Window& w, const float (&rows)[M][kSpan][kTile], float (&out)[M]) {
  for (int m = 0; m < M; ++m) {
    float sum = 0;
    for (int k = 0; k < kSsimTaps; ++k) sum += w.w[k] * rows[m][threadIdx.y + k][threadIdx.x];
    out[m] = sum;
  }
}

// A colour passed to a kernel by value.
struct Rgb {
  float v[kRgb];
};

// The target: unpacked (unpack_code) into image, the pixels `foreground` (when given) marks 0 set
// to `background`, and its window moments μ_b, E[b²].
__global__ void __launch_bounds__(kTile* kTile)
    ssim_target_kernel(const std::uint16_t* packed, const std::uint8_t* foreground, Rgb background,
                       int width, int height, Window w, float* image, float* mu, float* e_sq) {
  __shared__ float b[kSpan][kSpan];
  __shared__ float rows[2][kSpan][kTile];
  const int ch = blockIdx.z;
  stage(b, width, height, [&](std::size_t p) {
    return foreground && !foreground[p] ? background.v[ch] : unpack_code(packed[p * kRgb + ch]);
  });
  __syncthreads();
  filter_x<2>(w, rows, [&](int y, int x, float(&v)[2]) {
    v[0] = b[y][x];
    v[1] = b[y][x] * b[y][x];
  });
  __syncthreads();
  const int x = blockIdx.x * kTile + threadIdx.x, y = blockIdx.y * kTile + threadIdx.y;
  if (x >= width || y >= height) return;
  float moments[2];
  filter_y<2>(w, rows, moments);
  const std::size_t i = (std::size_t(y) * width + x) * kRgb + ch;
  image[i] = b[threadIdx.y + kSsimRadius][threadIdx.x + kSsimRadius];
  mu[i] = moments[0];
  e_sq[i] = moments[1];
}

// What the image loss's kernels share, passed by value.
struct ImageLossParams {
  int width, height;
  int rgb_channels, v_channels;  // strides of rgb and v_render
  Window w;
  float ssim_scale;  // v_ssim / (H·W·3): d mean / d S(p) times the upstream −λ·weight
  float l1_grad;     // (1 − λ)·weight / (H·W·3)
};

// The forward at each pixel and channel: the render's moments against the target's, the SSIM
// map's derivative maps (times ssim_scale) into `coefficients` [3, H, W, 3], the L1 gradient added
// into v_render, and the block's Σ|diff| and Σ SSIM into partials [2, blocks].
__global__ void __launch_bounds__(kTile* kTile)
    image_loss_forward_kernel(ImageLossParams params, const float* rgb, const float* target,
                              const float* mu_b, const float* e_bb, float* v_render,
                              float* coefficients, double* partials) {
  __shared__ float a[kSpan][kSpan], b[kSpan][kSpan];
  __shared__ float rows[3][kSpan][kTile];
  const int width = params.width, height = params.height, ch = blockIdx.z;
  stage(a, width, height, [&](std::size_t p) { return rgb[p * params.rgb_channels + ch]; });
  stage(b, width, height, [&](std::size_t p) { return target[p * kRgb + ch]; });
  __syncthreads();
  filter_x<3>(params.w, rows, [&](int y, int x, float(&v)[3]) {
    v[0] = a[y][x];
    v[1] = a[y][x] * a[y][x];
    v[2] = a[y][x] * b[y][x];
  });
  __syncthreads();
  const int x = blockIdx.x * kTile + threadIdx.x, y = blockIdx.y * kTile + threadIdx.y;
  double sums[kImageSums] = {};
  if (x < width && y < height) {
    float moments[3];
    filter_y<3>(params.w, rows, moments);
    const std::size_t p = std::size_t(y) * width + x, i = p * kRgb + ch;
    const LocalSsimT<float> l =
        local_ssim<float>(moments[0], mu_b[i], moments[1], e_bb[i], moments[2]);
    const std::size_t plane = std::size_t(width) * height * kRgb;
    coefficients[i] = params.ssim_scale * l.d_mu_a;
    coefficients[plane + i] = params.ssim_scale * l.d_e_aa;
    coefficients[2 * plane + i] = params.ssim_scale * l.d_e_ab;
    const float diff = a[threadIdx.y + kSsimRadius][threadIdx.x + kSsimRadius] -
                       b[threadIdx.y + kSsimRadius][threadIdx.x + kSsimRadius];
    v_render[p * params.v_channels + ch] += train::l1_gradient(diff, params.l1_grad);
    sums[0] = fabsf(diff);
    sums[1] = l.s;
  }
  block_sums<kTile, kTile>(sums, partials, gridDim.x * gridDim.y * gridDim.z, block_index());
}

// The SSIM backward at each pixel and channel: the derivative maps filtered with the window (every
// window that holds the pixel), through a, a², ab (ssim_pixel_gradient), added into v_render.
__global__ void __launch_bounds__(kTile* kTile)
    image_loss_backward_kernel(ImageLossParams params, const float* rgb, const float* target,
                               const float* coefficients, float* v_render) {
  __shared__ float c[3][kSpan][kSpan];
  __shared__ float rows[3][kSpan][kTile];
  const int width = params.width, height = params.height, ch = blockIdx.z;
  const std::size_t plane = std::size_t(width) * height * kRgb;
  for (int m = 0; m < 3; ++m)
    stage(c[m], width, height,
          [&](std::size_t p) { return coefficients[m * plane + p * kRgb + ch]; });
  __syncthreads();
  filter_x<3>(params.w, rows, [&](int y, int x, float(&v)[3]) {
    for (int m = 0; m < 3; ++m) v[m] = c[m][y][x];
  });
  __syncthreads();
  const int x = blockIdx.x * kTile + threadIdx.x, y = blockIdx.y * kTile + threadIdx.y;
  if (x >= width || y >= height) return;
  float g[3];
  filter_y<3>(params.w, rows, g);
  const std::size_t p = std::size_t(y) * width + x;
  v_render[p * params.v_channels + ch] += ssim_pixel_gradient<float>(
      g[0], g[1], g[2], rgb[p * params.rgb_channels + ch], target[p * kRgb + ch]);
}

// The image loss from the sums of Σ|diff| and Σ SSIM over `count` values.
struct FinishImageLoss {
  double count, ssim_lambda;
  double* loss;
  __device__ void operator()(const double (&totals)[kImageSums]) const {
    *loss = train::mix_image_loss(totals[0] / count, totals[1] / count, ssim_lambda);
  }
};

// The flow loss's sums over the known pixels: how many, and Σ|diff| of the two channels.
__global__ void __launch_bounds__(kPixelThreads)
    flow_sums_kernel(const float* render, int channels, int channel, const float* uv,
                     const std::uint8_t* valid, std::size_t pixels, double* partials) {
  const std::size_t p = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  double sums[kFlowSums] = {};
  if (p < pixels && valid[p]) {
    sums[0] = 1;
    for (int k = 0; k < 2; ++k)
      sums[1] += fabsf(render[p * channels + channel + k] - uv[2 * p + k]);
  }
  block_sums<kPixelThreads, 1>(sums, partials, gridDim.x, blockIdx.x);
}

// The flow loss and its per-value gradient weight / known (0 when no pixel is known).
struct FinishFlowLoss {
  double weight;
  double* loss;
  float* gradient;
  __device__ void operator()(const double (&totals)[kFlowSums]) const {
    const double known = totals[0];
    *loss = known > 0 ? totals[1] / known : 0.0;
    *gradient = known > 0 ? float(weight / known) : 0.0f;
  }
};

__global__ void __launch_bounds__(kPixelThreads)
    flow_gradient_kernel(const float* render, int channels, int channel, const float* uv,
                         const std::uint8_t* valid, std::size_t pixels, const float* gradient,
                         float* v_render) {
  const std::size_t p = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  if (p >= pixels || !valid[p]) return;
  const float grad = *gradient;
  for (int k = 0; k < 2; ++k) {
    const std::size_t i = p * channels + channel + k;
    v_render[i] += train::l1_gradient(render[i] - uv[2 * p + k], grad);
  }
}

// exp(m) of a camera's colour, rounded to float from double as glibc's expf computes it (within
// 0.51 ulp): the host's std::exp in all but rare ties, where the device's expf may differ by 2
// ulps.
__device__ float gain_of(float m) {
  return float(exp(double(m)));
}

__global__ void __launch_bounds__(kPixelThreads)
    camera_color_kernel(const float* rgb, int rgb_channels, std::size_t pixels, const float* color,
                        float* out) {
  const std::size_t p = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  if (p >= pixels) return;
  for (int k = 0; k < kRgb; ++k)
    out[p * kRgb + k] =
        model::camera_color_value(gain_of(color[k]), rgb[p * rgb_channels + k], color[kRgb + k]);
}

// d loss / d (m, c) per block into partials [6, blocks]; v_render's RGB scaled by the gains.
__global__ void __launch_bounds__(kPixelThreads)
    camera_color_backward_kernel(const float* rgb, int rgb_channels, std::size_t pixels,
                                 const float* color, float* v_render, int v_channels,
                                 double* partials) {
  const std::size_t p = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  double sums[kColorSums] = {};
  if (p < pixels) {
    for (int k = 0; k < kRgb; ++k) {
      const float gain = gain_of(color[k]);
      float& v = v_render[p * v_channels + k];
      sums[k] = double(v) * gain * rgb[p * rgb_channels + k];  // d out / d m = exp(m) rgb
      sums[kRgb + k] = v;                                      // d out / d c = 1
      v *= gain;
    }
  }
  block_sums<kPixelThreads, 1>(sums, partials, gridDim.x, blockIdx.x);
}

struct FinishCameraColor {
  float* v_color;
  __device__ void operator()(const double (&totals)[kColorSums]) const {
    for (int k = 0; k < kColorSums; ++k) v_color[k] += float(totals[k]);
  }
};

// Σ (rgb − target)² over each pixel's RGB, per block.
__global__ void __launch_bounds__(kPixelThreads)
    squared_error_kernel(const float* rgb, int rgb_channels, const float* target,
                         std::size_t pixels, double* partials) {
  const std::size_t p = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  double sums[kOneSum] = {};
  if (p < pixels)
    for (int k = 0; k < kRgb; ++k) {
      const double d = double(rgb[p * rgb_channels + k]) - double(target[p * kRgb + k]);
      sums[0] += d * d;
    }
  block_sums<kPixelThreads, 1>(sums, partials, gridDim.x, blockIdx.x);
}

// The regulariser's terms of the rows, per block.
__global__ void __launch_bounds__(kPixelThreads)
    regularizer_kernel(const std::int32_t* rows, std::size_t count, std::size_t n,
                       double opacity_weight, double scale_weight, const float* opacity_logit,
                       const float* log_scale, double* partials) {
  const std::size_t j = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  double sums[kOneSum] = {};
  if (j < count) {
    const std::size_t r = std::size_t(rows[j]);
    sums[0] = train::regularizer_add(0.0, opacity_weight, scale_weight, n, opacity_logit[r],
                                     log_scale + 3 * r);
  }
  block_sums<kPixelThreads, 1>(sums, partials, gridDim.x, blockIdx.x);
}

__global__ void __launch_bounds__(kPixelThreads)
    regularizer_backward_kernel(const std::int32_t* rows, std::size_t count, std::size_t n,
                                double opacity_weight, double scale_weight,
                                const float* opacity_logit, const float* log_scale,
                                float* v_opacity_logit, float* v_log_scale) {
  const std::size_t j = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  if (j >= count) return;
  const std::size_t r = std::size_t(rows[j]);
  train::regularizer_row_backward(opacity_weight, scale_weight, n, opacity_logit[r],
                                  log_scale + 3 * r, v_opacity_logit[r], v_log_scale + 3 * r);
}

__global__ void __launch_bounds__(kPixelThreads)
    camera_pose_kernel(std::size_t n, const float* means, const float* quats, const float* v_means,
                       const float* v_quats, double* partials) {
  const std::size_t i = std::size_t(blockIdx.x) * kPixelThreads + threadIdx.x;
  double sums[6] = {};
  if (i < n) {
    double moment[3] = {0, 0, 0}, force[3] = {0, 0, 0};
    model::add_pose_moment(means + 3 * i, quats + 4 * i, v_means + 3 * i, v_quats + 4 * i, moment,
                           force);
    for (int k = 0; k < 3; ++k) sums[k] = moment[k], sums[3 + k] = force[k];
  }
  block_sums<kPixelThreads, 1>(sums, partials, gridDim.x, blockIdx.x);
}

// Adds the six totals to out[0, 6).
struct AddPoseSums {
  double* out;
  __device__ void operator()(const double (&totals)[6]) const {
    for (int k = 0; k < 6; ++k) out[k] += totals[k];
  }
};

// Writes the one total to *out.
struct FinishSum {
  double* out;
  __device__ void operator()(const double (&totals)[kOneSum]) const { *out = totals[0]; }
};

template <int K, typename Finish>
void finish(const double* partials, int blocks, Finish f, const char* what) {
  finish_sums<K><<<1, kFinishThreads>>>(partials, blocks, f);
  check(cudaGetLastError(), what);
}

}  // namespace

void DevicePackedImage::upload(const PackedImage& image) {
  width = image.width, height = image.height, channels = image.channels;
  data.upload(image.data);
}

void DeviceFlow::upload(const Flow& flow) {
  width = flow.width, height = flow.height;
  uv.upload(flow.uv);
  valid.upload(flow.valid);
}

FlowUploads::FlowUploads(const std::vector<const Flow*>& flows) {
  check(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "flow upload stream");
  check(cudaEventCreateWithFlags(&copied_, cudaEventDisableTiming), "flow upload event");
  check(cudaEventCreateWithFlags(&read_, cudaEventDisableTiming), "flow upload event");
  for (const Flow* flow : flows) {
    if (!flow) continue;
    lock(flow->uv.data(), flow->uv.size() * sizeof(float));
    lock(flow->valid.data(), flow->valid.size());
  }
}

FlowUploads::~FlowUploads() {
  // Errors here mean a lost context, which the next call reports; a destructor cannot throw.
  cudaStreamSynchronize(stream_);
  for (void* host : locked_) cudaHostUnregister(host);
  cudaEventDestroy(copied_);
  cudaEventDestroy(read_);
  cudaStreamDestroy(stream_);
}

void FlowUploads::lock(const void* host, std::size_t bytes) {
  if (bytes == 0) return;
  void* p = const_cast<void*>(host);  // registering does not write; the copies only read
  if (cudaHostRegister(p, bytes, cudaHostRegisterDefault) == cudaSuccess) {
    locked_.push_back(p);
    locked_bytes_ += bytes;
  } else {
    cudaGetLastError();  // not sticky: this flow is copied from pageable memory
  }
}

void FlowUploads::copy(const Flow& flow, DeviceFlow& out) {
  out.width = flow.width, out.height = flow.height;
  out.uv.resize(flow.uv.size());
  out.valid.resize(flow.valid.size());
  check(cudaMemcpyAsync(out.uv.data(), flow.uv.data(), flow.uv.size() * sizeof(float),
                        cudaMemcpyHostToDevice, stream_),
        "flow upload");
  check(cudaMemcpyAsync(out.valid.data(), flow.valid.data(), flow.valid.size(),
                        cudaMemcpyHostToDevice, stream_),
        "flow upload");
}

void FlowUploads::start(const Flow* forward, const Flow* backward) {
  check(cudaEventRecord(read_, 0), "flow upload: the last flows' readers");
  check(cudaStreamWaitEvent(stream_, read_, 0), "flow upload: the last flows' readers");
  if (forward) copy(*forward, forward_);
  if (backward) copy(*backward, backward_);
  check(cudaEventRecord(copied_, stream_), "flow upload");
}

const DeviceFlow& FlowUploads::ready(const DeviceFlow& flow) {
  check(cudaStreamWaitEvent(0, copied_, 0), "flow upload: waiting for the copies");
  return flow;
}

const DeviceFlow& FlowUploads::forward() {
  return ready(forward_);
}

const DeviceFlow& FlowUploads::backward() {
  return ready(backward_);
}

void DeviceSsimTarget::assign(const DevicePackedImage& packed, const std::uint8_t* foreground,
                              const std::array<float, 3>& background) {
  if (packed.channels != kRgb || packed.width <= 0 || packed.height <= 0 ||
      packed.data.size() != std::size_t(packed.width) * packed.height * kRgb)
    fail("SSIM target on the device: the view is {}x{}x{} ({} values), an RGB image is needed",
         packed.width, packed.height, packed.channels, packed.data.size());
  width = packed.width, height = packed.height;
  const std::size_t n = std::size_t(width) * height * kRgb;
  image.resize(n);
  mu.resize(n);
  e_sq.resize(n);
  const Rgb colour{{background[0], background[1], background[2]}};
  ssim_target_kernel<<<tile_grid(width, height), dim3(kTile, kTile)>>>(
      packed.data.data(), foreground, colour, width, height, float_window(), image.data(),
      mu.data(), e_sq.data());
  check(cudaGetLastError(), "ssim_target_kernel launch");
}

void image_loss(const float* rgb, int rgb_channels, const DeviceSsimTarget& target,
                double ssim_lambda, double weight, float* v_render, int v_channels, double* loss,
                LossScratch& scratch) {
  const std::size_t n = std::size_t(target.width) * target.height * kRgb;
  if (target.image.size() != n || n == 0)
    fail("image loss on the device: the target was not prepared (DeviceSsimTarget::assign)");
  if (rgb_channels < kRgb || v_channels < kRgb)
    fail("image loss on the device: render of {} channels, gradient of {}: both need RGB",
         rgb_channels, v_channels);
  const ImageLossParams params{target.width,
                               target.height,
                               rgb_channels,
                               v_channels,
                               float_window(),
                               float(-ssim_lambda * weight / double(n)),
                               float((1 - ssim_lambda) * weight / double(n))};
  const dim3 grid = tile_grid(target.width, target.height);
  const int blocks = int(grid.x * grid.y * grid.z);
  scratch.coefficients.resize(3 * n);
  scratch.partials.resize(std::size_t(kImageSums) * blocks);
  image_loss_forward_kernel<<<grid, dim3(kTile, kTile)>>>(
      params, rgb, target.image.data(), target.mu.data(), target.e_sq.data(), v_render,
      scratch.coefficients.data(), scratch.partials.data());
  check(cudaGetLastError(), "image_loss_forward_kernel launch");
  finish<kImageSums>(scratch.partials.data(), blocks, FinishImageLoss{double(n), ssim_lambda, loss},
                     "image loss finish_sums launch");
  image_loss_backward_kernel<<<grid, dim3(kTile, kTile)>>>(params, rgb, target.image.data(),
                                                           scratch.coefficients.data(), v_render);
  check(cudaGetLastError(), "image_loss_backward_kernel launch");
}

void flow_loss(const float* render, int channels, int channel, const DeviceFlow& target,
               double weight, float* v_render, double* loss, LossScratch& scratch) {
  const std::size_t pixels = std::size_t(target.width) * target.height;
  if (channel < 0 || channel + 2 > channels || target.valid.size() != pixels ||
      target.uv.size() != 2 * pixels)
    fail("flow loss on the device: render of {} channels at channel {} vs flow {}x{}", channels,
         channel, target.width, target.height);
  if (pixels == 0) fail("flow loss on the device: the flow is empty");
  const int blocks = pixel_blocks(pixels);
  scratch.partials.resize(std::size_t(kFlowSums) * blocks);
  scratch.flow_gradient.resize(1);
  flow_sums_kernel<<<blocks, kPixelThreads>>>(render, channels, channel, target.uv.data(),
                                              target.valid.data(), pixels, scratch.partials.data());
  check(cudaGetLastError(), "flow_sums_kernel launch");
  finish<kFlowSums>(scratch.partials.data(), blocks,
                    FinishFlowLoss{weight, loss, scratch.flow_gradient.data()},
                    "flow loss finish_sums launch");
  flow_gradient_kernel<<<blocks, kPixelThreads>>>(render, channels, channel, target.uv.data(),
                                                  target.valid.data(), pixels,
                                                  scratch.flow_gradient.data(), v_render);
  check(cudaGetLastError(), "flow_gradient_kernel launch");
}

void apply_camera_color(const float* rgb, int rgb_channels, int width, int height,
                        const float* color, float* out) {
  if (rgb_channels < kRgb) fail("camera colour on the device: {} channels, need RGB", rgb_channels);
  const std::size_t pixels = std::size_t(width) * height;
  if (pixels == 0) return;
  camera_color_kernel<<<pixel_blocks(pixels), kPixelThreads>>>(rgb, rgb_channels, pixels, color,
                                                               out);
  check(cudaGetLastError(), "camera_color_kernel launch");
}

void apply_camera_color_backward(const float* rgb, int rgb_channels, int width, int height,
                                 const float* color, float* v_render, int v_channels,
                                 float* v_color, LossScratch& scratch) {
  if (rgb_channels < kRgb || v_channels < kRgb)
    fail(
        "camera colour backward on the device: image of {} channels, gradient of {}: both need "
        "RGB",
        rgb_channels, v_channels);
  const std::size_t pixels = std::size_t(width) * height;
  if (pixels == 0) return;
  const int blocks = pixel_blocks(pixels);
  scratch.partials.resize(std::size_t(kColorSums) * blocks);
  camera_color_backward_kernel<<<blocks, kPixelThreads>>>(
      rgb, rgb_channels, pixels, color, v_render, v_channels, scratch.partials.data());
  check(cudaGetLastError(), "camera_color_backward_kernel launch");
  finish<kColorSums>(scratch.partials.data(), blocks, FinishCameraColor{v_color},
                     "camera colour finish_sums launch");
}

void squared_error(const float* rgb, int rgb_channels, const float* target, int width, int height,
                   double* out, LossScratch& scratch) {
  if (rgb_channels < kRgb)
    fail("squared error on the device: an image of {} channels, RGB needed", rgb_channels);
  const std::size_t pixels = std::size_t(width) * height;
  if (pixels == 0) fail("squared error on the device: the image is empty ({}x{})", width, height);
  const int blocks = pixel_blocks(pixels);
  scratch.partials.resize(blocks);
  squared_error_kernel<<<blocks, kPixelThreads>>>(rgb, rgb_channels, target, pixels,
                                                  scratch.partials.data());
  check(cudaGetLastError(), "squared_error_kernel launch");
  finish<kOneSum>(scratch.partials.data(), blocks, FinishSum{out},
                  "squared error finish_sums launch");
}

void squared_error(const float* rgb, int rgb_channels, const DeviceSsimTarget& target, double* out,
                   LossScratch& scratch) {
  if (target.image.size() != std::size_t(target.width) * target.height * kRgb)
    fail("squared error on the device: the target was not prepared (DeviceSsimTarget::assign)");
  squared_error(rgb, rgb_channels, target.image.data(), target.width, target.height, out, scratch);
}

void regularizer(const DevicePrimitives& p, const std::int32_t* rows, std::size_t count,
                 double opacity_weight, double scale_weight, double* value, LossScratch& scratch) {
  if (count == 0) {
    check(cudaMemset(value, 0, sizeof(double)), "regularizer: cudaMemset");  // +0.0
    return;
  }
  const int blocks = pixel_blocks(count);
  scratch.partials.resize(blocks);
  regularizer_kernel<<<blocks, kPixelThreads>>>(rows, count, p.size(), opacity_weight, scale_weight,
                                                p.opacity_logit.data(), p.log_scale.data(),
                                                scratch.partials.data());
  check(cudaGetLastError(), "regularizer_kernel launch");
  finish<kOneSum>(scratch.partials.data(), blocks, FinishSum{value},
                  "regularizer finish_sums launch");
}

void regularizer_backward(const DevicePrimitives& p, const std::int32_t* rows, std::size_t count,
                          double opacity_weight, double scale_weight, DevicePrimitiveGrads& grads) {
  if (count == 0) return;
  if (grads.size() != p.size())
    fail("regularizer backward on the device: gradients of {} rows for {} primitives", grads.size(),
         p.size());
  regularizer_backward_kernel<<<pixel_blocks(count), kPixelThreads>>>(
      rows, count, p.size(), opacity_weight, scale_weight, p.opacity_logit.data(),
      p.log_scale.data(), grads.v_opacity_logit.data(), grads.v_log_scale.data());
  check(cudaGetLastError(), "regularizer_backward_kernel launch");
}

void camera_pose_sums(const DeviceGaussians& g, const DeviceGaussianGrads& grads, double* sums,
                      LossScratch& scratch) {
  const std::size_t n = g.size();
  if (n == 0) return;
  if (grads.size() != n)
    fail("camera pose sums: {} Gaussians but a gradient of {}", n, grads.size());
  const int blocks = pixel_blocks(n);
  scratch.partials.resize(std::size_t(blocks) * 6);
  camera_pose_kernel<<<blocks, kPixelThreads>>>(n, g.means.data(), g.quats.data(),
                                                grads.v_means.data(), grads.v_quats.data(),
                                                scratch.partials.data());
  check(cudaGetLastError(), "camera_pose_kernel launch");
  finish<6>(scratch.partials.data(), blocks, AddPoseSums{sums}, "camera pose finish_sums launch");
}

}  // namespace retimegs::cuda
