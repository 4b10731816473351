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

}  // namespace
}  // namespace retimegs::train
