#pragma once
// Flow-aware initialisation (DESIGN.md §2, paper §3.3.4) of the 4D primitives from the training
// set's per-frame point clouds and flows, the STGS baseline's initialisation, and the random
// fallback for scenes without points.
#include <cstdint>
#include <string>

#include "retimegs/model/primitives.hpp"
#include "retimegs/train/dataset.hpp"

namespace retimegs::train {

struct InitOptions {
  bool use_flow = true;  // false: the no-flow-init ablation (zero velocities, points unmoved)
  model::Representation representation = model::Representation::kRetime;
  std::size_t max_primitives = 100000;  // subsampled (deterministically) above this
  double initial_opacity = 0.1;
  std::uint64_t seed = 0;
};

// 3-D forward / backward displacement of point X (frame slot i) from the flows of every camera
// that sees it unoccluded: the flow is sampled at X's projection, the displaced pixel lifted back
// to 3-D at X's depth, and the displacements averaged. Returns false when no camera had a flow.
struct PointMotion {
  Eigen::Vector3d forward = Eigen::Vector3d::Zero(), backward = Eigen::Vector3d::Zero();
  int forward_views = 0, backward_views = 0;
};
std::vector<PointMotion> estimate_point_motion(const TrainingSet& set, int frame_slot);

// Returns the primitives and writes one line describing what was done to `note` (e.g. the random
// fallback when the scene has no points).
model::Primitives initialize(const TrainingSet& set, const InitOptions& options, std::string& note);

}  // namespace retimegs::train
