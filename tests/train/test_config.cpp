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
  EXPECT_FALSE(a.no_camera_color);
  EXPECT_TRUE(parse_ablations("no-camera-color", {}, "--ablate").no_camera_color);

  const Ablations none = parse_ablations("", {}, "--ablate");
  EXPECT_FALSE(none.no_flow_init || none.no_flow_loss || none.no_triple || none.no_stretch ||
               none.linear || none.no_camera_color);
}

TEST(ParseAblations, RefusesEmptyItemsAndUnknownNames) {
  EXPECT_EQ(test::message_of([] { parse_ablations("linear,", {}, "--ablate"); }),
            "--ablate: empty item in 'linear,'");
  // Every item is checked for emptiness before any name is looked up.
  EXPECT_EQ(test::message_of([] { parse_ablations("bogus,,linear", {}, "--ablate"); }),
            "--ablate: empty item in 'bogus,,linear'");
  EXPECT_EQ(test::message_of([] { parse_ablations("no_triple", {}, "--ablate"); }),
            "--ablate: unknown ablation 'no_triple' (no-flow-init, no-flow-loss, no-triple, "
            "no-stretch, linear, no-camera-color)");
}

}  // namespace
}  // namespace retimegs::train
