#include "retimegs/train_run/load_training_set.hpp"

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::train {

TrainingSet load_training_set(const io::Scene& scene, io::FrameSelection which,
                              const std::optional<io::FrameWindow>& window) {
  const io::TrainingViews views =
      window ? io::training_views(scene, which, *window) : io::training_views(scene, which);
  if (views.frames.size() < 2)
    fail("{}: training needs at least 2 training frames; the scene has {} frame(s)",
         scene.json_path().string(), scene.num_frames);
  if (views.cameras.empty()) fail("{}: no training cameras", scene.json_path().string());
  TrainingSet set;
  set.scene = scene;
  set.cameras = views.cameras;
  set.frames = views.frames;
  set.grid = {double(views.frames[0]), double(views.step), int(views.frames.size())};
  if (window)
    set.clip_grid = model::TimeGrid{0.0, double(views.step), int(views.clip_frames.size())};
  set.scene_extent = views.extent;
  set.near_plane = float(io::scene_near_plane(scene));

  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
  set.images.assign(nc, std::vector<PackedImage>(nf));
  set.masks.assign(nc, std::vector<std::optional<Image>>(nf));
  set.forward.assign(nc, std::vector<std::optional<Flow>>(nf));
  set.backward.assign(nc, std::vector<std::optional<Flow>>(nf));
  set.points.assign(nf, std::nullopt);
  parallel_for(nc * nf, [&](std::size_t job) {
    const std::size_t c = job / nf, i = job % nf;
    const int cam = set.cameras[c], k = set.frames[i];
    set.images[c][i] = pack(media::load_image(scene, cam, k), scene.image_path(cam, k).string());
    set.masks[c][i] = media::load_mask(scene, cam, k);
    // Forward: k to the next clip training frame; backward: k to the previous one.
    for (const auto& [a, b] : views.flow_pairs) {
      if (a == k) set.forward[c][i] = io::load_flow(scene, cam, a, b);
      if (b == k) set.backward[c][i] = io::load_flow(scene, cam, b, a);
    }
    if (c == 0) set.points[i] = io::load_points(scene, k);
  });
  return set;
}

}  // namespace retimegs::train
