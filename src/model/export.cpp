#include "retimegs/model/export.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/model/temporal_opacity.hpp"
#include "retimegs/model/trajectory.hpp"

namespace retimegs::model {

Splats export_splats(const Model& model, double t, double min_opacity) {
  if (!std::isfinite(t)) fail("export: time {} is not finite", t);
  const Primitives& p = model.primitives;
  const ModelConfig& config = model.config;
  const int k = sh_coeffs(config.sh_degree);
  Splats s;
  s.sh_degree = config.sh_degree;
  for (std::size_t i = 0; i < p.size(); ++i) {
    throw_if_interrupted_every(i);
    // In double: the exported logit is log(σ σ_τ / (1 - σ σ_τ)) of the float model's exact values.
    const double opacity =
        sigmoid<double>(p.opacity_logit[i]) * temporal_opacity(p, i, config, model.grid, t);
    if (opacity < min_opacity || !(opacity > 0)) continue;
    float x[3];
    apply_trajectory(trajectory_at<float>(config.representation, config.trajectory, p.mu_tau[i],
                                          float(t), float(model.grid.step)),
                     &p.mu[3 * i], &p.velocity[9 * i], x);
    s.means.insert(s.means.end(), x, x + 3);
    s.log_scales.insert(s.log_scales.end(), &p.log_scale[3 * i], &p.log_scale[3 * i + 3]);
    const float dt = float(t - p.mu_tau[i]);
    for (int a = 0; a < 4; ++a) s.quats.push_back(p.q0[4 * i + a] + p.q1[4 * i + a] * dt);
    s.opacity_logits.push_back(float(std::log(opacity) - std::log1p(-std::min(opacity, 1 - 1e-7))));
    s.sh.insert(s.sh.end(), &p.sh[Primitives::kShWidth * i],
                &p.sh[Primitives::kShWidth * i + 3 * k]);
  }
  return s;
}

}  // namespace retimegs::model
