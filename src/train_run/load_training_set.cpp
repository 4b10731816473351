#include "retimegs/train_run/load_training_set.hpp"

#include <filesystem>

#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/media/resize.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::train {

TrainingSet load_training_set(const io::Scene& scene, io::FrameSelection which,
                              const std::optional<io::FrameWindow>& window, double downscale) {
  check_downscale(downscale);
  const io::TrainingViews views =
      window ? io::training_views(scene, which, *window) : io::training_views(scene, which);
  if (views.frames.size() < 2)
    fail("{}: training needs at least 2 training frames; the scene has {} frame(s)",
         scene.json_path().string(), scene.num_frames);
  if (views.cameras.empty()) fail("{}: no training cameras", scene.json_path().string());
  io::Scene scaled = scene;
  for (Camera& camera : scaled.cameras) camera = downscaled(camera, downscale);
  TrainingSet set = unloaded_training_set(scaled, views);
  if (window)
    set.clip_grid = model::TimeGrid{0.0, double(views.step), int(views.clip_frames.size())};
  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
  const bool own_masks = !std::filesystem::exists(scene.estimated_masks_marker());
  parallel_for(nc * nf, [&](std::size_t job) {
    const std::size_t c = job / nf, i = job % nf;
    const int cam = set.cameras[c], k = set.frames[i];
    const int width = scaled.cameras[cam].width, height = scaled.cameras[cam].height;
    set.images[c][i] = pack(media::resize_area(media::load_image(scene, cam, k), width, height),
                            scene.image_path(cam, k).string());
    if (auto mask = own_masks ? media::load_mask(scene, cam, k) : std::nullopt)
      set.masks[c][i] = media::resize_area(*mask, width, height);
    auto load_flow = [&](int from, int to) -> std::optional<Flow> {
      if (auto flow = io::load_flow(scene, cam, from, to))
        return media::resize_flow(*flow, width, height);
      return std::nullopt;
    };
    // Forward: k to the next clip training frame; backward: k to the previous one.
    for (const auto& [a, b] : views.flow_pairs) {
      if (a == k) set.forward[c][i] = load_flow(a, b);
      if (b == k) set.backward[c][i] = load_flow(b, a);
    }
    if (c == 0) set.points[i] = io::load_points(scene, k);
  });
  return set;
}

}  // namespace retimegs::train
