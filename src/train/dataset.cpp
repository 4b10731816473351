#include "retimegs/train/dataset.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"

namespace retimegs::train {

std::size_t TrainingSet::flow_files() const {
  std::size_t n = 0;
  for (std::size_t c = 0; c < cameras.size(); ++c)
    for (std::size_t i = 0; i < frames.size(); ++i)
      n += forward[c][i].has_value() + backward[c][i].has_value();
  return n;
}

TrainingSet load_training_set(const io::Scene& scene, TrainFrames which) {
  TrainingSet set;
  set.scene = scene;
  const int step = which == TrainFrames::kEven ? 2 : 1;
  for (int k = 0; k < scene.num_frames; k += step) set.frames.push_back(k);
  if (set.frames.size() < 2)
    fail("{}: training needs at least 2 training frames; the scene has {} frame(s)",
         scene.json_path().string(), scene.num_frames);
  set.grid = {0.0, double(step), int(set.frames.size())};
  for (int c = 0; c < int(scene.cameras.size()); ++c)
    if (scene.cameras[c].split == Split::kTrain) set.cameras.push_back(c);
  if (set.cameras.empty()) fail("{}: no training cameras", scene.json_path().string());

  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
  set.images.assign(nc, std::vector<Image>(nf));
  set.masks.assign(nc, std::vector<std::optional<Image>>(nf));
  set.forward.assign(nc, std::vector<std::optional<Flow>>(nf));
  set.backward.assign(nc, std::vector<std::optional<Flow>>(nf));
  set.points.assign(nf, std::nullopt);
  parallel_for(nc * nf, [&](std::size_t job) {
    const std::size_t c = job / nf, i = job % nf;
    const int cam = set.cameras[c], k = set.frames[i];
    set.images[c][i] = io::load_image(scene, cam, k);
    set.masks[c][i] = io::load_mask(scene, cam, k);
    if (i + 1 < nf) set.forward[c][i] = io::load_flow(scene, cam, k, set.frames[i + 1]);
    if (i > 0) set.backward[c][i] = io::load_flow(scene, cam, k, set.frames[i - 1]);
    if (c == 0) set.points[i] = io::load_points(scene, k);
  });

  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int c : set.cameras) mean += scene.cameras[c].center();
  mean /= double(nc);
  double radius = 0;
  for (int c : set.cameras) radius = std::max(radius, (scene.cameras[c].center() - mean).norm());
  set.scene_extent = radius > 0 ? 1.1 * radius : 1.0;
  return set;
}

}  // namespace retimegs::train
