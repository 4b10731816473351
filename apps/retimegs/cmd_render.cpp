// retimegs render --model MODEL --scene SCENE --camera NAME (--time T | --times A:B:STEP |
//                 --slowmo F | --retime FILE) [--path CAM,CAM,...] [--near D] --out OUT
// retimegs render --model MODEL --scene SCENE --camera-path camera_path.json [--time T] --out OUT
//   outputs: [--size WxH | --scale S] [--fps F] [--alpha] [--bit-depth 8|16] [--force]
#include <cmath>
#include <memory>
#include <optional>
#include <variant>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/io/camera_path_json.hpp"
#include "retimegs/io/frame_writer.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/playback/output_size.hpp"
#include "retimegs/playback/render_model.hpp"

namespace retimegs::app {

void add_render_command(CLI::App& app) {
  struct Args {
    std::string model, scene, camera, path, times, retime, out, background = "0,0,0";
    std::optional<double> time;
    std::optional<int> slowmo;
    int path_frames = 60, threads = 0;
    std::optional<double> near;
    bool force = false;
    std::string camera_path;  // nerfstudio camera_path.json
    std::string size;         // --size WxH
    std::optional<double> scale, fps;
    bool alpha = false;
    int bit_depth = 8;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a model at any real-valued time: one image, a folder of PNGs or a video. MODEL is a "
      "4D model (.rgs) or a static 3DGS .ply (Inria layout; time is then ignored).");
  cmd->add_option("--model", args->model, "model file (.rgs or .ply)")
      ->required()
      ->check(input_file("a model"));
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
  auto* camera_path = cmd->add_option(
      "--camera-path", args->camera_path,
      "nerfstudio camera_path.json (ns-render camera-path): one camera per frame, its render_time "
      "over the model's time range (or --time T for every frame), the file's size and fps, the "
      "model's colours");
  camera_path->check(input_file("a camera path"));
  camera_path->excludes(camera)->excludes(path_option);
  auto* time = cmd->add_option("--time", args->time,
                               "one time, in scene frame units, within the model's time range");
  auto* times = cmd->add_option("--times", args->times, "times A:B:STEP (inclusive of B)");
  auto* slowmo = cmd->add_option("--slowmo", args->slowmo,
                                 "F frames per scene-frame interval over the model's time "
                                 "range, its first to last training frame (F x slow motion)");
  auto* retime = cmd->add_option("--retime", args->retime,
                                 "speed ramp: CSV rows output_frame,t (keyframes, linearly "
                                 "interpolated)");
  retime->check(input_file("a retime table"));
  time->excludes(times)->excludes(slowmo)->excludes(retime);
  times->excludes(slowmo)->excludes(retime);
  slowmo->excludes(retime);
  camera_path->excludes(times)->excludes(slowmo)->excludes(retime);
  cmd->add_option("--path-frames", args->path_frames,
                  "frames of a --path move at a fixed --time (bullet time)")
      ->capture_default_str();
  cmd->add_option("--out", args->out,
                  "output: x.png (one frame), x.mp4 / x.mov / x.mkv (H.264), x.avi (Motion-JPEG) "
                  "or a folder of PNGs with times.csv")
      ->required();
  cmd->add_option("--fps", args->fps,
                  "frame rate of a video (default: the scene's; a --camera-path file's own)");
  auto* size = cmd->add_option("--size", args->size,
                               "render at WxH, the camera's aspect ratio (intrinsics scaled; "
                               "default: the camera's size)");
  auto* scale = cmd->add_option("--scale", args->scale,
                                "render at the camera's size times S, rounded (intrinsics scaled)");
  size->excludes(scale);
  cmd->add_flag("--alpha", args->alpha,
                "PNG outputs: RGBA, straight colour and alpha = the render's opacity");
  cmd->add_option("--bit-depth", args->bit_depth, "PNG outputs: 8 or 16 bits per channel")
      ->check(CLI::IsMember({8, 16}))
      ->capture_default_str();
  cmd->add_option("--background", args->background, "background colour R,G,B in [0, 1]")
      ->capture_default_str();
  add_near_option(*cmd, args->near);
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  cmd->add_flag("--force", args->force, "replace an existing output");
  cmd->callback([args] {
    set_threads(args->threads);
    std::vector<InputPath> inputs = scene_inputs(args->scene);
    inputs.push_back({args->model, "model"});
    inputs.push_back({args->camera_path, "camera path file"});
    inputs.push_back({args->retime, "retime file"});
    check_output_overlap(args->out, "--out", inputs);
    const std::vector<float> background = parse_float_list(args->background, "--background", 3);
    const io::Scene scene = io::read_scene(args->scene, io::SceneCheck::kJson);
    const render::RenderOptions render_options = near_render_options(near_plane(args->near, scene));
    if (args->camera.empty() && args->path.empty() && args->camera_path.empty())
      fail("render: give --camera, --path or --camera-path");
    playback::OutputSize output_size;
    if (!args->size.empty()) output_size = playback::parse_output_size(args->size);
    output_size.scale = args->scale;
    if (args->fps && !(std::isfinite(*args->fps) && *args->fps > 0))
      fail("--fps: must be a finite number > 0, got {}", *args->fps);
    // The output options of every render source; a video's fps defaults to the source's.
    const auto writer_options = [&](double source_fps, std::vector<double> frame_times) {
      io::FrameWriterOptions o;
      o.fps = args->fps.value_or(source_fps);
      o.alpha = args->alpha;
      o.bit_depth = args->bit_depth;
      o.times = std::move(frame_times);
      o.force = args->force;
      return o;
    };
    std::optional<io::CameraPathFile> path_file;  // read before the model: fail fast
    if (!args->camera_path.empty()) path_file = io::read_camera_path_json(args->camera_path);

    const playback::LoadedModel model = playback::load_model(args->model);
    const auto* model_4d = std::get_if<model::Model>(&model);
    if (path_file) {
      const std::size_t n = path_file->frames.size();
      std::vector<double> path_times(n, args->time.value_or(0.0));  // a static model ignores time
      if (model_4d && !args->time) {
        if (!path_file->timed)
          fail("{}: camera_path entries have no 'render_time'; give --time T for every frame",
               args->camera_path);
        path_times = io::camera_path_times(*path_file, model_4d->grid.first, model_4d->grid.last());
      }
      if (model_4d) model::check_times(*model_4d, path_times, "render");
      std::vector<Camera> cameras;
      for (const auto& frame : path_file->frames)
        cameras.push_back(playback::at_output_size(frame.camera, output_size));
      io::FrameWriter writer(args->out, int(n), writer_options(path_file->fps, path_times));
      playback::render_camera_frames(model, cameras, path_times, background.data(), writer,
                                     render_options);
      spdlog::info("rendered {} frame{} to {}", n, n > 1 ? "s" : "", args->out);
      return;
    }
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
        check_frame_count(args->path_frames, "--path-frames");
        frame_times.assign(args->path_frames, frame_times[0]);  // bullet time
      }
    } else {
      path = {scene.cameras[scene.camera_index(args->camera)]};
    }

    for (Camera& c : path) c = playback::at_output_size(c, output_size);

    const int frames = int(frame_times.size());
    io::FrameWriter writer(args->out, frames, writer_options(scene.fps, frame_times));
    playback::render_frames(model, path, frame_times, background.data(), writer, render_options);
    spdlog::info("rendered {} frame{} to {}", frames, frames > 1 ? "s" : "", args->out);
  });
}

}  // namespace retimegs::app
