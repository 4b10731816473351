// The paper's ablation rows (docs/method.md, "Baseline and ablations") each change one part of the
// recipe: the part they name, and nothing else a run decides from its config.
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/train/initialize.hpp"
#include "retimegs/train/schedule.hpp"
#include "retimegs/train/strategy.hpp"

namespace retimegs::train {
namespace {

using model::Representation;

// The parts of the recipe, by what a run computes from its config.
std::map<std::string, std::string> recipe(const TrainConfig& config) {
  const Representation rep = config.model_config().representation;
  std::map<std::string, std::string> parts;
  const double w_flow = flow_weight(config, rep, 1);
  std::string images = "", flows = std::to_string(w_flow);
  for (const int frame : {0, 2, 4})
    for (const RenderPass& pass : render_passes(config, rep, frame, 5, w_flow > 0)) {
      images += std::to_string(int(pass.group)) + (pass.compensate ? "c" : "") +
                (pass.image ? "i " : " ");
      flows += pass.flow ? " f" : " -";
    }
  parts["image renders"] = images;
  parts["flow supervision"] = flows;
  const InitOptions init = init_options(config, rep);
  parts["initial motion"] = std::to_string(init.use_flow);
  parts["static initialisation"] = std::to_string(init.static_once);
  // Relocation off, so that a reshape at the stretching period is stretching.
  parts["stretching"] =
      std::to_string(McmcStrategy(config, 1).reshapes_at(config.scaled(config.stretch_every)));
  parts["trajectory"] = std::to_string(int(config.model_config().trajectory));
  return parts;
}

TEST(Ablations, EachChangesItsOnePartOfTheRecipe) {
  TrainConfig base;
  base.relocate_start = base.iters;
  const std::map<std::string, std::string> full = recipe(base);
  const std::map<std::string, std::string> part_of = {
      {"no-flow-init", "initial motion"}, {"no-flow-loss", "flow supervision"},
      {"no-triple", "image renders"},     {"no-stretch", "stretching"},
      {"linear", "trajectory"},           {"no-static-init", "static initialisation"},
  };
  for (const auto& [name, part] : part_of) {
    TrainConfig ablated = base;
    ablated.ablate = parse_ablations(name, {}, "--ablate");
    const std::map<std::string, std::string> changed = recipe(ablated);
    std::set<std::string> differ;
    for (const auto& [key, value] : full)
      if (changed.at(key) != value) differ.insert(key);
    EXPECT_EQ(differ, std::set<std::string>{part}) << name;
  }
}

// Without triple rendering the group renders keep their flow supervision and lose their image
// loss; with the flow loss off too, only the all-primitives render is left.
TEST(Ablations, NoTripleKeepsTheGroupsFlowAndDropsTheirImageLoss) {
  TrainConfig config;
  config.ablate.no_triple = true;
  const auto passes = render_passes(config, Representation::kRetime, 2, 5, true);
  ASSERT_EQ(passes.size(), 3u);
  EXPECT_TRUE(passes[0].group == model::Group::kAll && passes[0].image && !passes[0].flow);
  for (const int g : {1, 2})
    EXPECT_TRUE(passes[g].compensate && !passes[g].image && passes[g].flow) << g;
  const auto without_flow = render_passes(config, Representation::kRetime, 2, 5, false);
  ASSERT_EQ(without_flow.size(), 1u);
  EXPECT_TRUE(without_flow[0].group == model::Group::kAll && without_flow[0].image);
}

}  // namespace
}  // namespace retimegs::train
