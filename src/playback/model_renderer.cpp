#include "retimegs/playback/model_renderer.hpp"

#include <optional>
#include <utility>
#include <variant>

#include "retimegs/core/error.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/static_splats.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/render/depth.hpp"
#include "retimegs/render/rasterize.hpp"

#if RETIMEGS_HAS_CUDA
#include "model_renderer_gpu.hpp"
#else
namespace retimegs::playback {
struct ModelRenderer::Gpu {};
}  // namespace retimegs::playback
#endif

namespace retimegs::playback {

namespace {

// The colour map a render with `colors` goes through: a 4D model's stored correction of a
// training camera, for Colors::kCamera; none otherwise.
const model::CameraColor* colour_map(const LoadedModel& model, const Camera& camera,
                                     Colors colors) {
  const auto* m = std::get_if<model::Model>(&model);
  return m && colors == Colors::kCamera ? model::find_camera_color(*m, camera.name) : nullptr;
}

// Straight RGBA from a render over black (`rgb`, premultiplied) and its alpha.
Image straight_rgba(Image rgb, const UninitVector<float>& alpha, const model::CameraColor* color) {
  // Over black the image is the premultiplied colour sum_i c_i alpha_i T_i: divided by alpha it
  // is the straight colour. The colour map is affine per channel, so it maps a composite as
  // map(C + T b) = alpha map(C / alpha) + T map(b): it applies to the straight colour.
  const std::size_t n = rgb.pixels();
  for (std::size_t i = 0; i < n; ++i) {
    const float a = alpha[i];
    for (int c = 0; c < 3; ++c) rgb.data[3 * i + c] = a > 0 ? rgb.data[3 * i + c] / a : 0.0f;
  }
  if (color) model::apply_camera_color(rgb, *color, rgb);
  Image rgba(rgb.width, rgb.height, 4);
  for (std::size_t i = 0; i < n; ++i) {
    const float a = alpha[i];
    for (int c = 0; c < 3; ++c) rgba.data[4 * i + c] = a > 0 ? rgb.data[3 * i + c] : 0.0f;
    rgba.data[4 * i + 3] = a;
  }
  return rgba;
}

}  // namespace

ModelRenderer::ModelRenderer(LoadedModel model, cuda::Device device)
    : model_(std::move(model)), device_(device) {
  if (device_ == cuda::Device::kCpu) return;
#if RETIMEGS_HAS_CUDA
  gpu_ = std::make_unique<Gpu>(model_);
#else
  fail(
      "rendering on the GPU: this build has no CUDA backend (rebuild where nvcc is found, or "
      "run with --device cpu)");
#endif
}

ModelRenderer::~ModelRenderer() = default;
ModelRenderer::ModelRenderer(ModelRenderer&&) noexcept = default;
ModelRenderer& ModelRenderer::operator=(ModelRenderer&&) noexcept = default;

Image ModelRenderer::draw_side(const Camera& camera, double t, const float* background,
                               const render::RenderOptions& options, model::SeamSide side,
                               double seam, UninitVector<float>* alpha,
                               UninitVector<float>* composited_depth) const {
#if RETIMEGS_HAS_CUDA
  if (gpu_)
    return gpu_->draw(model_, camera, t, background, options, side, seam, alpha, composited_depth);
#endif
  render::RenderOutput out;
  if (const auto* splats = std::get_if<Splats>(&model_)) {
    render::rasterize_forward(model::splats_to_gaussians(*splats, camera), camera, background,
                              options, out);
  } else {
    const model::Model& m = std::get<model::Model>(model_);
    model::SliceOptions slice_options;
    slice_options.side = side, slice_options.side_seam = seam;
    const model::TimeSlice sliced =
        model::slice(m.primitives, m.config, m.grid, t, camera, slice_options);
    render::rasterize_forward(sliced.gaussians, camera, background, options, out);
  }
  if (alpha) *alpha = std::move(out.blend.alpha);
  if (composited_depth) *composited_depth = std::move(out.blend.depth);
  return std::move(out.blend.image);
}

Image ModelRenderer::draw(const Camera& camera, double t, const float* background,
                          const render::RenderOptions& options, UninitVector<float>* alpha,
                          Image* depth) const {
  render::RenderOptions draw_options = options;
  draw_options.render_depth = depth != nullptr;
  UninitVector<float> own_alpha, composited_depth;
  if (depth && !alpha) alpha = &own_alpha;  // the depth pass divides by it
  UninitVector<float>* depth_sum = depth ? &composited_depth : nullptr;
  const auto* m = std::get_if<model::Model>(&model_);
  const std::optional<model::SeamHandover> handover =
      m ? model::seam_handover(m->config, m->grid, t) : std::nullopt;
  Image image;
  if (!handover) {
    image =
        draw_side(camera, t, background, draw_options, model::SeamSide::kNone, 0, alpha, depth_sum);
  } else if (!handover->draws(model::SeamSide::kAfter)) {
    image = draw_side(camera, t, background, draw_options, model::SeamSide::kBefore, handover->seam,
                      alpha, depth_sum);
  } else if (!handover->draws(model::SeamSide::kBefore)) {
    image = draw_side(camera, t, background, draw_options, model::SeamSide::kAfter, handover->seam,
                      alpha, depth_sum);
  } else {
    // Every output is linear in the two images' compositing sums: the image over the background,
    // alpha and the composited depth cross-fade alike, and the depth pass divides the faded sums.
    UninitVector<float> after_alpha, after_depth;
    image = draw_side(camera, t, background, draw_options, model::SeamSide::kBefore, handover->seam,
                      alpha, depth_sum);
    const Image after =
        draw_side(camera, t, background, draw_options, model::SeamSide::kAfter, handover->seam,
                  alpha ? &after_alpha : nullptr, depth_sum ? &after_depth : nullptr);
    const auto fade = [w = float(handover->before)](float* before, const float* later,
                                                    std::size_t n) {
      for (std::size_t i = 0; i < n; ++i) before[i] = w * before[i] + (1 - w) * later[i];
    };
    fade(image.data.data(), after.data.data(), image.data.size());
    if (alpha) fade(alpha->data(), after_alpha.data(), alpha->size());
    if (depth_sum) fade(depth_sum->data(), after_depth.data(), depth_sum->size());
  }
  if (depth)
    *depth = render::depth_pass(composited_depth.data(), alpha->data(), image.width, image.height);
  return image;
}

Image ModelRenderer::render(const Camera& camera, double t, const float* background,
                            const render::RenderOptions& options, Colors colors,
                            Image* depth) const {
  Image image = draw(camera, t, background, options, nullptr, depth);
  if (const model::CameraColor* color = colour_map(model_, camera, colors))
    model::apply_camera_color(image, *color, image);
  return image;
}

Image ModelRenderer::render_rgba(const Camera& camera, double t,
                                 const render::RenderOptions& options, Colors colors,
                                 Image* depth) const {
  const float black[3] = {0, 0, 0};
  UninitVector<float> alpha;
  Image rgb = draw(camera, t, black, options, &alpha, depth);
  return straight_rgba(std::move(rgb), alpha, colour_map(model_, camera, colors));
}

}  // namespace retimegs::playback
