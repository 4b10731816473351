#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/train/config.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {

using nlohmann::json;

TEST(ParseAblations, SetsTheNamedAblationsOnTopOfTheGivenOnes) {
  Ablations from_file;
  from_file.no_stretch = true;
  const Ablations a = parse_ablations("linear,no-flow-init", from_file, "--ablate");
  EXPECT_TRUE(a.linear);
  EXPECT_TRUE(a.no_flow_init);
  EXPECT_TRUE(a.no_stretch);
  EXPECT_FALSE(a.no_flow_loss);
  EXPECT_FALSE(a.no_triple);
  EXPECT_FALSE(a.no_static_init);
  EXPECT_TRUE(parse_ablations("no-static-init", {}, "--ablate").no_static_init);
  EXPECT_FALSE(a.no_camera_color);
  EXPECT_TRUE(parse_ablations("no-camera-color", {}, "--ablate").no_camera_color);

  const Ablations none = parse_ablations("", {}, "--ablate");
  EXPECT_FALSE(none.no_flow_init || none.no_flow_loss || none.no_triple || none.no_stretch ||
               none.linear || none.no_static_init || none.no_camera_color);
}

TEST(ParseAblations, RefusesEmptyItemsAndUnknownNames) {
  EXPECT_EQ(test::message_of([] { parse_ablations("linear,", {}, "--ablate"); }),
            "--ablate: empty item in 'linear,'");
  // Every item is checked for emptiness before any name is looked up.
  EXPECT_EQ(test::message_of([] { parse_ablations("bogus,,linear", {}, "--ablate"); }),
            "--ablate: empty item in 'bogus,,linear'");
  EXPECT_EQ(test::message_of([] { parse_ablations("no_triple", {}, "--ablate"); }),
            "--ablate: unknown ablation 'no_triple' (no-flow-init, no-flow-loss, no-triple, "
            "no-stretch, linear, no-static-init, no-camera-color)");
}

TEST(Presets, SetIterationsAndBudgetOnlyAndDefaultIsTheConfigsOwn) {
  TrainConfig base;
  base.ssim_lambda = 0.3;
  const TrainConfig fast = with_preset(base, "fast", "--preset");
  const TrainConfig quality = with_preset(base, "quality", "--preset");
  EXPECT_LT(fast.iters, base.iters);
  EXPECT_LT(fast.cap, base.cap);
  EXPECT_GT(quality.iters, base.iters);
  EXPECT_GT(quality.cap, base.cap);
  EXPECT_EQ(fast.ssim_lambda, 0.3);  // nothing else changes
  const TrainConfig standard = with_preset(fast, "default", "--preset");
  EXPECT_EQ(standard.iters, 20000);  // the paper's schedule
  EXPECT_EQ(standard.iters, TrainConfig{}.iters);
  EXPECT_EQ(standard.cap, TrainConfig{}.cap);
  EXPECT_EQ(test::message_of([] { with_preset({}, "slow", "--preset"); }),
            "--preset: unknown preset 'slow'; known: " + describe_presets());
  EXPECT_NE(describe_presets().find("quality (30000 iterations"), std::string::npos);
}

// `--preset paper`: the default budget and the paper's reading of every departure that has one;
// every other key as it was.
TEST(Presets, PaperSelectsThePapersReadingsAtTheDefaultBudget) {
  TrainConfig base = with_preset({}, "fast", "--preset");
  base.ssim_lambda = 0.3;
  const TrainConfig paper = with_preset(base, "paper", "--preset");
  TrainConfig expected = base;
  expected.iters = TrainConfig{}.iters;
  expected.cap = TrainConfig{}.cap;
  expected.flow_hold = expected.relocate_per_duration = expected.init_average_lifts =
      expected.init_mean_velocity = expected.tie_end_velocities = true;
  expected.ablate.no_static_init = true;
  EXPECT_EQ(to_json(paper), to_json(expected));
  EXPECT_NE(describe_presets().find("paper (20000 iterations, cap 200000; the paper's readings)"),
            std::string::npos);
}

