#pragma once
// Images of one model at many cameras and times, on the CPU or on the GPU (DESIGN.md §3 "A second
// device: CUDA"): what `retimegs render` and `retimegs eval` draw with. On the GPU a 4D model's
// primitives are uploaded once; each image is sliced (cuda::slice) and rasterised
// (cuda::rasterize_forward) there, and its pixels (and alpha, and for a depth pass the composited
// depth) copied back. A static model's splats are turned into Gaussians for the camera on the host
// (model::splats_to_gaussians), then rasterised on the GPU. The colour map, RGBA's straight colour
// and a depth pass's division by alpha (render/depth.hpp) are applied on the host by the same code
// on both devices. The CPU's images are those of render_model and render_splats.
#include <memory>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/render/options.hpp"

namespace retimegs::playback {

class ModelRenderer {
 public:
  // kCuda needs a build with the CUDA backend and a usable GPU (cuda::resolve_device chose it);
  // otherwise throws Error naming the reason and --device cpu.
  explicit ModelRenderer(LoadedModel model, cuda::Device device = cuda::Device::kCpu);
  ~ModelRenderer();
  ModelRenderer(ModelRenderer&&) noexcept;
  ModelRenderer& operator=(ModelRenderer&&) noexcept;

  // The image over `background` (3 values, RGB) with `colors`: render_model or render_splats
  // (static splats ignore t and colors). With `depth`, the image's depth pass [H, W, 1]
  // (render/depth.hpp) into *depth, from the same render.
  Image render(const Camera& camera, double t, const float* background,
               const render::RenderOptions& options = {}, Colors colors = Colors::kModel,
               Image* depth = nullptr) const;

  // The image as straight (unassociated) RGBA, the alpha PNG defines: alpha is the accumulated
  // opacity 1 - T (T: the transmittance left behind the last Gaussian), RGB the colour of what
  // the pixel sees, its render over black divided by alpha (0 where alpha is 0), through the
  // camera's colour map as in render(). Compositing it over a background b gives render()'s image
  // over b (over the map's image of b for a camera with a colour map). `depth` as in render().
  Image render_rgba(const Camera& camera, double t, const render::RenderOptions& options = {},
                    Colors colors = Colors::kModel, Image* depth = nullptr) const;

  const LoadedModel& model() const { return model_; }
  cuda::Device device() const { return device_; }

 private:
  struct Gpu;  // the device's arrays, reused by every image: one image at a time

  // The image over `background` before any colour map, its alpha into `alpha` and its depth pass
  // into `depth` when given. Near a merged model's seams, the cross-fade of the two sides' images
  // (model::seam_handover).
  Image draw(const Camera& camera, double t, const float* background,
             const render::RenderOptions& options, UninitVector<float>* alpha, Image* depth) const;
  // One image of `side` of the seam at time `seam`, its alpha and composited depth when given.
  Image draw_side(const Camera& camera, double t, const float* background,
                  const render::RenderOptions& options, model::SeamSide side, double seam,
                  UninitVector<float>* alpha, UninitVector<float>* composited_depth) const;

  LoadedModel model_;
  cuda::Device device_;
  std::unique_ptr<Gpu> gpu_;  // kCuda only
};

}  // namespace retimegs::playback
