#pragma once
// A static 3DGS model (core/splats.hpp, e.g. an Inria .ply) made renderable for one camera:
// colours from the SH at each view direction, opacity = sigmoid(logit).
#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/core/splats.hpp"

namespace retimegs::model {

Gaussians splats_to_gaussians(const Splats& splats, const Camera& camera);

}  // namespace retimegs::model