// Every config value is range- and type-checked, with a message naming the key and the value:
// values that crashed training (zero divisors, SH degree 10), wrapped (cap -1), truncated
// (iters 2.5) or trained on a NaN loss (flow_weight_start 0).
TEST(ConfigFromJson, RefusesValuesOutsideTheirRangeNamingTheKey) {
  const struct {
    const char* json;
    const char* says;
  } cases[] = {
      {R"({"checkpoint_every": 0})", "'checkpoint_every' = 0 must lie in [1"},
      {R"({"scale_schedule": false, "relocate_every": 0})", "'relocate_every' = 0"},
      {R"({"scale_schedule": false, "sh_degree_every": 0})", "'sh_degree_every' = 0"},
      {R"({"scale_schedule": false, "stretch_every": 0})", "'stretch_every' = 0"},
      {R"({"max_sh_degree": 10})", "'max_sh_degree' = 10 must lie in [0, 3]"},
      {R"({"max_sh_degree": -1})", "'max_sh_degree' = -1"},
      {R"({"cap": -1})", "'cap' must be >= 0, got -1"},
      {R"({"cap": 0})", "'cap' = 0"},
      {R"({"iters": 2.5})", "'iters' must be an integer, got 2.5"},
      {R"({"iters": 100000000000000000000})", "'iters' must be an integer"},
      {R"({"iters": 10000000000})", "'iters' = 10000000000 is out of range"},
      // std::abs of the smallest int64 was undefined (fuzz/).
      {R"({"iters": -9223372036854775808})", "'iters' = -9223372036854775808 is out of range"},
      {R"({"growth": -1})", "'growth' = -1 must lie in [1, inf]"},
      {R"({"min_opacity": 2})", "'min_opacity' = 2 must lie in [0, 1)"},
      {R"({"lr_means": -0.1})", "'lr_means' = -0.1"},
      {R"({"flow_weight_start": 0})", "'flow_weight_start' = 0 must lie in (0"},
      {R"({"init_opacity": 1})", "'init_opacity' = 1"},
      {R"({"ssim_lambda": 1.5})", "'ssim_lambda' = 1.5"},
      {R"({"gamma": 0})", "'gamma' = 0"},
      {R"({"scale_schedule": 1})", "'scale_schedule' must be true or false, got 1"},
      {R"({"lr_sh0": "fast"})", "'lr_sh0' must be a number, got \"fast\""},
  };
  for (const auto& c : cases) {
    const std::string message =
        test::message_of([&] { config_from_json(c.json, TrainConfig{}, "cfg.json"); });
    EXPECT_NE(message.find("cfg.json: "), std::string::npos) << c.json << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.json << ": " << message;
  }
  // The defaults, the presets and values at the edges of their ranges are accepted.
  EXPECT_NO_THROW(check_config(TrainConfig{}, "defaults"));
  for (const char* preset : {"fast", "default", "quality"})
    EXPECT_NO_THROW(check_config(with_preset(TrainConfig{}, preset, "--preset"), preset));
  EXPECT_NO_THROW(config_from_json(
      R"({"min_opacity": 0, "final_prune_opacity": 0, "growth": 1, "ssim_lambda": 1,
          "max_sh_degree": 0, "lr_means": 0, "iters": 1, "cap": 1,
          "seed": 18446744073709551615})",
      TrainConfig{}, "edges"));
}

