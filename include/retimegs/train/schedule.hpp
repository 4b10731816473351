#pragma once
// What a step's iteration and view decide, on every device alike (docs/method.md, "Training"):
// the renders of the step (triple rendering), the flow weight, the learning-rate factors and the
// active SH degree. Pure functions of the configuration, so that the CPU and a GPU step follow
// one schedule.
#include <vector>

#include "retimegs/model/primitives.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/train/config.hpp"

namespace retimegs::train {

// One render of a step's view and the losses on it: `image` the image loss, `flow` the flow loss.
// Triple rendering renders all primitives, then each group compensated (image and flow losses on
// the groups); otherwise all primitives once.
struct RenderPass {
  model::Group group;
  bool compensate, image, flow;
};

// Triple at interior frames (frame slot i of `frames`), one render at the ends and for STGS;
// `flow`: the flow loss is on at this step. The no_triple ablation drops the image loss of the
// group renders only (the paper's row: triple rendering is their image loss; their flow
// supervision stays), so a group render is made only while the flow loss is on.
// `on_grid`: the view is at its training time t_i (TrainingSet::on_grid). A view off the grid (a
// camera on its own clock) has one render, all primitives at its own time, with the image loss
// alone: the groups, their compensation σ_τ(t_i) and the flow features are defined at t_i only.
std::vector<RenderPass> render_passes(const TrainConfig& config,
                                      model::Representation representation, int i, int frames,
                                      bool flow, bool on_grid = true);

// The flow loss weight at iteration `it`: log-linear from flow_weight_start to flow_weight_end
// until flow_decay_until (scaled), then constant; with flow_hold, flow_weight_start until
// flow_decay_until, then log-linear to flow_weight_end at the last iteration. 0 for STGS and the
// no_flow_loss ablation.
double flow_weight(const TrainConfig& config, model::Representation representation, int it);

// The factor of every learning rate: 1 until lr_decay_start (scaled), then exponential down to
// lr_decay_final at the last iteration.
double lr_factor(const TrainConfig& config, int it);

// The means' own decay: exponential to lr_means_final over the whole run.
double means_decay(const TrainConfig& config, int it);

// The active SH degree: min(max_sh_degree, it / sh_degree_every (scaled)).
int sh_degree(const TrainConfig& config, int it);

}  // namespace retimegs::train
