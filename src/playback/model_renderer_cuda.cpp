// ModelRenderer on the GPU (built with the CUDA backend only; src/CMakeLists.txt).
#include <variant>

#include "model_renderer_gpu.hpp"
#include "retimegs/model/static_splats.hpp"

namespace retimegs::playback {

ModelRenderer::Gpu::Gpu(const LoadedModel& model) {
  if (const auto* m = std::get_if<model::Model>(&model)) primitives.upload(m->primitives);
}

Image ModelRenderer::Gpu::draw(const LoadedModel& model, const Camera& camera, double t,
                               const float* background, const render::RenderOptions& options,
                               model::SeamSide side, double side_seam, UninitVector<float>* alpha,
                               UninitVector<float>* composited_depth) {
  const cuda::DeviceGaussians* gaussians = &splats;
  if (const auto* m = std::get_if<model::Model>(&model)) {
    cuda::DeviceSliceOptions slice_options;
    slice_options.side = side, slice_options.side_seam = side_seam;
    cuda::slice(primitives, m->config, m->grid, t, camera, slice_options, sliced);
    gaussians = &sliced.gaussians;
  } else {
    splats.upload(model::splats_to_gaussians(std::get<Splats>(model), camera));
  }
  cuda::rasterize_forward(*gaussians, camera, background, options, out);
  Image image(out.blend.width, out.blend.height, out.blend.channels);
  out.blend.image.download(image.data.data());
  if (alpha) {
    alpha->resize(out.blend.alpha.size());
    out.blend.alpha.download(alpha->data());
  }
  if (composited_depth) {
    composited_depth->resize(out.blend.depth.size());
    out.blend.depth.download(composited_depth->data());
  }
  return image;
}

}  // namespace retimegs::playback