// RUN/config.json, checkpoints and model.rgs hold to_json's text: its key order and number
// formatting are part of the file formats. The default config's text, byte for byte.
constexpr const char* kDefaultJson = R"json({
  "ablate": {
    "linear": false,
    "no_camera_color": false,
    "no_flow_init": false,
    "no_flow_loss": false,
    "no_static_init": false,
    "no_stretch": false,
    "no_triple": false
  },
  "camera_pose_reg": 0.0001,
  "camera_refine_start": 1000,
  "cap": 200000,
  "checkpoint_every": 1000,
  "checkpoint_keep": 2,
  "clock_refine_start": 10000,
  "final_prune_opacity": 0.03,
  "flow_decay_until": 12000,
  "flow_hold": false,
  "flow_weight_end": 1e-06,
  "flow_weight_start": 0.5,
  "gamma": 0.005,
  "growth": 1.05,
  "init_average_lifts": false,
  "init_mean_velocity": false,
  "init_opacity": 0.1,
  "iters": 20000,
  "lr_camera_color": 0.001,
  "lr_camera_pose": 0.0005,
  "lr_decay_final": 0.1,
  "lr_decay_start": 18000,
  "lr_means": 0.00016,
  "lr_means_final": 0.01,
  "lr_opacities": 0.05,
  "lr_quat_rate": 0.001,
  "lr_quats": 0.001,
  "lr_scales": 0.005,
  "lr_sh0": 0.0025,
  "lr_sh_rest_factor": 0.05,
  "lr_temporal_center": 0.0001,
  "lr_temporal_scale": 0.03,
  "lr_time_offset": 0.005,
  "lr_velocity": 0.00016,
  "max_sh_degree": 3,
  "min_opacity": 0.01,
  "opacity_reg": 0.01,
  "random_background": null,
  "refine_cameras": null,
  "refine_clocks": null,
  "relocate_every": 100,
  "relocate_per_duration": false,
  "relocate_start": 500,
  "relocate_stop": 25000,
  "scale_reg": 0.1,
  "scale_schedule": true,
  "seed": 0,
  "sh_degree_every": 1000,
  "ssim_lambda": 0.2,
  "stgs_baseline": false,
  "stretch_color": 0.1,
  "stretch_distance": 0.01,
  "stretch_every": 3000,
  "stretch_speed": 0.002,
  "tie_end_velocities": false
})json";

// `json_text` with the value of its (only) key `key` replaced by `value`.
std::string with_value(std::string json_text, const std::string& key, const std::string& value) {
  const std::string quoted = "\"" + key + "\": ";
  const std::size_t at = json_text.find(quoted);
  EXPECT_NE(at, std::string::npos) << key;
  if (at == std::string::npos) return json_text;
  const std::size_t start = at + quoted.size();
  return json_text.replace(start, json_text.find_first_of(",\n", start) - start, value);
}

TEST(ConfigToJson, WritesTheSameTextAsEver) {
  EXPECT_EQ(to_json(TrainConfig{}), kDefaultJson);
  EXPECT_EQ(to_json(with_preset(TrainConfig{}, "default", "--preset")), kDefaultJson);
  EXPECT_EQ(to_json(with_preset(TrainConfig{}, "fast", "--preset")),
            with_value(with_value(kDefaultJson, "cap", "100000"), "iters", "5000"));
  EXPECT_EQ(to_json(with_preset(TrainConfig{}, "quality", "--preset")),
            with_value(with_value(kDefaultJson, "cap", "600000"), "iters", "30000"));
  // Flags set, the largest seed, and numbers whose shortest round-trip form is long or in
  // exponent notation.
  TrainConfig odd;
  odd.seed = 18446744073709551615u;
  odd.ablate.linear = odd.ablate.no_camera_color = true;
  odd.stgs_baseline = true;
  odd.scale_schedule = false;
  odd.lr_means = 1.0 / 3;
  odd.gamma = 1e-300;
  odd.growth = 1e20;
  odd.cap = 1000000000;
  odd.iters = 1;
  odd.ssim_lambda = 0.1 + 0.2;
  odd.max_sh_degree = 0;
  std::string expected = kDefaultJson;
  for (const auto& [key, value] : std::initializer_list<std::pair<const char*, const char*>>{
           {"linear", "true"},
           {"no_camera_color", "true"},
           {"seed", "18446744073709551615"},
           {"stgs_baseline", "true"},
           {"scale_schedule", "false"},
           {"lr_means", "0.3333333333333333"},
           {"gamma", "1e-300"},
           {"growth", "1e+20"},
           {"cap", "1000000000"},
           {"iters", "1"},
           {"ssim_lambda", "0.30000000000000004"},
           {"max_sh_degree", "0"}})
    expected = with_value(expected, key, value);
  EXPECT_EQ(to_json(odd), expected);
}
// The key's value in `config_json` (to_json's object, or one in its shape).
const json& value_in(const json& config_json, const ConfigKey& key) {
  return (key.is_ablation() ? config_json.at("ablate") : config_json).at(std::string(key.name));
}
json& value_in(json& config_json, const ConfigKey& key) {
  return (key.is_ablation() ? config_json["ablate"] : config_json)[std::string(key.name)];
}

