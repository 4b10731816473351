// retimegs render --model MODEL --scene SCENE --camera NAME (--time T | --times A:B:STEP |
//                 --slowmo F | --retime FILE) [--path CAM,CAM,...] [--near D] --out OUT
#include <cmath>
#include <memory>
#include <optional>
#include <variant>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/eval/render_model.hpp"
#include "retimegs/io/frame_writer.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::app {

void add_render_command(CLI::App& app) {
  struct Args {
    std::string model, scene, camera, path, times, retime, out, background = "0,0,0";
    std::optional<double> time;
    std::optional<int> slowmo;
    int path_frames = 60, threads = 0;
    std::optional<double> near;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a model at any real-valued time: one image, a folder of PNGs or a video. MODEL is a "
      "4D model (.rgs) or a static 3DGS .ply (Inria layout; time is then ignored).");
  cmd->add_option("--model", args->model, "model file (.rgs or .ply)")->required();
  cmd->add_option("--scene", args->scene, "scene folder whose cameras and fps are used")
      ->required();
  auto* camera = cmd->add_option("--camera", args->camera,
                                 "camera name in the scene (a training camera renders through its "
                                 "learned colour map, any other with the model's colours)");
  auto* path_option =
      cmd->add_option("--path", args->path,
                      "cameras CAM,CAM,... to move through (bullet time with --time), with the "
                      "model's colours");
  camera->excludes(path_option);
  auto* time = cmd->add_option("--time", args->time,
                               "one time, in scene frame units, within the model's time range");
  auto* times = cmd->add_option("--times", args->times, "times A:B:STEP (inclusive of B)");
  auto* slowmo = cmd->add_option("--slowmo", args->slowmo,
                                 "F frames per scene-frame interval over the model's time "
                                 "range, its first to last training frame (F x slow motion)");
  auto* retime = cmd->add_option("--retime", args->retime,
                                 "speed ramp: CSV rows output_frame,t (keyframes, linearly "
                                 "interpolated)");
  time->excludes(times)->excludes(slowmo)->excludes(retime);
  times->excludes(slowmo)->excludes(retime);
  slowmo->excludes(retime);
  cmd->add_option("--path-frames", args->path_frames,
                  "frames of a --path move at a fixed --time (bullet time)")
      ->capture_default_str();
  cmd->add_option("--out", args->out,
                  "output: x.png (one frame), x.mp4 / x.avi (video at the scene's fps) or a folder")
      ->required();
  cmd->add_option("--background", args->background, "background colour R,G,B in [0, 1]")
      ->capture_default_str();
  add_near_option(*cmd, args->near);
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  cmd->add_flag("--force", args->force, "replace an existing output");
  cmd->callback([args] {
    set_threads(args->threads);
    const std::vector<float> background = parse_float_list(args->background, "--background", 3);
    const io::Scene scene = io::read_scene(args->scene, io::SceneCheck::kJson);
    const render::RenderOptions render_options = near_render_options(near_plane(args->near, scene));
    if (args->camera.empty() && args->path.empty()) fail("render: give --camera or --path");

    const eval::LoadedModel model = eval::load_model(args->model);
    const auto* model_4d = std::get_if<model::Model>(&model);
    std::vector<double> frame_times;
    if (args->time)
      frame_times = {*args->time};
    else if (!args->times.empty())
      frame_times = parse_time_range(args->times, "--times");
    else if (args->slowmo && model_4d)
      frame_times = slowmo_times(model_4d->grid.first, model_4d->grid.last(), *args->slowmo);
    else if (args->slowmo)  // a static model: the scene's clip
      frame_times = slowmo_times(0, scene.num_frames - 1, *args->slowmo);
    else if (!args->retime.empty())
      frame_times = io::read_retime_csv(args->retime);
    else
      fail("render: give one of --time, --times, --slowmo or --retime");
    if (model_4d) model::check_times(*model_4d, frame_times, "render");
    std::vector<Camera> path;
    if (!args->path.empty()) {
      for (const auto& name : split_list(args->path, "--path"))
        path.push_back(scene.cameras[scene.camera_index(name)]);
      if (frame_times.size() == 1) {
        if (args->path_frames < 1) fail("--path-frames: must be >= 1, got {}", args->path_frames);
        frame_times.assign(args->path_frames, frame_times[0]);  // bullet time
      }
    } else {
      path = {scene.cameras[scene.camera_index(args->camera)]};
    }

    const int frames = int(frame_times.size());
    io::FrameWriter writer(args->out, frames, scene.fps, args->force);
    eval::render_frames(model, path, frame_times, background.data(), writer, render_options);
    spdlog::info("rendered {} frame{} to {}", frames, frames > 1 ? "s" : "", args->out);
  });
}

}  // namespace retimegs::app
