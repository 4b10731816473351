#include "retimegs/train/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <optional>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/escape_control_chars.hpp"
#include "retimegs/model/sh.hpp"

namespace retimegs::train {

namespace {

using nlohmann::json;

// Iteration counts, milestones and the cap fit an int with room for scaling.
constexpr double kMaxInteger = 1e9;
constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr Range kCount{1, kMaxInteger};       // iterations, periods (divisors), the cap
constexpr Range kMilestone{0, kMaxInteger};   // an iteration
constexpr Range kCountOrAll{0, kMaxInteger};  // a count, 0 meaning no limit
constexpr Range kNonNegative{0, kInf};        // thresholds
// Adam moves a parameter by about its rate per step: a rate above 1 (a scene extent per step for
// the means, a factor e for the scales) cannot converge and is a typo (1e308 fails with NaNs).
constexpr Range kRate{0, 1};
// Loss weights: the image loss is at most 1 per pixel; a weight beyond 100 leaves it no say.
constexpr double kMaxWeight = 100;
constexpr Range kWeight{0, kMaxWeight};
constexpr Range kPositiveWeight{0, kMaxWeight, true};  // the flow weight decays log-linearly
constexpr Range kFactor{0, 1, true};                   // a decay's final factor
constexpr Range kOpacity{0, 1, false, true};

// The tables of docs/formats.md, by heading.
constexpr std::string_view kRun = "**Run**";
constexpr std::string_view kSchedule = "**Schedule**";
constexpr std::string_view kRates = "**Learning rates** (Adam, β = 0.9 / 0.999, ε = 1e-15)";
constexpr std::string_view kLosses = "**Losses and model**";
constexpr std::string_view kCameras =
    "**Camera refinement** (docs/method.md, \"Camera refinement\")";
constexpr std::string_view kDensity = "**Primitive budget and density control**";
constexpr std::string_view kPaper =
    "**The paper's readings** (each `false` by default; `--preset paper` sets them and "
    "`ablate.no_static_init`; docs/method.md, \"Departures from the paper\")";
constexpr std::string_view kAblate =
    "**`ablate`**, an object (`--ablate` adds to it; each key with `-` for `_` is an `--ablate` "
    "name)";

// seed and cap share the member type of 64-bit unsigned keys.
static_assert(std::is_same_v<std::size_t, std::uint64_t>);

// Every key of TrainConfig, once. E is the scene extent, Δt the spacing of the training frames;
// "scaled" marks a milestone given for 20 000 iterations (TrainConfig::scaled).
constexpr ConfigKey kKeys[] = {
    {"iters", &TrainConfig::iters, kCount, kRun, "iterations (`--iters`, `--preset`)"},
    {"seed", &TrainConfig::seed, std::nullopt, kRun,
     "random seed (`--seed`); the same seed and thread count give the same model"},
    {"stgs_baseline", &TrainConfig::stgs_baseline, std::nullopt, kRun,
     "train the SpacetimeGaussians representation (`--baseline stgs`)"},
    {"scale_schedule", &TrainConfig::scale_schedule, std::nullopt, kRun,
     "scale the milestones by iters / 20 000 (at least 1)"},
    {"checkpoint_every", &TrainConfig::checkpoint_every, kCount, kRun,
     "iterations between checkpoints (not scaled)"},
    {"checkpoint_keep", &TrainConfig::checkpoint_keep, kCountOrAll, kRun,
     "checkpoints kept: writing one removes all but the latest this many; 0 keeps all"},

    {"sh_degree_every", &TrainConfig::sh_degree_every, kCount, kSchedule,
     "scaled; the active SH degree is min(max_sh_degree, iteration / this)"},
    {"max_sh_degree", &TrainConfig::max_sh_degree, Range{0, model::kMaxShDegree}, kSchedule,
     "highest SH degree trained"},
    {"lr_decay_start", &TrainConfig::lr_decay_start, kMilestone, kSchedule,
     "scaled; from here every learning rate decays exponentially …"},
    {"lr_decay_final", &TrainConfig::lr_decay_final, kFactor, kSchedule,
     "… to this factor at the last iteration"},
    {"flow_decay_until", &TrainConfig::flow_decay_until, kCount, kSchedule,
     "scaled; the flow weight reaches `flow_weight_end` here and stays (`flow_hold`: starts to "
     "decay here)"},
    {"relocate_every", &TrainConfig::relocate_every, kCount, kSchedule,
     "scaled; relocation and growth period"},
    {"relocate_start", &TrainConfig::relocate_start, kMilestone, kSchedule,
     "scaled; relocation runs at iterations strictly after this …"},
    {"relocate_stop", &TrainConfig::relocate_stop, kMilestone, kSchedule,
     "scaled; … and strictly before this (scaled, it lies beyond the last iteration, so "
     "relocation runs to the end)"},
    {"stretch_every", &TrainConfig::stretch_every, kCount, kSchedule,
     "scaled; dynamic stretching period (also its first iteration); never at the last iteration"},

    {"lr_means", &TrainConfig::lr_means, kRate, kRates, "`mu`, × E"},
    {"lr_means_final", &TrainConfig::lr_means_final, kFactor, kRates,
     "factor the `mu` and `velocity` rates decay to (exponentially) over the run"},
    // The means' rate: a faster one helps scenes with large, exact motion but hurts captures with
    // noisy flow and small motion (bench/velocity_lr.sh; README, Results).
    {"lr_velocity", &TrainConfig::lr_velocity, kRate, kRates, "`velocity` (v1, v2, v3), × E ÷ Δt"},
    {"lr_scales", &TrainConfig::lr_scales, kRate, kRates, "`log_scale`"},
    {"lr_quats", &TrainConfig::lr_quats, kRate, kRates, "`q0`"},
    {"lr_quat_rate", &TrainConfig::lr_quat_rate, kRate, kRates, "`q1` (rotation rate), ÷ Δt"},
    {"lr_opacities", &TrainConfig::lr_opacities, kRate, kRates, "`opacity_logit`"},
    {"lr_sh0", &TrainConfig::lr_sh0, kRate, kRates, "SH DC coefficients"},
    {"lr_sh_rest_factor", &TrainConfig::lr_sh_rest_factor, kRate, kRates,
     "factor of `lr_sh0` for the higher SH bands"},
    {"lr_temporal_center", &TrainConfig::lr_temporal_center, kRate, kRates,
     "STGS only: temporal centre μ_τ"},
    {"lr_temporal_scale", &TrainConfig::lr_temporal_scale, kRate, kRates,
     "STGS only: log temporal scale"},
    {"lr_camera_color", &TrainConfig::lr_camera_color, kRate, kRates,
     "per-camera colour maps m and c"},

    {"ssim_lambda", &TrainConfig::ssim_lambda, Range{0, 1}, kLosses,
     "image loss (1 − λ)·L1 + λ·(1 − SSIM)"},
    {"flow_weight_start", &TrainConfig::flow_weight_start, kPositiveWeight, kLosses,
     "flow-loss weight at iteration 0 …"},
    {"flow_weight_end", &TrainConfig::flow_weight_end, kPositiveWeight, kLosses,
     "… falling log-linearly to this at `flow_decay_until` (`flow_hold`: at the last iteration)"},
    {"opacity_reg", &TrainConfig::opacity_reg, kWeight, kLosses,
     "weight of the mean opacity regulariser"},
    {"scale_reg", &TrainConfig::scale_reg, kWeight, kLosses,
     "weight of the mean scale regulariser"},
    {"random_background", &TrainConfig::random_background, std::nullopt, kLosses,
     "each step composites its renders over a random colour, which the target takes where its "
     "mask says background, so that alpha is coverage (`render --alpha` a matte); `null`: on for "
     "a capture without masks (the run records the value it used)"},
    // An edge wider than the clip makes every primitive's opacity follow the edge alone.
    {"gamma", &TrainConfig::gamma, Range{0, 1, true}, kLosses,
     "sharpness of the temporal-opacity edges, in normalised clip time (stored in the model)"},

    {"refine_cameras", &TrainConfig::refine_cameras, std::nullopt, kCameras,
     "learn a pose correction (rotation about the camera's centre, shift) per training camera; "
     "`null`: on for a scene whose calibration is the user's (scene.json `calibration`), off for "
     "a lab calibration (the run records the value it used)"},
    {"lr_camera_pose", &TrainConfig::lr_camera_pose, kRate, kCameras,
     "the corrections' rotation (radians) and shift (× E)"},
    {"camera_refine_start", &TrainConfig::camera_refine_start, kMilestone, kCameras,
     "scaled; the corrections move at iterations after this"},
    {"camera_pose_reg", &TrainConfig::camera_pose_reg, kWeight, kCameras,
     "weight of |ω|² + |τ / E|² summed over the training cameras: a pull toward the given "
     "calibration where the images do not decide"},
    {"refine_clocks", &TrainConfig::refine_clocks, std::nullopt, kCameras,
     "learn a correction of each training camera's clock (a time shift of all its frames) for "
     "the cameras off the scene's clock (scene.json `time_offset` or `frame_times`); `null`: on "
     "for a scene whose clocks were estimated (scene.json `clocks`), off for given ones (the run "
     "records the value it used)"},
    {"lr_time_offset", &TrainConfig::lr_time_offset, kRate, kCameras,
     "the clock corrections, in frames"},
    {"clock_refine_start", &TrainConfig::clock_refine_start, kMilestone, kCameras,
     "scaled; the clock corrections move at iterations after this (late: the in-between states "
     "are fitted first)"},

    {"cap", &TrainConfig::cap, kCount, kDensity,
     "most primitives (`--cap`, `--preset`); initial seeds above it are subsampled"},
    {"init_opacity", &TrainConfig::init_opacity, Range{0, 1, true, true}, kDensity,
     "opacity of the initial primitives"},
    {"min_opacity", &TrainConfig::min_opacity, kOpacity, kDensity,
     "relocation moves primitives with σ at or below this"},
    {"growth", &TrainConfig::growth, Range{1, kInf}, kDensity,
     "each relocation grows the count to min(cap, ⌊growth · N⌋)"},
    // train::faint_short_rows.
    {"final_prune_opacity", &TrainConfig::final_prune_opacity, kOpacity, kDensity,
     "after training, primitives below this opacity whose window spans one interval are removed; "
     "0 keeps them"},
    {"stretch_distance", &TrainConfig::stretch_distance, kNonNegative, kDensity,
     "stretching: largest neighbour distance, × E"},
    {"stretch_color", &TrainConfig::stretch_color, kNonNegative, kDensity,
     "stretching: largest DC colour difference per channel; initialisation: largest change of a "
     "still point's look"},
    {"stretch_speed", &TrainConfig::stretch_speed, kNonNegative, kDensity,
     "stretching and initialisation: largest speed of static content, × E per frame"},

    {"flow_hold", &TrainConfig::flow_hold, std::nullopt, kPaper,
     "the flow weight holds at `flow_weight_start` until `flow_decay_until`, then decays "
     "exponentially to `flow_weight_end` at the last iteration; false: it decays from iteration 0"},
    {"relocate_per_duration", &TrainConfig::relocate_per_duration, std::nullopt, kPaper,
     "relocation and growth draw sources ∝ σ/(τ_l + τ_r); false: ∝ σ·(τ_l + τ_r)"},
    {"init_average_lifts", &TrainConfig::init_average_lifts, std::nullopt, kPaper,
     "initialisation: a point's 3-D displacement is the mean of each view's flow lifted at its "
     "depth; false: the least-squares fit over the views"},
    {"init_mean_velocity", &TrainConfig::init_mean_velocity, std::nullopt, kPaper,
     "initialisation: v1 = v2 = v3 = the mean of the forward and the negated backward "
     "displacement; false: each control point where the flows put the point"},
    {"tie_end_velocities", &TrainConfig::tie_end_velocities, std::nullopt, kPaper,
     "v1 of the clip's first interval and v3 of its last follow v2 after every step; false: they "
     "keep their initial values"},

    {"no_flow_init", &Ablations::no_flow_init, std::nullopt, kAblate,
     "velocities start at 0, points unmoved (static content found as without it)"},
    {"no_flow_loss", &Ablations::no_flow_loss, std::nullopt, kAblate, "flow weight 0"},
    {"no_triple", &Ablations::no_triple, std::nullopt, kAblate,
     "no image loss on the group renders (their flow loss stays)"},
    {"no_stretch", &Ablations::no_stretch, std::nullopt, kAblate, "no dynamic stretching"},
    {"linear", &Ablations::linear, std::nullopt, kAblate, "straight-line trajectories"},
    {"no_static_init", &Ablations::no_static_init, std::nullopt, kAblate,
     "still points are not merged into long-lived primitives"},
    {"no_camera_color", &Ablations::no_camera_color, std::nullopt, kAblate,
     "no per-camera colour maps"},
};

// The value `member` names in `config` (TrainConfig or const TrainConfig).
template <class Config, class T>
auto& field(Config& config, T TrainConfig::*member) {
  return config.*member;
}
template <class Config>
auto& field(Config& config, bool Ablations::*member) {
  return config.ablate.*member;
}

// The key's name in messages: "linear" inside "ablate" is 'ablate.linear'.
std::string path(const ConfigKey& key) {
  return key.is_ablation() ? fmt::format("ablate.{}", key.name) : std::string(key.name);
}

// The key's `--ablate` name.
std::string flag_name(const ConfigKey& key) {
  std::string name(key.name);
  std::replace(name.begin(), name.end(), '_', '-');
  return name;
}

const ConfigKey* find_key(std::string_view name, bool ablation) {
  const auto hit = std::find_if(std::begin(kKeys), std::end(kKeys), [&](const ConfigKey& k) {
    return k.name == name && k.is_ablation() == ablation;
  });
  return hit == std::end(kKeys) ? nullptr : hit;
}

// Sets `key` to `value`, refusing a value of another JSON type and an integer an int cannot hold:
// the JSON library would truncate 2.5 to an integer key, wrap -1 into the unsigned cap and turn
// 1e20 into INT_MIN.
void set_key(const ConfigKey& key, const json& value, TrainConfig& config,
             const std::string& what) {
  std::visit(
      [&](auto member) {
        auto& target = field(config, member);
        using T = std::remove_reference_t<decltype(target)>;
        if constexpr (std::is_same_v<T, std::optional<bool>>) {
          if (!value.is_boolean() && !value.is_null())
            fail("{}: '{}' must be true, false or null, got {}", what, path(key), value.dump());
          target = value.is_null() ? std::nullopt : std::optional<bool>(value.get<bool>());
        } else if constexpr (std::is_same_v<T, bool>) {
          if (!value.is_boolean())
            fail("{}: '{}' must be true or false, got {}", what, path(key), value.dump());
        } else if constexpr (std::is_integral_v<T>) {
          if (!value.is_number_integer())
            fail("{}: '{}' must be an integer, got {}", what, path(key), value.dump());
          // A key with a range counts iterations or primitives; one without (the seed) takes any
          // value of its type.
          if (key.range &&
              (value.is_number_unsigned() ? value.get<std::uint64_t>() > kMaxInteger
                                          : std::abs(value.get<double>()) > kMaxInteger))
            fail("{}: '{}' = {} is out of range", what, path(key), value.dump());
          if (std::is_unsigned_v<T> && !value.is_number_unsigned() && value.get<std::int64_t>() < 0)
            fail("{}: '{}' must be >= 0, got {}", what, path(key), value.dump());
        } else {
          if (!value.is_number())
            fail("{}: '{}' must be a number, got {}", what, path(key), value.dump());
        }
        if constexpr (!std::is_same_v<T, std::optional<bool>>) target = value.get<T>();
      },
      key.member);
}

// `config` with the keys of the object `keys` set. Every key is known before any is set.
TrainConfig set_keys(const json& keys, TrainConfig config, const std::string& what) {
  if (!keys.is_object()) fail("{}: the config must be a JSON object", what);
  std::vector<std::pair<const ConfigKey*, const json*>> found;
  for (const auto& [name, value] : keys.items()) {
    if (name != "ablate") {
      found.emplace_back(find_key(name, false), &value);
      // Escaped: a NUL in the key would end what() there.
      if (!found.back().first)
        fail("{}: unknown config key '{}'", what, escape_control_chars(name));
      continue;
    }
    if (!value.is_object()) fail("{}: 'ablate' must be an object, got {}", what, value.dump());
    for (const auto& [ablation, flag] : value.items()) {
      found.emplace_back(find_key(ablation, true), &flag);
      if (!found.back().first)
        fail("{}: unknown ablation '{}'", what, escape_control_chars(ablation));
    }
  }
  for (const auto& [key, value] : found) set_key(*key, *value, config, what);
  return config;
}

}  // namespace

bool Range::contains(double value) const {
  return (open_low ? value > low : value >= low) && (open_high ? value < high : value <= high);
}

std::string to_string(const Range& range) {
  return fmt::format("{}{}, {}{}", range.open_low ? "(" : "[", range.low, range.high,
                     range.open_high ? ")" : "]");
}

std::span<const ConfigKey> config_keys() {
  return kKeys;
}

std::string ablation_names() {
  std::string names;
  for (const ConfigKey& key : kKeys)
    if (key.is_ablation()) names += (names.empty() ? "" : ", ") + flag_name(key);
  return names;
}

Ablations parse_ablations(const std::string& list, Ablations ablate, const std::string& flag) {
  if (list.empty()) return ablate;
  std::vector<std::string> names;
  for (std::size_t start = 0; start <= list.size();) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    names.push_back(list.substr(start, comma - start));
    if (names.back().empty()) fail("{}: empty item in '{}'", flag, list);
    start = comma + 1;
  }
  for (const std::string& name : names) {
    const auto* hit = std::find_if(std::begin(kKeys), std::end(kKeys), [&](const ConfigKey& k) {
      return k.is_ablation() && flag_name(k) == name;
    });
    if (hit == std::end(kKeys))
      fail("{}: unknown ablation '{}' ({})", flag, name, ablation_names());
    ablate.*std::get<bool Ablations::*>(hit->member) = true;
  }
  return ablate;
}

