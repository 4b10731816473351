#pragma once
// Every hyper-parameter of training, with the paper's values as defaults (docs/method.md; paper
// appendix A). `--config FILE` overrides any subset; RUN/config.json records the full set.
// A key's default is its member's initialiser here; its range and meaning are its entry in the
// key table (config_keys(), src/train/config.cpp), from which the JSON reading and writing, the
// range checks and the key tables of docs/formats.md come.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "retimegs/model/primitives.hpp"

namespace retimegs::train {

// The config's `ablate` object: parts of the recipe switched off (docs/method.md).
struct Ablations {
  bool no_flow_init = false;
  bool no_flow_loss = false;
  bool no_triple = false;
  bool no_stretch = false;
  bool linear = false;
  bool no_static_init = false;
  bool no_camera_color = false;

  friend bool operator==(const Ablations&, const Ablations&) = default;
};

// Sets the ablations named in `list` (comma-separated names of ablation_names(); empty: none) on
// top of `ablate`. Throws Error naming `flag` on an empty item or an unknown name.
Ablations parse_ablations(const std::string& list, Ablations ablate, const std::string& flag);
// "no-flow-init, no-flow-loss, ...": the names `--ablate` takes, each its key with '-' for '_'.
std::string ablation_names();

struct TrainConfig {
  int iters = 20000;
  std::uint64_t seed = 0;
  bool stgs_baseline = false;
  Ablations ablate;

  // Milestones are given for the paper's 20 000 iterations and scaled by iters / 20 000 when
  // `scale_schedule` is set, so that a short run follows the same recipe compressed.
  bool scale_schedule = true;
  int sh_degree_every = 1000;
  int max_sh_degree = 3;
  int lr_decay_start = 18000;
  double lr_decay_final = 0.1;
  int flow_decay_until = 12000;
  // The paper's reading of its flow schedule: held at flow_weight_start until flow_decay_until,
  // then exponential to flow_weight_end at the last iteration. false: exponential from iteration
  // 0, reaching flow_weight_end at flow_decay_until (docs/method.md, "Departures from the paper").
  bool flow_hold = false;
  int relocate_every = 100, relocate_start = 500, relocate_stop = 25000;
  int stretch_every = 3000;

  // Learning rates (gsplat defaults; means and velocities x scene extent).
  double lr_means = 1.6e-4, lr_means_final = 0.01;
  double lr_velocity = 1.6e-4;
  double lr_scales = 5e-3, lr_quats = 1e-3, lr_quat_rate = 1e-3, lr_opacities = 5e-2;
  double lr_sh0 = 2.5e-3, lr_sh_rest_factor = 1.0 / 20;
  double lr_temporal_center = 1e-4, lr_temporal_scale = 3e-2;
  double lr_camera_color = 1e-3;  // Dynamic 3D Gaussians' rate

  // Losses and regularisers.
  double ssim_lambda = 0.2;
  double flow_weight_start = 0.5, flow_weight_end = 1e-6;
  double opacity_reg = 0.01, scale_reg = 0.1;
  // Every step's renders over a random colour of its own (train/background.hpp); unset: on for a
  // capture without masks (train::random_background, which the run writes into its config).
  std::optional<bool> random_background;

  // Model.
  double gamma = 0.005;

  // Camera refinement (model/camera_pose.hpp). Unset: on for a scene whose calibration is the
  // user's (train::refine_cameras, which the run writes into its config).
  std::optional<bool> refine_cameras;
  double lr_camera_pose = 5e-4;    // ω in radians, τ in scene extents
  int camera_refine_start = 1000;  // scaled: the scene takes shape before the cameras move
  double camera_pose_reg = 1e-4;

  // Clock refinement (docs/method.md, "Camera clock refinement"). Unset: on for a scene whose
  // clocks were estimated (train::refine_clocks, which the run writes into its config).
  std::optional<bool> refine_clocks;
  double lr_time_offset = 5e-3;   // frames
  // Scaled. Late: between training times only the cameras off the grid see the scene, so a clock
  // moved before their in-between states are fitted follows the model's first interpolation.
  int clock_refine_start = 10000;

  // Flow-aware initialisation: the paper's readings (true) or the project's (docs/method.md).
  bool init_average_lifts = false;  // 3-D displacement: mean of the per-view lifts at the depth
  bool init_mean_velocity = false;  // v1 = v2 = v3 = the mean of both displacements
  // The paper's fallback at the clip's ends kept through training: v1 of the clip's first interval
  // and v3 of its last follow v2 after every step.
  bool tie_end_velocities = false;

  // MCMC.
  std::size_t cap = 200000;
  bool relocate_per_duration = false;  // relocation score σ/(τ_l+τ_r) (paper); false: σ·(τ_l+τ_r)
  double min_opacity = 0.01, growth = 1.05;
  double final_prune_opacity = 0.03;
  double init_opacity = 0.1;

  // Dynamic stretching.
  double stretch_distance = 0.01, stretch_color = 0.1, stretch_speed = 0.002;

  int checkpoint_every = 1000;
  int checkpoint_keep = 2;  // each is ~3x the model: the latest two, one to fall back on

  // Milestone `iteration` (given for 20 000 iterations) in this run's units.
  int scaled(int iteration) const;
  model::ModelConfig model_config() const;

  friend bool operator==(const TrainConfig&, const TrainConfig&) = default;
};

// The values a number key takes: [low, high], an end excluded where it is open.
struct Range {
  double low, high;
  bool open_low = false, open_high = false;

  bool contains(double value) const;
};
// "[0, 1)", "(0, inf]": as check_config's messages and docs/formats.md write a range.
std::string to_string(const Range& range);

// One key of the config: its JSON name, where its value lives, the values it takes and its
// line in the documentation.
struct ConfigKey {
  // A member of TrainConfig, or of its `ablate` object (written inside "ablate").
  // A std::optional<bool> is a flag whose default depends on the capture (JSON null: unset).
  using Member =
      std::variant<bool TrainConfig::*, int TrainConfig::*, std::uint64_t TrainConfig::*,
                   double TrainConfig::*, std::optional<bool> TrainConfig::*, bool Ablations::*>;
  std::string_view name;
  Member member;
  std::optional<Range> range;  // none: any value of its type (flags, the seed)
  std::string_view group;      // the table of docs/formats.md that lists it, by its heading
  std::string_view help;       // Markdown, one line

  bool is_ablation() const { return std::holds_alternative<bool Ablations::*>(member); }
};

// Every key, in the order of the documentation.
std::span<const ConfigKey> config_keys();

// Presets of `train --preset`: iterations and primitive budget, fast to quality; `default` is
// TrainConfig's own iters and cap (the paper's 20 000 steps), `paper` the default budget with the
// paper's readings (the keys of "The paper's readings" and ablate.no_static_init). Returns `config`
// with the preset's values; throws Error naming `flag` on an unknown name.
TrainConfig with_preset(TrainConfig config, const std::string& name, const std::string& flag);
// "fast (5000 iterations, cap 100000), default (...), ...", for help texts and errors.
std::string describe_presets();

// JSON text with every key (keys in alphabetical order); parse applies the keys present in
// `json_text` on top of `config` and throws Error naming an unknown key or a wrongly typed value.
std::string to_json(const TrainConfig& config);
TrainConfig config_from_json(const std::string& json_text, TrainConfig config,
                             const std::string& what);
// Every value in its key's range; throws Error naming `what`, the key and the value.
// config_from_json calls it.
void check_config(const TrainConfig& config, const std::string& what);

}  // namespace retimegs::train
