#include "retimegs/model/static_splats.hpp"

#include <cmath>

#include "retimegs/model/sh.hpp"

namespace retimegs::model {

Gaussians splats_to_gaussians(const Splats& splats, const Camera& camera) {
  const std::size_t n = splats.size();
  const int k = splats.sh_coeffs();
  Gaussians g(n, 3);
  g.means = splats.means;
  g.log_scales = splats.log_scales;
  g.quats = splats.quats;
  const Eigen::Vector3f eye = camera.center().cast<float>();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    g.opacities[i] = 1.0f / (1.0f + std::exp(-splats.opacity_logits[i]));
    const float dir[3] = {splats.means[3 * i] - eye.x(), splats.means[3 * i + 1] - eye.y(),
                          splats.means[3 * i + 2] - eye.z()};
    sh_color(splats.sh_degree, &splats.sh[i * k * 3], dir, &g.features[3 * i]);
  }
  return g;
}

}  // namespace retimegs::model