// The name messages give the key: an ablation's is 'ablate.<name>'.
std::string quoted_path(const ConfigKey& key) {
  return fmt::format("'{}{}'", key.is_ablation() ? "ablate." : "", key.name);
}

// A value of `key` other than `default_value`, of its type and inside its range.
json other_value(const ConfigKey& key, const json& default_value) {
  if (default_value.is_boolean()) return !default_value.get<bool>();
  if (default_value.is_null()) return true;  // a flag whose default depends on the capture
  const double d = default_value.get<double>();
  for (double v : {d + 1, d - 1, d / 2}) {
    if (key.range && !key.range->contains(v)) continue;
    if (!default_value.is_number_integer()) return v;
    if (v == std::floor(v) && v >= 0) return std::uint64_t(v);
  }
  ADD_FAILURE() << key.name << ": no other value in range";
  return default_value;
}

// The members of an aggregate: the most initialisers its braces take, as AnyValue converts to the
// type of any member (a nested aggregate included, so its braces are not elided).
struct AnyValue {
  template <class T>
  operator T() const;
};
template <class T, class... Values>
constexpr std::size_t member_count() {
  if constexpr (requires { T{Values{}..., AnyValue{}}; })
    return member_count<T, Values..., AnyValue>();
  else
    return sizeof...(Values);
}

// A member added to TrainConfig without a key would be neither written, read nor checked.
TEST(ConfigKeys, NameEveryMemberOnce) {
  const auto keys = config_keys();
  std::size_t top_level = 0, ablations = 0;
  for (const ConfigKey& key : keys) ++(key.is_ablation() ? ablations : top_level);
  EXPECT_EQ(member_count<TrainConfig>(), top_level + 1);  // + the `ablate` object
  EXPECT_EQ(member_count<Ablations>(), ablations);
  for (std::size_t i = 0; i < keys.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      EXPECT_FALSE(keys[i].member == keys[j].member) << keys[i].name << ", " << keys[j].name;
      EXPECT_FALSE(keys[i].name == keys[j].name && keys[i].is_ablation() == keys[j].is_ablation())
          << keys[i].name;
    }
}

TEST(ConfigKeys, EveryKeyIsWrittenAndReadBack) {
  const json defaults = json::parse(to_json(TrainConfig{}));
  json changed = json::object();
  for (const ConfigKey& key : config_keys())
    value_in(changed, key) = other_value(key, value_in(defaults, key));
  const TrainConfig config = config_from_json(changed.dump(), TrainConfig{}, "changed.json");
  const json written = json::parse(to_json(config));
  for (const ConfigKey& key : config_keys())
    EXPECT_EQ(value_in(written, key), value_in(changed, key)) << key.name;
  EXPECT_EQ(written, changed);  // and no other key
  EXPECT_EQ(config_from_json(to_json(config), TrainConfig{}, "config.json"), config);
  EXPECT_EQ(config_from_json("{}", config, "empty.json"), config);
}

