#pragma once
// Which views train, and the scene size they give. prepare writes exactly these flows and points,
// train reads exactly these, eval's baselines blend these frames, and prepare's random points and
// training's random fallback share one box: all call the functions below, none re-derives them.
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "retimegs/io/scene.hpp"

namespace retimegs::io {

// --train-frames: even trains on frames 0, 2, 4, ... (the odd ones are held out for evaluation),
// all on every frame.
enum class FrameSelection { kEven, kAll };

// "even" or "all"; throws Error naming `flag` otherwise.
FrameSelection parse_frame_selection(const std::string& text, const std::string& flag);

// `train --window A:B`, `prepare --window A:B`: scene frames A..B of a long clip, trained apart
// from the rest and merged later (model/merge.hpp). Both ends are training frames, so that
// consecutive windows share their boundary frame.
struct FrameWindow {
  int first = 0, last = 0;  // scene frames, first < last
};

// "A:B"; throws Error naming `flag` unless A and B are integers with 0 <= A < B.
FrameWindow parse_frame_window(const std::string& text, const std::string& flag);

struct TrainingViews {
  std::vector<int> cameras;  // scene indices of the training cameras (split "train")
  std::vector<int> frames;   // 0, step, 2 step, ... < num_frames (within the window, if any)
  // The whole clip's training frames: `frames` unless a window restricts them. A window's model
  // keeps the clip's time grid, so that windows share one grid.
  std::vector<int> clip_frames;
  int step = 1;  // 2 (kEven) or 1 (kAll)
  // Consecutive training frames of the clip (a, b) with a flow between them in both directions
  // for every training camera: those of `frames`, and for a window also the pair leaving each of
  // its ends for the clip frame beyond. The flow out of a window's end frame supervises the motion
  // of its last (first) interval's primitives there, through the tangent of their trajectory, as
  // the next interval's flow does in a whole-clip run; without it that tangent is free, and the
  // frames next to a seam are drawn on a guessed path.
  std::vector<std::pair<int, int>> flow_pairs;
  // 1.1 x the largest distance of a training camera's centre from their mean (gsplat's scene
  // scale; 1 when they coincide or there are none): the unit of learning rates and distances.
  double extent = 1;
};

// TrainingViews::extent of the scene: the unit training measures distances in, and calibration
// errors with them (perturb_calibration.hpp).
double scene_extent(const Scene& scene);

// The near plane as a fraction of the extent. On captures whose cameras see each other (domes,
// stages) the model holds each rig camera's body and the wall around it, placed only as precisely
// as the distant cameras that see them allow: blobs up to about 0.3 m in front of a camera centre
// on Panoptic (9 % of its extent), which a render from that camera would draw over its image. A rig
// camera looks across the stage at content metres away (on a dome of radius R, the nearest wall in
// view is more than R away), so culling this close loses nothing it sees.
constexpr double kNearPlaneFraction = 0.09;

// kNearPlaneFraction x TrainingViews::extent: the near plane of training's renders and the
// default of eval's and render's.
double scene_near_plane(const Scene& scene);

// Frames between consecutive training frames, the stride of the flows training reads: 2 for
// kEven, 1 for kAll.
int frame_step(FrameSelection which);

// Frames 0, step, 2 step, ... < num_frames (step: frame_step), and the others:
// what evaluation scores by default (`eval --frames odd` is held_out_frames of kEven).
std::vector<int> training_frames(int num_frames, FrameSelection which);
std::vector<int> held_out_frames(int num_frames, FrameSelection which);

// Empty lists are not errors here: each command checks for what it needs.
TrainingViews training_views(const Scene& scene, FrameSelection which);
// The views of the training frames within `window`, the flow pairs between them and those leaving
// its ends; cameras and extent stay the whole clip's (every window trains with the same learning
// rates and near plane).
// Throws Error naming the scene unless both ends are training frames of the clip.
TrainingViews training_views(const Scene& scene, FrameSelection which, const FrameWindow& window);

// The training cameras alone (split "train"), as in training_views().
std::vector<int> training_cameras(const Scene& scene);

// An axis-aligned cube.
struct Box {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double half = 0;  // half the side
  Eigen::Vector3d lo() const { return centre - Eigen::Vector3d::Constant(half); }
  Eigen::Vector3d hi() const { return centre + Eigen::Vector3d::Constant(half); }
};

// Where random points are seeded (prepare's random_points, training's fallback for a scene
// without points): centred on the mean over `cameras` of (centre + extent x viewing direction),
// side extent, with the extent of TrainingViews taken over `cameras`. Throws Error naming the
// scene when `cameras` is empty.
Box cameras_look_box(const Scene& scene, const std::vector<int>& cameras);

// Random points seeded in that box in all, for a scene without points (gsplat's random
// initialisation size): prepare spreads them over the training frames, training's fallback seeds
// them at once.
constexpr std::size_t kRandomPointsTotal = 20000;

}  // namespace retimegs::io
