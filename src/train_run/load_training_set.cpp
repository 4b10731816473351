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
  TrainingSet set = unloaded_training_set(scene, views);
  if (window)
    set.clip_grid = model::TimeGrid{0.0, double(views.step), int(views.clip_frames.size())};
  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
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
