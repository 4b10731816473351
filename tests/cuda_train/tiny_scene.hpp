#pragma once
// A tiny training set built in memory, for the training step's tests on both devices (CpuStep,
// the CUDA step): no files and no image codecs, so that it builds in the lean GPU build
// (RETIMEGS_GPU_ONLY, DESIGN.md §3), where neither media nor load_training_set exists.
//
// The scene: `cameras` cameras on a quarter of a ring of radius 4 around the origin (all "train"),
// looking at it, and `frames` scene frames, all of them training frames (io::FrameSelection::kAll).
// A ball of radius 0.5 moves along x at 0.1 per frame (`speed`) in front of a black background;
// each image is the ball's projection drawn as a disc of its colour, with a one-pixel soft edge.
// Each frame slot has the ball's surface as a point cloud (the flow-aware initialisation's seeds)
// and the ball's disc as its mask, so that the black is the capture's background and training stays
// over black by default (train/background.hpp) on both devices; there are no flows. The fields the
// loader derives from a scene (frames, grid, extent, near plane) come from the function
// load_training_set calls, train::unloaded_training_set of the scene's io::training_views.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/train/dataset.hpp"

namespace retimegs::test {

struct TinySceneOptions {
  int cameras = 2;
  int frames = 3;
  int width = 32, height = 24;
  int points_per_frame = 200;  // on the ball's surface (a Fibonacci sphere)
  double speed = 0.1;          // the ball's, along x per frame
  // Per camera (empty: none): its clock's time_offset (io::CameraClock); its images show the ball
  // at its own times (io::frame_time), its points stay at the frames' times.
  std::vector<double> time_offsets;
};

// The ball's centre at scene time `frame` (any real time: held-out in-between images too).
inline Eigen::Vector3d tiny_ball_centre(double frame, double speed = 0.1) {
  return {-speed + speed * frame, 0, 0};
}
constexpr double kTinyBallRadius = 0.5;
constexpr float kTinyBallColour[3] = {0.9f, 0.5f, 0.2f};

// What `cam` sees at scene time `frame`: the ball as a disc of its colour with a one-pixel soft
// edge, on black.
inline Image tiny_ball_image(const Camera& cam, double frame, double speed = 0.1) {
  const Eigen::Vector3d x_cam = cam.world_to_cam(tiny_ball_centre(frame, speed));
  const Eigen::Vector2d uv = cam.project_cam(x_cam);
  const double radius = cam.fx * kTinyBallRadius / x_cam.z();  // pixels
  Image image(cam.width, cam.height, 3);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const double d = (Eigen::Vector2d(x + 0.5, y + 0.5) - uv).norm();
      const float cover = float(std::clamp(radius + 0.5 - d, 0.0, 1.0));
      for (int a = 0; a < 3; ++a) image.at(y, x, a) = cover * kTinyBallColour[a];
    }
  return image;
}

inline train::TrainingSet tiny_training_set(const TinySceneOptions& options = {}) {
  io::Scene scene;
  scene.num_frames = options.frames;
  scene.fps = 10;
  scene.up = {0, -1, 0};
  for (int c = 0; c < options.cameras; ++c) {
    const double angle = 0.5 * std::numbers::pi * c / options.cameras;
    Camera cam;
    cam.name = fmt::format("cam{:02d}", c);
    cam.width = options.width, cam.height = options.height;
    cam.fx = cam.fy = options.width;  // about 53 degrees across
    cam.cx = 0.5 * options.width, cam.cy = 0.5 * options.height;
    const Eigen::Vector3d eye(4 * std::sin(angle), -0.5, -4 * std::cos(angle));
    cam.world_to_camera = look_at(eye, Eigen::Vector3d::Zero(), scene.up);
    cam.split = Split::kTrain;
    scene.cameras.push_back(cam);
  }
  if (!options.time_offsets.empty()) {
    scene.clocks.resize(scene.cameras.size());
    for (std::size_t c = 0; c < options.time_offsets.size(); ++c)
      scene.clocks[c].time_offset = options.time_offsets[c];
  }

  train::TrainingSet set =
      train::unloaded_training_set(scene, io::training_views(scene, io::FrameSelection::kAll));
  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
  for (std::size_t i = 0; i < nf; ++i) {
    const Eigen::Vector3d centre = tiny_ball_centre(set.frames[i], options.speed);
    for (std::size_t c = 0; c < nc; ++c) {
      const Image image =
          tiny_ball_image(scene.cameras[set.cameras[c]],
                          io::frame_time(scene, set.cameras[c], set.frames[i]), options.speed);
      set.images[c][i] = pack(image, fmt::format("tiny scene camera {} frame {}", c, i));
      Image mask(image.width, image.height, 1);
      for (std::size_t p = 0; p < mask.pixels(); ++p) mask.data[p] = image.data[3 * p];
      set.masks[c][i] = mask;  // coverage times the ball's red 0.9: foreground where over half
    }
    io::PointCloud cloud;
    const int n = options.points_per_frame;
    for (int k = 0; k < n; ++k) {  // Fibonacci sphere: evenly spread, deterministic
      const double z = 1 - 2 * (k + 0.5) / n, r = std::sqrt(1 - z * z);
      const double phi = k * std::numbers::pi * (3 - std::sqrt(5.0));
      const Eigen::Vector3d x =
          centre + kTinyBallRadius * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
      for (int a = 0; a < 3; ++a) {
        cloud.xyz.push_back(float(x[a]));
        cloud.rgb.push_back(kTinyBallColour[a]);
      }
    }
    set.points[i] = std::move(cloud);
  }
  return set;
}

}  // namespace retimegs::test