TEST(ConfigKeys, EveryKeyRefusesAWrongTypeAndValuesOutsideItsRange) {
  const json defaults = json::parse(to_json(TrainConfig{}));
  for (const ConfigKey& key : config_keys()) {
    const json& d = value_in(defaults, key);
    std::vector<std::string> bad = {"[]"};
    if (!d.is_null()) bad.push_back("null");
    if (d.is_boolean() || d.is_null()) bad.insert(bad.end(), {"1", "\"true\""});
    if (d.is_number_integer()) bad.insert(bad.end(), {"2.5", "\"1\"", "true", "1e20"});
    if (d.is_number_unsigned()) bad.push_back("-1");
    if (d.is_number_float()) bad.insert(bad.end(), {"\"1\"", "true"});
    if (key.range) {
      const Range& r = *key.range;
      bad.push_back(fmt::format("{}", r.open_low ? r.low : r.low - 1));
      if (std::isfinite(r.high))
        bad.push_back(fmt::format("{}", r.open_high ? r.high : r.high + 1));
    }
    for (const std::string& value : bad) {
      const std::string text = key.is_ablation()
                                   ? fmt::format(R"({{"ablate": {{"{}": {}}}}})", key.name, value)
                                   : fmt::format(R"({{"{}": {}}})", key.name, value);
      const std::string message =
          test::message_of([&] { config_from_json(text, TrainConfig{}, "bad.json"); });
      EXPECT_EQ(message.rfind("bad.json: ", 0), 0u) << text << ": " << message;
      EXPECT_NE(message.find(quoted_path(key)), std::string::npos) << text << ": " << message;
    }
  }
  EXPECT_EQ(test::message_of([] { config_from_json(R"({"ablate": true})", {}, "bad.json"); }),
            "bad.json: 'ablate' must be an object, got true");
}

// docs/formats.md's key tables, as config_keys() writes them.
std::string key_tables() {
  const json defaults = json::parse(to_json(TrainConfig{}));
  std::string text;
  std::string_view group;
  for (const ConfigKey& key : config_keys()) {
    if (key.group != group) {
      group = key.group;
      text +=
          fmt::format("\n{}\n\n| key | default | values | meaning |\n|---|---|---|---|\n", group);
    }
    const json& d = value_in(defaults, key);
    const std::string values = key.range        ? to_string(*key.range)
                               : d.is_boolean() ? "true, false"
                               : d.is_null()    ? "true, false, null"
                                                : "any 64-bit unsigned integer";
    text += fmt::format("| `{}` | {} | {} | {} |\n", key.name, d.dump(), values, key.help);
  }
  return text;
}

// The documentation lists every key with its default, range and meaning from the key table; when
// they differ, the test writes the page with its tables regenerated and says where.
TEST(ConfigKeys, AreTheTablesOfTheDocs) {
  const std::filesystem::path page = std::filesystem::path(RETIMEGS_DOCS_DIR) / "formats.md";
  const std::string begin = "<!-- generated: the key tables of train::config_keys() -->\n";
  const std::string end = "\n<!-- end of the generated key tables -->";
  std::string text = test::read_text(page);
  const std::size_t from = text.find(begin), to = text.find(end);
  ASSERT_NE(from, std::string::npos) << page << " has no line " << begin;
  ASSERT_NE(to, std::string::npos) << page << " has no line " << end;
  const std::size_t start = from + begin.size();
  if (text.compare(start, to - start, key_tables()) == 0) return;
  const std::filesystem::path regenerated =
      std::filesystem::temp_directory_path() / "retimegs_formats.md";
  test::write_text(regenerated, text.replace(start, to - start, key_tables()));
  ADD_FAILURE() << page << "'s key tables differ from train::config_keys(); to update them: cp "
                << regenerated << " " << page;
}

}  // namespace
}  // namespace retimegs::train
