#pragma once
// The training step's losses on the GPU (DESIGN.md §3 "A second device: CUDA"):
// train/losses.hpp's image loss, flow loss and regulariser and model/camera_color.hpp's colour
// map, forward and backward, on device arrays, and the squared error of the log's PSNR. The
// per-pixel formulas are the CPU's own (core/ssim_formulas.hpp, train/loss_formulas.hpp,
// model/camera_color.hpp); what differs:
//   - SSIM runs in float (the CPU in double): the loss agrees with the CPU's to ~1e-6 relative and
//     its gradient to ~1e-5 of the gradient's largest value (tests/cuda/test_losses_cuda.cpp);
//   - sums are per-block partials in double, added in a fixed order: the same value on every run,
//     equal to the CPU's to double rounding. The L1 and flow gradients are the CPU's bit for bit;
//   - the colour map's gain · value + offset may be fused into one rounding on one device and not
//     on the other, and exp(m) is rounded from double on the device: a couple of ulps.
// Every call runs on the default stream and leaves its loss in device memory: the host reads it
// only when it asks (DeviceBuffer::download), so a step has no other host round trip.
//
//   cuda::DeviceSsimTarget target;  target.assign(packed_view);      // once per view
//   cuda::image_loss(render.data(), C, target, lambda, 1.0, v_render.data(), C, loss.data(), s);
#include <array>
#include <cstdint>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "retimegs/cuda/rasterize.hpp"

namespace retimegs::cuda {

// A training image on the device in its packed 16-bit form (core/image.hpp PackedImage): half the
// memory of floats, unpacked where it is used.
struct DevicePackedImage {
  int width = 0, height = 0, channels = 0;
  DeviceBuffer<std::uint16_t> data;  // [H, W, C]

  void upload(const PackedImage& image);
};

// A flow on the device (core/image.hpp Flow).
struct DeviceFlow {
  int width = 0, height = 0;
  DeviceBuffer<float> uv;            // [H, W, 2]
  DeviceBuffer<std::uint8_t> valid;  // [H, W] 1 = known

  void upload(const Flow& flow);
};

// A view's two flows brought to the device while the step's kernels before the flow loss run
// (shading, slicing, the first render): the training set's host flows are page-locked in place
// once (cudaHostRegister), which lets a copy run beside the kernels at the bus's full rate, and
// they are copied on a stream of their own. Kernels launched on the default stream after forward()
// or backward() wait for the copies; the next start() waits for the kernels launched before it, so
// that it never overwrites flows still being read. A flow the host will not lock (one that shares
// a page with one locked before it, or past the host's limit) is copied from pageable memory,
// correct but without the overlap.
class FlowUploads {
 public:
  explicit FlowUploads(const std::vector<const Flow*>& flows);  // null entries are skipped
  ~FlowUploads();
  FlowUploads(const FlowUploads&) = delete;
  FlowUploads& operator=(const FlowUploads&) = delete;

  // Starts the copies of the view's flows; a null one is not copied (its DeviceFlow keeps the
  // last one's contents).
  void start(const Flow* forward, const Flow* backward);
  const DeviceFlow& forward();
  const DeviceFlow& backward();
  std::size_t locked_bytes() const { return locked_bytes_; }

 private:
  void lock(const void* host, std::size_t bytes);
  void copy(const Flow& flow, DeviceFlow& out);
  const DeviceFlow& ready(const DeviceFlow& flow);

  DeviceFlow forward_, backward_;
  cudaStream_t stream_ = nullptr;
  cudaEvent_t copied_ = nullptr, read_ = nullptr;
  std::vector<void*> locked_;
  std::size_t locked_bytes_ = 0;
};

// The target side of SSIM (core/ssim.hpp SsimTarget) on the device: the training view unpacked
// (unpack_code) and its window moments μ_b, E[b²] in float, prepared once per view for every
// render of a step.
struct DeviceSsimTarget {
  int width = 0, height = 0;
  DeviceBuffer<float> image, mu, e_sq;  // [H, W, 3] each