namespace {

// A preset sets keys of the config, as a --config file does; `note` says what else than the budget.
struct Preset {
  std::string_view name;
  json keys;
  std::string_view note;
};

const std::vector<Preset>& presets() {
  static const std::vector<Preset> table = [] {
    const json default_budget = {{"iters", TrainConfig{}.iters}, {"cap", TrainConfig{}.cap}};
    // The paper's reading wherever the paper states one (docs/method.md, "Departures from the
    // paper"), at the default budget: the paper's 20 000 steps, the project's cap.
    json paper = default_budget;
    for (const ConfigKey& key : kKeys)
      if (key.group == kPaper) paper[std::string(key.name)] = true;
    paper["ablate"] = {{"no_static_init", true}};
    return std::vector<Preset>{
        {"fast", {{"iters", 5000}, {"cap", 100000}}, ""},
        {"default", default_budget, ""},
        {"quality", {{"iters", 30000}, {"cap", 600000}}, ""},
        {"paper", paper, "; the paper's readings"},
    };
  }();
  return table;
}

}  // namespace

std::string describe_presets() {
  std::string text;
  for (const Preset& p : presets())
    text += fmt::format("{}{} ({} iterations, cap {}{})", text.empty() ? "" : ", ", p.name,
                        p.keys.at("iters").dump(), p.keys.at("cap").dump(), p.note);
  return text;
}

