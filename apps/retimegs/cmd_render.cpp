// retimegs render --model MODEL --scene SCENE --camera NAME (--time T | --times A:B:STEP |
//                 --slowmo F | --retime FILE) [--own-clock] [--path CAM,CAM,...] [--near D]
//                 --out OUT
// retimegs render --model MODEL --scene SCENE --camera-path camera_path.json [--time T] --out OUT
//   outputs: [--size WxH | --scale S] [--fps F] [--crf N] [--alpha] [--bit-depth 8|16]
//   [--exr half|float] [--depth] [--force]
//   [--device cpu|cuda|auto] [--threads T]
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/io/camera_path_json.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/frame_writer.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/playback/output_size.hpp"
#include "retimegs/playback/shot.hpp"

namespace retimegs::app {

void add_render_command(CLI::App& app) {
  struct Args {
    std::string model, scene, path, times, retime, out, background = "0,0,0";
    playback::SceneShotRequest shot;  // --camera, --time, --slowmo and --path-frames
    int threads = 0;
    std::optional<double> near;
    bool force = false;
    std::string camera_path;  // nerfstudio camera_path.json
    std::string size;         // --size WxH
    std::optional<double> scale, fps;
    std::optional<int> crf;
    bool alpha = false, depth = false;
    int bit_depth = 8;
    std::string exr;
    std::string device;  // add_device_option's default
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
  auto* camera = cmd->add_option("--camera", args->shot.camera,
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
  auto* time =
      cmd->add_option("--time", args->shot.time,
                      "one time, in scene frame units, within the model's time range (a static "
                      ".ply needs none)");
  auto* times = cmd->add_option("--times", args->times, "times A:B:STEP (inclusive of B)");
  cmd->add_flag("--own-clock", args->shot.own_clock,
                "with --camera: the times are the camera's own frame positions (its frame k at "
                "k), each drawn at its scene time on the camera's clock (scene.json time_offset, "
                "frame_times, with the model's clock correction), to reproduce its frames")
      ->needs(camera);
  auto* slowmo = cmd->add_option("--slowmo", args->shot.slowmo,
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
  cmd->add_option("--path-frames", args->shot.path_frames,
                  "frames of a --path move at a fixed --time (bullet time)")
      ->capture_default_str();
  cmd->add_option("--out", args->out,
                  "output: x.png or x.exr (one frame), x.mp4 / x.mov / x.mkv (H.264, through the "
                  "ffmpeg program), x.avi (Motion-JPEG) or a folder of PNGs (EXRs with --exr) "
                  "with times.csv")
      ->required();
  cmd->add_option("--fps", args->fps,
                  "frame rate of a video (default: the scene's; a --camera-path file's own)");
  cmd->add_option("--crf", args->crf,
                  "H.264 outputs: libx264's constant quality, 0 (lossless; High 4:4:4 profile, "
                  "which browsers do not play) to 51 (coarsest); 16 to 18 is near-lossless "
                  "(default: 23, x264's)");
  auto* size = cmd->add_option("--size", args->size,
                               "render at WxH, the camera's aspect ratio (intrinsics scaled; "
                               "default: the camera's size)");
  auto* scale = cmd->add_option("--scale", args->scale,
                                "render at the camera's size times S, rounded (intrinsics scaled)");
  size->excludes(scale);
  cmd->add_flag("--alpha", args->alpha,
                "image outputs: RGBA, alpha = the render's opacity (PNG: straight colour; EXR: "
                "premultiplied)");
  cmd->add_option("--bit-depth", args->bit_depth, "PNG outputs: 8 or 16 bits per channel")
      ->check(CLI::IsMember({8, 16}))
      ->capture_default_str();
  cmd->add_option("--exr", args->exr,
                  "OpenEXR frames, half or 32-bit float per channel, unclamped (alpha "
                  "premultiplied): a folder of EXRs, or x.exr (half by default)")
      ->check(CLI::IsMember({"half", "float"}));
  cmd->add_flag(
      "--depth", args->depth,
      "EXR outputs: also a depth pass per frame, the expected camera z of what each pixel "
      "shows in scene units (1e10 where nothing is drawn), one 32-bit float channel "
      "beside the frame: x.depth.exr, <frame>.depth.exr in a folder");
  cmd->add_option("--background", args->background, "background colour R,G,B in [0, 1]")
      ->capture_default_str();
  add_near_option(*cmd, args->near);
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  add_device_option(*cmd, args->device);
  cmd->add_flag("--force", args->force, "replace an existing output");
  cmd->callback([args] {
    set_threads(args->threads);
    std::vector<InputPath> inputs = scene_inputs(args->scene);
    inputs.push_back({args->model, "model"});
    inputs.push_back({args->camera_path, "camera path file"});
    inputs.push_back({args->retime, "retime file"});
    check_output_overlap(args->out, "--out", inputs);
    // A one-frame output's depth pass is a second file beside it (a folder's are inside it).
    if (args->depth && std::filesystem::path(args->out).has_extension())
      check_output_overlap(media::depth_path(args->out), "--out", inputs);
    const std::vector<float> background = parse_float_list(args->background, "--background", 3);
    const cuda::Device device = cuda::resolve_device(args->device);
    const io::Scene scene = media::read_scene(args->scene, media::SceneCheck::kJson);
    const render::RenderOptions render_options =
        playback::near_render_options(playback::near_plane(args->near, scene));
    playback::SceneShotRequest request = args->shot;
    if (request.camera.empty() && args->path.empty() && args->camera_path.empty())
      fail("render: give --camera, --path or --camera-path");
    if (!args->size.empty()) request.size = playback::parse_output_size(args->size);
    request.size.scale = args->scale;
    if (args->fps) check_fps(*args->fps, "--fps");
    std::optional<io::CameraPathFile> path_file;  // read before the model: fail fast
    if (!args->camera_path.empty()) path_file = io::read_camera_path_json(args->camera_path);

    playback::LoadedModel model = playback::load_model(args->model);
    if (!args->times.empty()) request.times = parse_time_range(args->times, "--times");
    if (!args->path.empty()) request.path = split_list(args->path, "--path");
    request.retime = args->retime;
    const playback::Shot shot =
        path_file ? playback::camera_path_shot(*path_file, request.time, model, request.size)
                  : playback::scene_shot(request, scene, model);
    media::FrameWriterOptions writer_options;
    writer_options.fps = args->fps.value_or(shot.fps);  // a video's: the source's by default
    writer_options.alpha = args->alpha;
    writer_options.bit_depth = args->bit_depth;
    if (!args->exr.empty())
      writer_options.exr =
          args->exr == "float" ? media::ExrPrecision::kFloat : media::ExrPrecision::kHalf;
    writer_options.depth = args->depth;
    writer_options.crf = args->crf;
    writer_options.times = shot.times;
    writer_options.force = args->force;
    const std::size_t frames = shot.times.size();
    media::FrameWriter writer(args->out, int(frames), writer_options);
    spdlog::info("rendering {} frame{} on {}", frames, frames > 1 ? "s" : "",
                 cuda::describe(device));
    const playback::ModelRenderer renderer(std::move(model), device);
    playback::render_shot(renderer, shot, background.data(), writer, render_options);
    spdlog::info("rendered {} frame{} to {}", frames, frames > 1 ? "s" : "", args->out);
  });
}

}  // namespace retimegs::app
