#pragma once
// Flow-aware initialisation (docs/method.md, paper §3.3.4) of the 4D primitives from the training
// set's per-frame point clouds and flows, the STGS baseline's initialisation, and the random
// fallback for scenes without points.
#include <cstdint>
#include <string>

#include "retimegs/model/primitives.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"

namespace retimegs::train {

struct InitOptions {
  // false: the no-flow-init ablation: zero velocities, points unmoved; static content is still
  // found from the flows as with true, so that the ablation changes the motion alone.
  bool use_flow = true;
  model::Representation representation = model::Representation::kRetime;
  std::size_t max_primitives = 100000;  // subsampled (deterministically) above this
  double initial_opacity = 0.1;
  std::uint64_t seed = 0;
  // Static content once (flow-aware path only; false: the no-static-init ablation): points no
  // faster than the stretching speed (x scene extent, TrainConfig's meaning) whose look in the
  // images holds within the stretching colour over a run of frames start as one unmoving
  // primitive over the run.
  bool static_once = true;
  double stretch_color = TrainConfig{}.stretch_color;
  double stretch_speed = TrainConfig{}.stretch_speed;
  // The paper's readings (TrainConfig's init_average_lifts, init_mean_velocity): each 3-D
  // displacement the mean of the per-view lifts at the point's depth; v1 = v2 = v3 = the mean of
  // the forward and the negated backward displacement, the seeds moved by it.
  bool average_lifts = false, mean_velocity = false;
};

// The initialisation a training run with `config` makes: its ablations, budget, opacity, seed and
// static-content thresholds.
InitOptions init_options(const TrainConfig& config, model::Representation representation);

// 3-D forward / backward displacement of point X (frame slot i) from the flows of every camera
// that sees it unoccluded (z-test against the cloud's own depth map): the flow is sampled at X's
// projection and the displacement is the least-squares fit of X + d to every camera's displaced
// pixel. The paper's recipe lifts each displaced pixel at X's depth and averages; that plain
// average underestimates motion along each view's depth axis (about half of a horizontal motion for
// cameras on a ring), so the average is only the fallback for a single or ill-conditioned view.
struct PointMotion {
  Eigen::Vector3d forward = Eigen::Vector3d::Zero(), backward = Eigen::Vector3d::Zero();
  int forward_views = 0, backward_views = 0;
};
std::vector<PointMotion> estimate_point_motion(const TrainingSet& set, int frame_slot);

// Returns the primitives and writes one line describing what was done to `note` (e.g. the random
// fallback when the scene has no points).
model::Primitives initialize(const TrainingSet& set, const InitOptions& options, std::string& note);

}  // namespace retimegs::train
