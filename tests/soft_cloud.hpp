#pragma once
// A model of n soft, round primitives around the origin for the tests that render one: uniform
// positions within ±spread, one scale, a drift along x, random DC colours, every window [0, 2] on
// the time grid {0, 2, 2}; opacity logits fixed or, when not given, uniform within ±0.5.
#include <cmath>
#include <optional>
#include <random>

#include "retimegs/model/model_file.hpp"
#include "retimegs/model/temporal_opacity.hpp"

namespace retimegs::test {

struct SoftCloud {
  int count = 12;
  unsigned seed = 1;
  float spread = 1.0f;
  float scale = 0.15f;
  float drift = 0.0f;  // velocity's x component, world units per unit time
  std::optional<float> opacity_logit = std::nullopt;
};

inline model::Model soft_cloud(const SoftCloud& spec) {
  model::Model model;
  model.grid = {0.0, 2.0, 2};
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<float> u(-1, 1);
  model::Primitives& p = model.primitives;
  p.resize(spec.count);
  for (int i = 0; i < spec.count; ++i) {
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = spec.spread * u(rng);
    for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(spec.scale);
    p.q0[4 * i] = 1;
    p.velocity[9 * i] = spec.drift;
    for (int k = 0; k < 3; ++k) p.sh[48 * i + k] = 0.8f * u(rng);
    p.opacity_logit[i] = spec.opacity_logit ? *spec.opacity_logit : 0.5f * u(rng);
    p.mu_tau[i] = 1.0f;
    p.tau_l[i] = p.tau_r[i] = 2.0f;
  }
  return model;
}

// Two clouds as a merge leaves two windows' static worlds at a seam: on the grid {0, 2, 3} with a
// seam at t = 2 and `seam_fade`, `before`'s supports [0, 2] and `after`'s [2, 4] (each open at
// its clip end, closed at the seam). With `whole`, one cloud alone over the whole clip instead
// (`before`'s when whole = kBefore): what its window draws on its own.
inline model::Model seamed_clouds(const SoftCloud& before, const SoftCloud& after, double seam_fade,
                                  model::SeamSide whole = model::SeamSide::kNone) {
  model::Model model = soft_cloud(whole == model::SeamSide::kAfter ? after : before);
  model.grid = {0.0, 2.0, 3};
  model::Primitives& p = model.primitives;
  if (whole != model::SeamSide::kNone) {
    for (std::size_t i = 0; i < p.size(); ++i) p.mu_tau[i] = 2, p.tau_l[i] = p.tau_r[i] = 2;
    return model;
  }
  model.config.seams = {1};
  model.config.seam_fade = seam_fade;
  const model::Primitives later = soft_cloud(after).primitives;
  const std::size_t n = p.size();
  p.resize(n + later.size());
  for (std::size_t i = 0; i < later.size(); ++i) p.copy_row(n + i, later, i);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.mu_tau[i] = i < n ? 1.0f : 3.0f;
    p.tau_l[i] = p.tau_r[i] = 1.0f;
  }
  return model;
}

}  // namespace retimegs::test
