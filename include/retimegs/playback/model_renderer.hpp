#pragma once
// Images of one model at many cameras and times, on the CPU or on the GPU (DESIGN.md §3 "A second
// device: CUDA"): what `retimegs render` and `retimegs eval` draw with. On the GPU a 4D model's
// primitives are uploaded once; each image is sliced (cuda::slice) and rasterised
// (cuda::rasterize_forward) there, and its pixels (and alpha) copied back. A static model's
// splats are turned into Gaussians for the camera on the host (model::splats_to_gaussians), then
// rasterised on the GPU. The colour map and RGBA's straight colour are applied on the host by the
// same code on both devices. The CPU's images are those of render_model and render_splats.
#include <memory>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/cuda/device.hpp"
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
  // (static splats ignore t and colors).
  Image render(const Camera& camera, double t, const float* background,
               const render::RenderOptions& options = {}, Colors colors = Colors::kModel) const;

  // The image as straight (unassociated) RGBA, the alpha PNG defines: alpha is the accumulated
  // opacity 1 - T (T: the transmittance left behind the last Gaussian), RGB the colour of what
  // the pixel sees, its render over black divided by alpha (0 where alpha is 0), through the
  // camera's colour map as in render(). Compositing it over a background b gives render()'s image
  // over b (over the map's image of b for a camera with a colour map).
  Image render_rgba(const Camera& camera, double t, const render::RenderOptions& options = {},
                    Colors colors = Colors::kModel) const;

  const LoadedModel& model() const { return model_; }
  cuda::Device device() const { return device_; }

 private:
  struct Gpu;  // the device's arrays, reused by every image: one image at a time

  // The image over `background` before any colour map, and its alpha into `alpha` when given.
  Image draw(const Camera& camera, double t, const float* background,
             const render::RenderOptions& options, UninitVector<float>* alpha) const;

  LoadedModel model_;
  cuda::Device device_;
  std::unique_ptr<Gpu> gpu_;  // kCuda only
};

}  // namespace retimegs::playback
