#include "retimegs/train/config.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"

namespace retimegs::train {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(Ablations, no_flow_init, no_flow_loss, no_triple,
                                                no_stretch, linear, no_static_init, no_camera_color)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    TrainConfig, iters, seed, stgs_baseline, ablate, scale_schedule, sh_degree_every, max_sh_degree,
    lr_decay_start, lr_decay_final, flow_decay_until, relocate_every, relocate_start, relocate_stop,
    stretch_every, lr_means, lr_means_final, lr_velocity, lr_scales, lr_quats, lr_quat_rate,
    lr_opacities, lr_sh0, lr_sh_rest_factor, lr_temporal_center, lr_temporal_scale, ssim_lambda,
    flow_weight_start, flow_weight_end, opacity_reg, scale_reg, gamma, cap, min_opacity,
    final_prune_opacity, growth, init_opacity, stretch_distance, stretch_color, stretch_speed,
    checkpoint_every, lr_camera_color)

Ablations parse_ablations(const std::string& list, Ablations ablate, const std::string& flag) {
  if (list.empty()) return ablate;
  std::vector<std::string> names;
  for (std::size_t start = 0; start <= list.size();) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    names.push_back(list.substr(start, comma - start));
    if (names.back().empty()) fail("{}: empty item in '{}'", flag, list);
    start = comma + 1;
  }
  const std::pair<std::string_view, bool Ablations::*> known[] = {
      {"no-flow-init", &Ablations::no_flow_init},
      {"no-flow-loss", &Ablations::no_flow_loss},
      {"no-triple", &Ablations::no_triple},
      {"no-stretch", &Ablations::no_stretch},
      {"linear", &Ablations::linear},
      {"no-static-init", &Ablations::no_static_init},
      {"no-camera-color", &Ablations::no_camera_color}};
  for (const std::string& name : names) {
    const auto* hit = std::find_if(std::begin(known), std::end(known),
                                   [&](const auto& k) { return k.first == name; });
    if (hit == std::end(known))
      fail(
          "{}: unknown ablation '{}' (no-flow-init, no-flow-loss, no-triple, no-stretch, linear, "
          "no-static-init, no-camera-color)",
          flag, name);
    ablate.*(hit->second) = true;
  }
  return ablate;
}

namespace {

struct Preset {
  std::string_view name;
  int iters;
  std::size_t cap;
};

const std::vector<Preset>& presets() {
  static const std::vector<Preset> table = {
      {"fast", 5000, 100000},
      {"default", TrainConfig{}.iters, TrainConfig{}.cap},
      {"quality", 30000, 600000},
  };
  return table;
}

}  // namespace

std::string describe_presets() {
  std::string text;
  for (const Preset& p : presets())
    text += fmt::format("{}{} ({} iterations, cap {})", text.empty() ? "" : ", ", p.name, p.iters,
                        p.cap);
  return text;
}

TrainConfig with_preset(TrainConfig config, const std::string& name, const std::string& flag) {
  for (const Preset& p : presets())
    if (p.name == name) {
      config.iters = p.iters, config.cap = p.cap;
      return config;
    }
  fail("{}: unknown preset '{}'; known: {}", flag, name, describe_presets());
}

int TrainConfig::scaled(int iteration) const {
  constexpr double kPaperIterations = 20000;
  if (!scale_schedule) return iteration;
  return std::max(1, int(std::lround(iteration * double(iters) / kPaperIterations)));
}

model::ModelConfig TrainConfig::model_config() const {
  model::ModelConfig m;
  m.representation = stgs_baseline ? model::Representation::kStgs : model::Representation::kRetime;
  m.trajectory =
      ablate.linear ? model::TrajectoryKind::kLinear : model::TrajectoryKind::kCatmullRom;
  m.gamma = gamma;
  m.sh_degree = 0;
  return m;
}

std::string to_json(const TrainConfig& config) {
  return nlohmann::json(config).dump(2);
}

TrainConfig config_from_json(const std::string& text, TrainConfig config, const std::string& what) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail("{}: malformed JSON: {}", what, e.what());
  }
  if (!j.is_object()) fail("{}: the config must be a JSON object", what);
  const nlohmann::json known = config;
  for (const auto& [key, value] : j.items()) {
    if (!known.contains(key)) fail("{}: unknown config key '{}'", what, key);
    if (key == "ablate")
      for (const auto& [k, v] : value.items())
        if (!known["ablate"].contains(k)) fail("{}: unknown ablation '{}'", what, k);
  }
  nlohmann::json merged = known;
  merged.merge_patch(j);
  try {
    config = merged.get<TrainConfig>();
  } catch (const nlohmann::json::exception& e) {
    fail("{}: a config value has the wrong type: {}", what, e.what());
  }
  const nlohmann::json check = config;
  for (const auto& [key, value] : check.items())
    if (value.is_number_float() && !std::isfinite(value.get<double>()))
      fail("{}: '{}' is not finite", what, key);
  if (config.iters < 1) fail("{}: 'iters' must be >= 1, got {}", what, config.iters);
  if (config.cap < 1) fail("{}: 'cap' must be >= 1", what);
  if (!(config.gamma > 0)) fail("{}: 'gamma' must be > 0", what);
  return config;
}

}  // namespace retimegs::train
