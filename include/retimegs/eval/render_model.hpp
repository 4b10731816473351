#pragma once
// One RGB image of a model from a camera: a 4D model (.rgs) at any real time, or a static 3DGS
// model. The shared path of `retimegs render`, `eval` and the trainer's previews.
#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/splats.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/render/options.hpp"

namespace retimegs::eval {

// background: 3 values (RGB).
Image render_model(const model::Model& model, const Camera& camera, double t,
                   const float* background, const render::RenderOptions& options = {});

Image render_splats(const Splats& splats, const Camera& camera, const float* background,
                    const render::RenderOptions& options = {});

}  // namespace retimegs::eval