  // Throws Error unless `packed` is an RGB image (3 channels), not empty. With `foreground` [H, W]
  // (device; train::foreground_flags of the view's mask), the pixels it marks 0 take `background`
  // (RGB) instead of the image's: train::replace_background's target.
  void assign(const DevicePackedImage& packed, const std::uint8_t* foreground = nullptr,
              const std::array<float, 3>& background = {});
};

// Scratch of the losses, kept across calls (its allocations settle after the first step).
struct LossScratch {
  DeviceBuffer<float> coefficients;   // [3, H, W, 3] scale · dS/d(μ_a, E[a²], E[ab])
  DeviceBuffer<double> partials;      // [sums, blocks] per-block partial sums
  DeviceBuffer<float> flow_gradient;  // [1] weight / known pixels of the flow loss
};

// train::image_loss on the device: (1 − λ)·L1 + λ·(1 − SSIM) of rgb against the target, mean over
// H×W×3. rgb [H, W, rgb_channels] holds RGB in its first 3 channels (a render with its flow
// channels, or the colour-mapped [H, W, 3]); weight · d loss / d rgb is added into the first 3
// channels of v_render [H, W, v_channels]; *loss (device) is set to the loss, unweighted as the
// CPU returns it. Throws Error on channel counts below 3 or an unprepared target.
void image_loss(const float* rgb, int rgb_channels, const DeviceSsimTarget& target,
                double ssim_lambda, double weight, float* v_render, int v_channels, double* loss,
                LossScratch& scratch);

// train::flow_loss on the device: the mean over known pixels of the L1 distance between the
// render's channels (channel, channel + 1) and the flow; render and v_render are [H, W, channels]
// and weight · d loss / d render is added into v_render's same two channels. *loss (device) is set
// to the loss, 0 (and no gradient) when no pixel is known. Throws Error on a size mismatch.
void flow_loss(const float* render, int channels, int channel, const DeviceFlow& target,
               double weight, float* v_render, double* loss, LossScratch& scratch);

// Σ over pixels and RGB channels of (rgb − target)², each difference taken in double: the sum of
// core/psnr.hpp's psnr(), whose rule psnr_from_squared_error(*out, H·W·3) then applies on the
// host. rgb [H, W, rgb_channels] holds RGB first, target [H, W, 3]; *out (device). Per-block
// partials added in a fixed order: the same on every run, the CPU's sum to double rounding.
void squared_error(const float* rgb, int rgb_channels, const float* target, int width, int height,
                   double* out, LossScratch& scratch);
// The same against a prepared view (its unpacked image).
void squared_error(const float* rgb, int rgb_channels, const DeviceSsimTarget& target, double* out,
                   LossScratch& scratch);

// train::regularizer on the device over rows[0, count) (device, int32, distinct) of the N =
// primitives.size() rows: *value (device) is set to it, 0 when count is 0. The rows' terms
// (train/loss_formulas.hpp regularizer_add) are summed in double per block, the blocks in a fixed
// order: the same on every run, the CPU's sum to double rounding.
void regularizer(const DevicePrimitives& primitives, const std::int32_t* rows, std::size_t count,
                 double opacity_weight, double scale_weight, double* value, LossScratch& scratch);
// train::regularizer_backward on the device: d regularizer / d opacity_logit and d / d log_scale
// of the rows added into grads (regularizer_row_backward, the CPU's floats but for exp's last bit).
void regularizer_backward(const DevicePrimitives& primitives, const std::int32_t* rows,
                          std::size_t count, double opacity_weight, double scale_weight,
                          DevicePrimitiveGrads& grads);

// model::apply_camera_color on the device: out [H, W, 3] = exp(m) ⊙ rgb + c, rgb [H, W,
// rgb_channels] with RGB first; color [6] (device) holds m then c, a camera's row of the step's
// colour parameters.
void apply_camera_color(const float* rgb, int rgb_channels, int width, int height,
                        const float* color, float* out);

// model::apply_camera_color_backward on the device: v_render [H, W, v_channels] holds d loss /
// d out in its first 3 channels on entry and d loss / d rgb there on return; d loss / d (m, c) is
// added into v_color [6] (device).
void apply_camera_color_backward(const float* rgb, int rgb_channels, int width, int height,
                                 const float* color, float* v_render, int v_channels,
                                 float* v_color, LossScratch& scratch);

// model::camera_pose_vjp's world-frame sums on the device: the moment and force
// (model::add_pose_moment) of a render's Gaussians from the rasteriser's gradient, added into
// sums [6] (device: moment, then force), so that a step's passes accumulate before one copy to
// the host, where model::pose_gradient turns them into the correction's gradient. Per-block
// partials added in a fixed order: the same on every run.
void camera_pose_sums(const DeviceGaussians& gaussians, const DeviceGaussianGrads& grads,
                      double* sums, LossScratch& scratch);

}  // namespace retimegs::cuda
