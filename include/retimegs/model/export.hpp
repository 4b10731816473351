#pragma once
// The 3D Gaussians of one time as a static 3DGS model (core/splats.hpp), ready for the Inria .ply
// that SuperSplat and other viewers open: position x(T), rotation q(T), opacity logit including
// the temporal factor σ·σ_τ(T), log-scales and the SH coefficients of the active degree.
#include "retimegs/core/splats.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::model {

// Primitives whose opacity at T is below `min_opacity` (default: one 8-bit step, which the
// renderer skips anyway) are left out.
Splats export_splats(const Model& model, double t, double min_opacity = 1.0 / 255.0);

}  // namespace retimegs::model
