#pragma once
// What training reads from a scene, loaded once: the training cameras and frames, their images,
// masks, the flows between consecutive training frames, and the per-frame point clouds. Loaded
// from a scene's files by train_run/load_training_set.hpp (which reads the images through
// media), or built in memory (tests/cuda_train/tiny_scene.hpp).
#include <optional>
#include <utility>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::train {

struct TrainingSet {
  io::Scene scene;
  // As io::training_views() gives them.
  std::vector<int> cameras;  // indices of the training cameras (split "train")
  std::vector<int> frames;   // scene frames used for training: t_i = frames[i]
  model::TimeGrid grid;      // t_i = grid.at(i) == frames[i]
  // Set when a window (train --window) restricts the frames: the whole clip's training frames,
  // the time grid of the model written.
  std::optional<model::TimeGrid> clip_grid;

  // Indexed [camera slot][frame slot], slots as in `cameras` / `frames`.
  // Each view's scene time, io::frame_time of its camera and frame: grid.at(i) unless the camera
  // keeps its own clock (docs/method.md, "Cameras on their own clocks"). Empty in a set built in
  // memory without clocks: every view at its grid time.
  std::vector<std::vector<double>> times;
  std::vector<std::vector<PackedImage>> images;            // RGB [H, W, 3]
  std::vector<std::vector<std::optional<Image>>> masks;    // [H, W, 1] when the scene has them
  std::vector<std::vector<std::optional<Flow>>> forward;   // t_i -> t_{i+1}
  std::vector<std::vector<std::optional<Flow>>> backward;  // t_i -> t_{i-1}
  std::vector<std::optional<io::PointCloud>> points;       // per frame slot

  // Whether view (camera slot c, frame slot i) is at its training time t_i: the triple rendering
  // and the flow loss are defined there; a view off the grid is supervised by the image loss of
  // its all-primitives render at its own time.
  double time(int c, int i) const { return times.empty() ? grid.at(i) : times[c][i]; }
  bool on_grid(int c, int i) const { return time(c, i) == grid.at(i); }
  // The grid slots (a, b) around view (c, i)'s time, a == b at a grid time or beyond the grid's
  // ends: a plain render at that time touches only rows of slots a and b (TrainingRows).
  std::pair<int, int> slots_around(int c, int i) const { return slots_at(time(c, i)); }
  // The grid slots (a, b) around time t: a == b at a grid time or beyond the grid's ends.
  std::pair<int, int> slots_at(double t) const;

  double scene_extent = 1.0;  // io::TrainingViews::extent
  float near_plane = 0.01f;   // io::scene_near_plane
  std::size_t flow_files() const;
  std::size_t image_bytes() const;  // of the packed images
};

// The training set of `views` (io::training_views of `scene`) with nothing read yet: its cameras,
// frames, time grid, extent and near plane, every per-view array sized and empty. A loader (or a
// test, a benchmark) fills the images, masks, flows and points.
TrainingSet unloaded_training_set(const io::Scene& scene, const io::TrainingViews& views);

}  // namespace retimegs::train
