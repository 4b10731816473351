#include "retimegs/train/dataset.hpp"

#include <algorithm>
#include <cmath>

namespace retimegs::train {

std::size_t TrainingSet::flow_files() const {
  std::size_t n = 0;
  for (std::size_t c = 0; c < cameras.size(); ++c)
    for (std::size_t i = 0; i < frames.size(); ++i)
      n += forward[c][i].has_value() + backward[c][i].has_value();
  return n;
}

std::size_t TrainingSet::image_bytes() const {
  std::size_t n = 0;
  for (const auto& per_camera : images)
    for (const PackedImage& image : per_camera) n += image.bytes();
  return n;
}

std::pair<int, int> TrainingSet::slots_at(double t) const {
  const double k = (t - grid.first) / grid.step;
  const int a = int(std::clamp(std::floor(k), 0.0, double(grid.count - 1)));
  const int b = int(std::clamp(std::ceil(k), 0.0, double(grid.count - 1)));
  return {a, b};
}

TrainingSet unloaded_training_set(const io::Scene& scene, const io::TrainingViews& views) {
  TrainingSet set;
  set.scene = scene;
  set.cameras = views.cameras;
  set.frames = views.frames;
  set.grid = {double(views.frames[0]), double(views.step), int(views.frames.size())};
  set.scene_extent = views.extent;
  set.near_plane = float(io::scene_near_plane(scene));
  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
  set.times.assign(nc, std::vector<double>(nf));
  for (std::size_t c = 0; c < nc; ++c)
    for (std::size_t i = 0; i < nf; ++i)
      set.times[c][i] = io::frame_time(scene, set.cameras[c], set.frames[i]);
  set.images.assign(nc, std::vector<PackedImage>(nf));
  set.masks.assign(nc, std::vector<std::optional<Image>>(nf));
  set.forward.assign(nc, std::vector<std::optional<Flow>>(nf));
  set.backward.assign(nc, std::vector<std::optional<Flow>>(nf));
  set.points.assign(nf, std::nullopt);
  return set;
}

}  // namespace retimegs::train
