#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/train/config.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {

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

}  // namespace
}  // namespace retimegs::train
