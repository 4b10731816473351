#include "retimegs/train/losses.hpp"

#include <array>
#include <cmath>

#include "retimegs/core/error.hpp"
#include "retimegs/core/ssim.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/train/loss_formulas.hpp"

namespace retimegs::train {

namespace {
// Images below this many pixels, and row sets below this many rows, are not worth waking the other
// threads for.
constexpr std::ptrdiff_t kParallelPixels = 1 << 14;
constexpr std::ptrdiff_t kParallelRows = 1 << 12;
// The regulariser's sum is split into this many runs of the rows (more than any thread count).
constexpr int kRegularizerRuns = 64;
}  // namespace

const Image& rgb_of(const Image& render, Image& buffer) {
  if (render.channels == 3) return render;
  buffer.width = render.width, buffer.height = render.height, buffer.channels = 3;
  buffer.data.resize(3 * render.pixels());
  const std::ptrdiff_t pixels = std::ptrdiff_t(render.pixels());
#pragma omp parallel for schedule(static) if (pixels >= kParallelPixels)
  for (std::ptrdiff_t p = 0; p < pixels; ++p)
    for (int c = 0; c < 3; ++c) buffer.data[3 * p + c] = render.data[render.channels * p + c];
  return buffer;
}

double image_loss(const Image& rgb, const SsimTarget& ssim_target, double ssim_lambda,
                  double weight, Image& v_render) {
  if (!ssim_target.image) fail("image loss: the target was not prepared");
  const Image& target = *ssim_target.image;
  if (rgb.channels != 3 || rgb.width != target.width || rgb.height != target.height ||
      target.channels != 3 || v_render.width != rgb.width || v_render.height != rgb.height ||
      v_render.channels < 3)
    fail("image loss: render {}x{}x{} vs target {}x{}x{}, gradient {}x{}x{}", rgb.width, rgb.height,
         rgb.channels, target.width, target.height, target.channels, v_render.width,
         v_render.height, v_render.channels);
  const std::size_t n = rgb.data.size();
  const float l1_grad = float((1 - ssim_lambda) * weight / double(n));
  const int channels = v_render.channels;
  const std::ptrdiff_t pixels = std::ptrdiff_t(rgb.pixels());
  double l1 = 0;
#pragma omp parallel for schedule(static) reduction(+ : l1) if (pixels >= kParallelPixels)
  for (std::ptrdiff_t p = 0; p < pixels; ++p)
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * p + c;
      const float diff = rgb.data[i] - target.data[i];
      l1 += std::abs(diff);
      v_render.data[channels * p + c] += l1_gradient(diff, l1_grad);
    }
  l1 /= double(n);
  const double s = ssim_backward_add(rgb, ssim_target, -ssim_lambda * weight, v_render);
  return mix_image_loss(l1, s, ssim_lambda);
}

double flow_loss(const Image& render, int channel, const Flow& target, double weight,
                 Image& v_render) {
  if (render.width != target.width || render.height != target.height ||
      channel + 2 > render.channels)
    fail("flow loss: render {}x{}x{} vs flow {}x{} at channel {}", render.width, render.height,
         render.channels, target.width, target.height, channel);
  const std::ptrdiff_t pixels = std::ptrdiff_t(render.pixels());
  std::size_t known = 0;
#pragma omp parallel for schedule(static) reduction(+ : known) if (pixels >= kParallelPixels)
  for (std::ptrdiff_t p = 0; p < pixels; ++p) known += target.valid[p];
  if (known == 0) return 0;
  const float grad = float(weight / double(known));
  double sum = 0;
#pragma omp parallel for schedule(static) reduction(+ : sum) if (pixels >= kParallelPixels)
  for (std::ptrdiff_t p = 0; p < pixels; ++p) {
    if (!target.valid[p]) continue;
    for (int k = 0; k < 2; ++k) {
      const float diff = render.data[render.channels * p + channel + k] - target.uv[2 * p + k];
      sum += std::abs(diff);
      v_render.data[render.channels * p + channel + k] += l1_gradient(diff, grad);
    }
  }
  return sum / double(known);
}

double regularizer(const model::Primitives& p, const std::vector<std::int32_t>& rows,
                   double opacity_weight, double scale_weight) {
  const std::size_t n = p.size();
  const std::size_t count = rows.size();
  // Partial sums over a fixed split of the rows, added in order: the same for any thread count.
  std::array<double, kRegularizerRuns> partial{};
#pragma omp parallel for schedule(static) if (count >= std::size_t(kParallelRows))
  for (int run = 0; run < kRegularizerRuns; ++run) {
    double sum = 0;
    for (std::size_t j = count * run / kRegularizerRuns; j < count * (run + 1) / kRegularizerRuns;
         ++j) {
      const std::size_t r = std::size_t(rows[j]);
      sum = regularizer_add(sum, opacity_weight, scale_weight, n, p.opacity_logit[r],
                            &p.log_scale[3 * r]);
    }
    partial[run] = sum;
  }
  double reg = 0;
  for (const double sum : partial) reg += sum;
  return reg;
}

void regularizer_backward(const model::Primitives& p, const std::vector<std::int32_t>& rows,
                          double opacity_weight, double scale_weight,
                          model::PrimitiveGrads& grads) {
  const std::size_t n = p.size();
  const std::ptrdiff_t count = std::ptrdiff_t(rows.size());
  // Rows are distinct: each iteration writes its own gradient slots.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < count; ++j) {
    const std::size_t r = std::size_t(rows[j]);
    regularizer_row_backward(opacity_weight, scale_weight, n, p.opacity_logit[r],
                             &p.log_scale[3 * r], grads.v_opacity_logit[r],
                             &grads.v_log_scale[3 * r]);
  }
}

}  // namespace retimegs::train
