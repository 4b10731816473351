#include "retimegs/train/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/model/sh.hpp"

namespace retimegs::train {

namespace {
// Iteration counts, milestones and the cap fit an int with room for scaling.
constexpr double kMaxInteger = 1e9;
}  // namespace

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
  // Types first: the JSON library would truncate 2.5 to an integer key, wrap -1 into the
  // unsigned cap and turn 1e20 into INT_MIN.
  for (const auto& [key, value] : j.items()) {
    const nlohmann::json& like = known[key];
    if (key == "ablate") continue;
    if (like.is_boolean() && !value.is_boolean())
      fail("{}: '{}' must be true or false, got {}", what, key, value.dump());
    if (like.is_number_integer()) {  // signed or unsigned
      if (!value.is_number_integer())
        fail("{}: '{}' must be an integer, got {}", what, key, value.dump());
      const bool any_size = key == "seed";  // a 64-bit generator seed
      if (!any_size && (value.is_number_unsigned() ? value.get<std::uint64_t>() > kMaxInteger
                                                   : std::abs(value.get<double>()) > kMaxInteger))
        fail("{}: '{}' = {} is out of range", what, key, value.dump());
      if (like.is_number_unsigned() && !value.is_number_unsigned() && value.get<std::int64_t>() < 0)
        fail("{}: '{}' must be >= 0, got {}", what, key, value.dump());
    }
    if (like.is_number_float() && !value.is_number())
      fail("{}: '{}' must be a number, got {}", what, key, value.dump());
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
  check_config(config, what);
  return config;
}

void check_config(const TrainConfig& c, const std::string& what) {
  // [low, high] with an open end where `open_*`; every rule names its key.
  const auto range = [&](const char* key, double v, double low, double high, bool open_low = false,
                         bool open_high = false) {
    const bool ok = (open_low ? v > low : v >= low) && (open_high ? v < high : v <= high);
    if (!ok)
      fail("{}: '{}' = {} must lie in {}{}, {}{}", what, key, v, open_low ? "(" : "[", low, high,
           open_high ? ")" : "]");
  };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  range("iters", c.iters, 1, kMaxInteger);
  range("cap", double(c.cap), 1, kMaxInteger);
  range("sh_degree_every", c.sh_degree_every, 1, kMaxInteger);  // a divisor
  range("max_sh_degree", c.max_sh_degree, 0, model::kMaxShDegree);
  range("lr_decay_start", c.lr_decay_start, 0, kMaxInteger);
  range("lr_decay_final", c.lr_decay_final, 0, 1, true);
  range("flow_decay_until", c.flow_decay_until, 1, kMaxInteger);
  range("relocate_every", c.relocate_every, 1, kMaxInteger);  // a divisor
  range("relocate_start", c.relocate_start, 0, kMaxInteger);
  range("relocate_stop", c.relocate_stop, 0, kMaxInteger);
  range("stretch_every", c.stretch_every, 1, kMaxInteger);        // a divisor
  range("checkpoint_every", c.checkpoint_every, 1, kMaxInteger);  // a divisor
  for (const auto& [key, v] : {std::pair{"lr_means", c.lr_means},
                               {"lr_velocity", c.lr_velocity},
                               {"lr_scales", c.lr_scales},
                               {"lr_quats", c.lr_quats},
                               {"lr_quat_rate", c.lr_quat_rate},
                               {"lr_opacities", c.lr_opacities},
                               {"lr_sh0", c.lr_sh0},
                               {"lr_sh_rest_factor", c.lr_sh_rest_factor},
                               {"lr_temporal_center", c.lr_temporal_center},
                               {"lr_temporal_scale", c.lr_temporal_scale},
                               {"lr_camera_color", c.lr_camera_color},
                               {"opacity_reg", c.opacity_reg},
                               {"scale_reg", c.scale_reg},
                               {"stretch_distance", c.stretch_distance},
                               {"stretch_color", c.stretch_color},
                               {"stretch_speed", c.stretch_speed}})
    range(key, v, 0, kInf);
  range("lr_means_final", c.lr_means_final, 0, 1, true);
  range("ssim_lambda", c.ssim_lambda, 0, 1);
  // The flow weight decays log-linearly between the two: both must be positive.
  range("flow_weight_start", c.flow_weight_start, 0, kInf, true);
  range("flow_weight_end", c.flow_weight_end, 0, kInf, true);
  range("gamma", c.gamma, 0, kInf, true);
  range("min_opacity", c.min_opacity, 0, 1, false, true);
  range("final_prune_opacity", c.final_prune_opacity, 0, 1, false, true);
  range("init_opacity", c.init_opacity, 0, 1, true, true);
  range("growth", c.growth, 1, kInf);
}

}  // namespace retimegs::train
