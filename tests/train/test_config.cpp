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

  const Ablations none = parse_ablations("", {}, "--ablate");
  EXPECT_FALSE(none.no_flow_init || none.no_flow_loss || none.no_triple || none.no_stretch ||
               none.linear || none.no_static_init);
}

TEST(ParseAblations, RefusesEmptyItemsAndUnknownNames) {
  EXPECT_EQ(test::message_of([] { parse_ablations("linear,", {}, "--ablate"); }),
            "--ablate: empty item in 'linear,'");
  // Every item is checked for emptiness before any name is looked up.
  EXPECT_EQ(test::message_of([] { parse_ablations("bogus,,linear", {}, "--ablate"); }),
            "--ablate: empty item in 'bogus,,linear'");
  EXPECT_EQ(test::message_of([] { parse_ablations("no_triple", {}, "--ablate"); }),
            "--ablate: unknown ablation 'no_triple' (no-flow-init, no-flow-loss, no-triple, "
            "no-stretch, linear, no-static-init)");
}

}  // namespace
}  // namespace retimegs::train
