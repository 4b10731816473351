#include "retimegs/playback/shot.hpp"

#include <variant>

#include "retimegs/core/camera_path.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::playback {

Camera shot_camera(const Shot& shot, int frame) {
  if (shot.per_frame) return shot.cameras[frame];
  const int frames = int(shot.times.size());
  return camera_along_path(shot.cameras, frames > 1 ? double(frame) / (frames - 1) : 0.0);
}

Colors shot_colors(const Shot& shot) {
  return !shot.per_frame && shot.cameras.size() == 1 ? Colors::kCamera : Colors::kModel;
}

Shot scene_shot(const SceneShotRequest& request, const io::Scene& scene, const LoadedModel& model) {
  const auto* model_4d = std::get_if<model::Model>(&model);
  Shot shot;
  shot.fps = scene.fps;
  if (request.time)
    shot.times = {*request.time};
  else if (request.times)
    shot.times = range_times(*request.times, "--times");
  else if (request.slowmo && model_4d)
    shot.times = slowmo_times(model_4d->grid.first, model_4d->grid.last(), *request.slowmo);
  else if (request.slowmo)  // a static model: the scene's clip
    shot.times = slowmo_times(0, scene.num_frames - 1, *request.slowmo);
  else if (!request.retime.empty())
    shot.times = ramp_times(media::read_retime_csv(request.retime));
  else if (!model_4d)  // a static model looks the same at every time: one frame
    shot.times = {0.0};
  else
    fail("render: give one of --time, --times, --slowmo or --retime");
  if (request.own_clock) {
    if (request.camera.empty() || !request.path.empty())
      fail("--own-clock: only with --camera (the camera whose clock times the frames)");
    if (request.slowmo)
      fail("--own-clock: give the camera's frames with --time, --times or --retime, not --slowmo");
    const int camera = scene.camera_index(request.camera);
    for (double& t : shot.times) t = seen_time(model, scene, camera, t);
  }
  if (model_4d) model::check_times(*model_4d, shot.times, "render");
  // Scene cameras as the model saw them (seen_camera): a path moves between the corrected ones.
  const auto scene_camera = [&](const std::string& name) {
    return seen_camera(model, scene.cameras[scene.camera_index(name)]);
  };
  if (!request.path.empty()) {
    for (const std::string& name : request.path) shot.cameras.push_back(scene_camera(name));
    if (shot.times.size() == 1) {
      if (request.path_frames < 1) fail("--path-frames: must be >= 1, got {}", request.path_frames);
      check_frame_count(request.path_frames, "--path-frames");
      shot.times.assign(request.path_frames, shot.times[0]);  // bullet time
    }
  } else {
    shot.cameras = {scene_camera(request.camera)};
  }
  for (Camera& c : shot.cameras) c = at_output_size(c, request.size);
  return shot;
}

Shot camera_path_shot(const io::CameraPathFile& file, const std::optional<double>& time,
                      const LoadedModel& model, const OutputSize& size) {
  const auto* model_4d = std::get_if<model::Model>(&model);
  Shot shot;
  shot.per_frame = true;
  shot.fps = file.fps;
  shot.times.assign(file.frames.size(), time.value_or(0.0));  // a static model ignores time
  if (model_4d && !time) {
    if (!file.timed)
      fail("{}: camera_path entries have no 'render_time'; give --time T for every frame",
           file.source.string());
    shot.times = io::camera_path_times(file, model_4d->grid.first, model_4d->grid.last());
  }
  if (model_4d) model::check_times(*model_4d, shot.times, "render");
  for (const io::CameraPathFrame& frame : file.frames)
    shot.cameras.push_back(at_output_size(frame.camera, size));
  return shot;
}

namespace {
// One frame as `writer` takes it: straight RGBA when it writes alpha, else RGB over `background`;
// its depth pass into `depth` when the writer takes one.
Image frame_for(const media::FrameWriter& writer, const ModelRenderer& renderer,
                const Camera& camera, double t, const float* background,
                const render::RenderOptions& options, Colors colors, Image* depth) {
  if (writer.alpha()) return renderer.render_rgba(camera, t, options, colors, depth);
  return renderer.render(camera, t, background, options, colors, depth);
}
}  // namespace

void render_shot(const ModelRenderer& renderer, const Shot& shot, const float* background,
                 media::FrameWriter& writer, const render::RenderOptions& options) {
  if (shot.per_frame && shot.cameras.size() != shot.times.size())
    fail("render: {} cameras for {} times", shot.cameras.size(), shot.times.size());
  const int frames = int(shot.times.size());
  const Colors colors = shot_colors(shot);
  Progress progress("render", frames, frames > 1);
  for (int f = 0; f < frames; ++f) {
    Image depth;
    Image* depth_out = writer.depth() ? &depth : nullptr;
    const Image image = frame_for(writer, renderer, shot_camera(shot, f), shot.times[f], background,
                                  options, colors, depth_out);
    writer.write(image, depth_out);
    progress.tick();
  }
  progress.finish();
  writer.finish();
}

}  // namespace retimegs::playback
