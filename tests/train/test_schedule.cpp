// The per-iteration schedule every device follows (train/schedule.hpp).
#include <cmath>

#include <gtest/gtest.h>

#include "retimegs/train/schedule.hpp"

namespace retimegs::train {
namespace {

using model::Group;
using model::Representation;

TEST(Schedule, TripleRenderingAtInteriorFramesOnly) {
  const TrainConfig config;
  const auto interior = render_passes(config, Representation::kRetime, 2, 5, true);
  ASSERT_EQ(interior.size(), 3u);
  EXPECT_EQ(interior[0].group, Group::kAll);
  EXPECT_FALSE(interior[0].compensate || interior[0].flow) << "flow is on the groups";
  EXPECT_EQ(interior[1].group, Group::kLeft);
  EXPECT_EQ(interior[2].group, Group::kRight);
  EXPECT_TRUE(interior[1].compensate && interior[1].flow && interior[2].compensate &&
              interior[2].flow);
  for (const int end : {0, 4}) {
    const auto passes = render_passes(config, Representation::kRetime, end, 5, true);
    ASSERT_EQ(passes.size(), 1u) << "frame " << end;
    EXPECT_TRUE(passes[0].group == Group::kAll && !passes[0].compensate && passes[0].flow);
  }
  EXPECT_EQ(render_passes(config, Representation::kStgs, 2, 5, false).size(), 1u);
  for (const auto& passes : {interior, render_passes(config, Representation::kRetime, 2, 5, false)})
    for (const RenderPass& pass : passes) EXPECT_TRUE(pass.image) << "every render's image loss";
}

TEST(Schedule, FlowWeightDecaysLogLinearlyThenStays) {
  TrainConfig config;  // 20 000 iterations: milestones as given
  EXPECT_DOUBLE_EQ(flow_weight(config, Representation::kRetime, 0), 0.5);
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 6000), std::sqrt(0.5 * 1e-6), 1e-12);
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 12000), 1e-6, 1e-15);
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 19000), 1e-6, 1e-15);
  EXPECT_EQ(flow_weight(config, Representation::kStgs, 0), 0.0);
  config.iters = 2000;  // milestones scaled by a tenth: 1e-6 from iteration 1 200 on
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 1200), 1e-6, 1e-15);
  config.ablate.no_flow_loss = true;
  EXPECT_EQ(flow_weight(config, Representation::kRetime, 0), 0.0);
}

// The paper's reading (flow_hold): 0.5 until flow_decay_until, then exponential to 1e-6 at the
// last iteration.
TEST(Schedule, FlowWeightHeldThenDecaysToTheEnd) {
  TrainConfig config;
  config.flow_hold = true;
  EXPECT_DOUBLE_EQ(flow_weight(config, Representation::kRetime, 1), 0.5);
  EXPECT_DOUBLE_EQ(flow_weight(config, Representation::kRetime, 12000), 0.5);
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 16000), std::sqrt(0.5 * 1e-6), 1e-12);
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 20000), 1e-6, 1e-15);
  config.iters = 2000;  // scaled: held until 1 200
  EXPECT_DOUBLE_EQ(flow_weight(config, Representation::kRetime, 1200), 0.5);
  EXPECT_NEAR(flow_weight(config, Representation::kRetime, 1600), std::sqrt(0.5 * 1e-6), 1e-12);
  config.ablate.no_flow_loss = true;
  EXPECT_EQ(flow_weight(config, Representation::kRetime, 1), 0.0);
}

TEST(Schedule, RatesAndShDegree) {
  const TrainConfig config;
  EXPECT_EQ(lr_factor(config, 18000), 1.0);
  EXPECT_NEAR(lr_factor(config, 19000), std::sqrt(0.1), 1e-12);
  EXPECT_NEAR(lr_factor(config, 20000), 0.1, 1e-12);
  EXPECT_EQ(means_decay(config, 0), 1.0);
  EXPECT_NEAR(means_decay(config, 10000), 0.1, 1e-12);
  EXPECT_NEAR(means_decay(config, 20000), 0.01, 1e-12);
  EXPECT_EQ(sh_degree(config, 999), 0);
  EXPECT_EQ(sh_degree(config, 1000), 1);
  EXPECT_EQ(sh_degree(config, 2999), 2);
  EXPECT_EQ(sh_degree(config, 50000), 3);
}

}  // namespace
}  // namespace retimegs::train
