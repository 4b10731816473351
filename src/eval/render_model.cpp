#include "retimegs/eval/render_model.hpp"

#include "retimegs/model/evaluate.hpp"
#include "retimegs/model/static_splats.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::eval {

Image render_model(const model::Model& model, const Camera& camera, double t,
                   const float* background, const render::RenderOptions& options) {
  const model::Evaluated evaluated =
      model::evaluate(model.primitives, model.config, model.grid, t, camera, {});
  return render::rasterize_forward(evaluated.gaussians, camera, background, options).blend.image;
}

Image render_splats(const Splats& splats, const Camera& camera, const float* background,
                    const render::RenderOptions& options) {
  return render::rasterize_forward(model::splats_to_gaussians(splats, camera), camera, background,
                                   options)
      .blend.image;
}

}  // namespace retimegs::eval