TrainConfig with_preset(TrainConfig config, const std::string& name, const std::string& flag) {
  for (const Preset& p : presets())
    if (p.name == name) return set_keys(p.keys, config, flag);
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
  json j;
  for (const ConfigKey& key : kKeys)
    std::visit(
        [&](auto member) {
          json& value = (key.is_ablation() ? j["ablate"] : j)[std::string(key.name)];
          const auto& v = field(config, member);
          if constexpr (std::is_same_v<std::remove_cvref_t<decltype(v)>, std::optional<bool>>)
            value = v ? json(*v) : json(nullptr);
          else
            value = v;
        },
        key.member);
  return j.dump(2);
}

TrainConfig config_from_json(const std::string& text, TrainConfig config, const std::string& what) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    fail("{}: malformed JSON: {}", what, e.what());
  }
  config = set_keys(j, config, what);
  check_config(config, what);
  return config;
}

void check_config(const TrainConfig& config, const std::string& what) {
  for (const ConfigKey& key : kKeys) {
    if (!key.range) continue;
    const double value = std::visit(
        [&](auto member) {
          const auto& v = field(config, member);
          if constexpr (std::is_arithmetic_v<std::remove_cvref_t<decltype(v)>>)
            return double(v);
          else
            return 0.0;  // a key of another type has no range
        },
        key.member);
    if (!key.range->contains(value))
      fail("{}: '{}' = {} must lie in {}", what, path(key), value, to_string(*key.range));
  }
}

}  // namespace retimegs::train
