#pragma once
// Every hyper-parameter of training, with the paper's values as defaults (docs/method.md; paper
// appendix A). `--config FILE` overrides any subset; RUN/config.json records the full set.
#include <cstdint>
#include <string>

#include "retimegs/model/primitives.hpp"

namespace retimegs::train {

struct Ablations {
  bool no_flow_init = false;  // velocities start at 0, points unmoved
  bool no_flow_loss = false;  // flow weight 0
  bool no_triple = false;     // only the all-primitives render at each frame
  bool no_stretch = false;
  bool linear = false;          // x(t) = μ + (t - μ_τ) v2
  bool no_static_init = false;  // every seed keeps its own interval at initialisation
  // No per-camera colour correction (model::CameraColor): every camera sees the model's colours.
  bool no_camera_color = false;
};

// Sets the ablations named in `list` (comma-separated: no-flow-init, no-flow-loss, no-triple,
// no-stretch, linear, no-static-init, no-camera-color; empty: none) on top of `ablate`. Throws
// Error naming `flag` on an empty item or an unknown name.
Ablations parse_ablations(const std::string& list, Ablations ablate, const std::string& flag);

struct TrainConfig {
  int iters = 20000;
  std::uint64_t seed = 0;
  bool stgs_baseline = false;  // --baseline stgs
  Ablations ablate;

  // Milestones are given for the paper's 20 000 iterations and scaled by iters / 20 000 when
  // `scale_schedule` is set, so that a short run follows the same recipe compressed.
  bool scale_schedule = true;
  int sh_degree_every = 1000;  // active SH degree = min(step / this, max_sh_degree)
  int max_sh_degree = 3;
  int lr_decay_start = 18000;    // all rates decay exponentially from here to the end
  double lr_decay_final = 0.1;   // ... down to this factor at the last iteration
  int flow_decay_until = 12000;  // flow weight decays log-linearly until here, then stays
  int relocate_every = 100, relocate_start = 500, relocate_stop = 25000;
  int stretch_every = 3000;  // dynamic stretching (also its first iteration)

  // Learning rates (gsplat defaults; means and velocities x scene extent).
  double lr_means = 1.6e-4, lr_means_final = 0.01;  // means decay to 1 % over training
  // x extent / Δt. The means' rate: a faster one helps scenes with large, exact motion but hurts
  // captures with noisy flow and small motion (bench/velocity_lr.sh; README, Results).
  double lr_velocity = 1.6e-4;
  double lr_scales = 5e-3, lr_quats = 1e-3, lr_quat_rate = 1e-3, lr_opacities = 5e-2;
  double lr_sh0 = 2.5e-3, lr_sh_rest_factor = 1.0 / 20;
  double lr_temporal_center = 1e-4, lr_temporal_scale = 3e-2;  // STGS only
  double lr_camera_color = 1e-3;  // per-camera colour m and c (Dynamic 3D Gaussians' rate)

  // Losses and regularisers.
  double ssim_lambda = 0.2;
  double flow_weight_start = 0.5, flow_weight_end = 1e-6;
  double opacity_reg = 0.01, scale_reg = 0.1;

  // Model.
  double gamma = 0.005;  // normalised clip time

  // MCMC.
  std::size_t cap = 200000;  // primitive budget
  double min_opacity = 0.01, growth = 1.05;
  // After the last step, the primitives below this opacity that span one interval are removed
  // (train::faint_short_rows; 0 keeps them).
  double final_prune_opacity = 0.03;
  double init_opacity = 0.1;

  // Dynamic stretching: neighbours within this distance (x scene extent), colour (SH DC) and
  // speed (x extent per frame) thresholds.
  double stretch_distance = 0.01, stretch_color = 0.1, stretch_speed = 0.002;

  int checkpoint_every = 1000;

  // Milestone `iteration` (given for 20 000 iterations) in this run's units.
  int scaled(int iteration) const;
  model::ModelConfig model_config() const;
};

// Budget presets of `train --preset`: iterations and primitive budget, fast to quality.
// `default` is TrainConfig's own iters and cap (the paper's 20 000 steps). Returns `config` with
// the preset's values; throws Error naming `flag` on an unknown name.
TrainConfig with_preset(TrainConfig config, const std::string& name, const std::string& flag);
// "fast (5000 iterations, cap 100000), default (...), ...", for help texts and errors.
std::string describe_presets();

// JSON text with every field; parse applies the keys present in `json_text` on top of `config`
// and throws Error naming an unknown key or a wrongly typed value.
std::string to_json(const TrainConfig& config);
TrainConfig config_from_json(const std::string& json_text, TrainConfig config,
                             const std::string& what);
// Every value in its range (iterations and divisors >= 1, rates and weights >= 0, opacities in
// [0, 1), ...); throws Error naming `what`, the key and the value. config_from_json calls it.
void check_config(const TrainConfig& config, const std::string& what);

}  // namespace retimegs::train
