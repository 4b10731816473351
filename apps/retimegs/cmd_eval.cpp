// retimegs eval (--model MODEL | --baseline crossfade|nearest|flow) --scene SCENE
//               [--frames odd|all|LIST] [--cameras LIST] [--train-frames even|all] [--stability]
//               [--lpips-weights DIR] [--save-renders DIR] [--near D] [--device cpu|cuda|auto]
//               --out METRICS.json
#include <filesystem>
#include <memory>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/eval/protocol.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/playback/render_model.hpp"

namespace retimegs::app {
namespace fs = std::filesystem;

void add_eval_command(CLI::App& app) {
  struct Args {
    std::string model, baseline, scene, frames = "odd", cameras, lpips, save, out,
                                        train_frames = "even";
    int threads = 0;
    std::optional<double> near;
    bool stability = false, force = false;
    std::string device;  // add_device_option's default
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "eval",
      "Render held-out frames and score them against the ground truth (PSNR, SSIM, "
      "LPIPS; inside the masks when the scene has them, and on the whole image) as JSON.");
  auto* model = cmd->add_option("--model", args->model, "model (.rgs, or a static .ply)")
                    ->check(input_file("a model"));
  auto* baseline = cmd->add_option("--baseline", args->baseline,
                                   "score a 2D in-betweening of the neighbouring training frames "
                                   "instead: crossfade (blend), nearest (copy of the closer) or "
                                   "flow (interpolation along their optical flow, occlusion-aware; "
                                   "the scene's flow files, else estimated with DIS)")
                       ->check(CLI::IsMember({"crossfade", "nearest", "flow"}));
  model->excludes(baseline);
  cmd->add_option("--scene", args->scene, "scene folder")->required();
  cmd->add_option("--frames", args->frames, "odd, all, or a list like 1,3,5")
      ->capture_default_str();
  cmd->add_option("--cameras", args->cameras,
                  "camera names, comma-separated (default: every camera)");
  cmd->add_option(
         "--train-frames", args->train_frames,
         "the training frames the baselines blend and --stability runs through: even or all")
      ->check(CLI::IsMember({"even", "all"}))
      ->capture_default_str();
  cmd->add_flag("--stability", args->stability,
                "also measure temporal stability: the largest mean absolute change, in 8-bit "
                "levels, between consecutive frames of an 8x slow-motion render through the "
                "training frames, over pixels static in the ground truth");
  cmd->add_option("--lpips-weights", args->lpips,
                  "LPIPS-squeeze weights folder (default: the repository's "
                  "data/lpips_squeeze/weights; without weights lpips is null)");
  cmd->add_option("--save-renders", args->save, "also write DIR/<camera>/<frame:05d>.png");
  auto* near = add_near_option(*cmd, args->near);
  cmd->add_option("--out", args->out, "metrics JSON to write")->required();
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  add_device_option(*cmd, args->device);
  cmd->add_flag("--force", args->force, "replace an existing --out file and --save-renders folder");
  cmd->callback([args, near] {
    set_threads(args->threads);
    std::vector<InputPath> inputs = scene_inputs(args->scene);
    inputs.push_back({args->model, "model"});
    inputs.push_back({args->lpips, "LPIPS weights folder", true});
    check_output_overlap(args->out, "--out", inputs);
    if (!args->save.empty()) check_output_overlap(args->save, "--save-renders", inputs);
    check_output_free(args->out, args->force);
    if (!args->save.empty()) check_output_free(output_path(args->save), args->force);
    if (args->model.empty() == args->baseline.empty()) fail("eval: give --model or --baseline");
    if (!args->baseline.empty() && near->count() > 0)
      fail("--near {}: a baseline renders no Gaussians; give --near with --model", *args->near);
    const cuda::Device device = cuda::resolve_device(args->device);
    const io::Scene scene = media::read_scene(args->scene);
    const double near_plane = playback::near_plane(args->near, scene);
    eval::EvalOptions options;
    options.frames = eval::parse_frames(args->frames, scene.num_frames, "--frames");
    if (!args->cameras.empty()) {
      for (const auto& name : split_list(args->cameras, "--cameras"))
        options.cameras.push_back(scene.camera_index(name));
      if (!args->baseline.empty())
        eval::check_baseline_cameras(scene, options.cameras, "--cameras");
    } else if (!args->baseline.empty()) {
      options.cameras = io::training_cameras(scene);
    } else {
      for (int c = 0; c < int(scene.cameras.size()); ++c) options.cameras.push_back(c);
    }
    if (!args->lpips.empty()) {
      if (!fs::is_directory(args->lpips)) fail("--lpips-weights: {}: no such folder", args->lpips);
      options.lpips_weights = fs::path(args->lpips);
    } else if (fs::is_directory(RETIMEGS_DEFAULT_LPIPS_WEIGHTS)) {
      options.lpips_weights = fs::path(RETIMEGS_DEFAULT_LPIPS_WEIGHTS);
    }
    if (!args->save.empty()) options.save_renders = fs::path(args->save);
    options.replace_renders = args->force;
    const std::vector<int> train_frames =
        io::training_views(scene, io::parse_frame_selection(args->train_frames, "--train-frames"))
            .frames;
    if (args->stability) options.stability_frames = train_frames;

    eval::FrameRenderer renderer;
    if (!args->baseline.empty()) {
      renderer = eval::baseline_renderer(scene, train_frames,
                                         eval::parse_baseline(args->baseline, "--baseline"));
    } else {
      playback::LoadedModel loaded = playback::load_model(args->model);
      if (const auto* m = std::get_if<model::Model>(&loaded))
        for (const int seam : m->config.seams) options.seams.push_back(m->grid.at(seam));
      renderer = eval::model_renderer(scene, std::move(loaded),
                                      playback::near_render_options(near_plane), device);
    }
    spdlog::info("evaluating {} views{} on {}", options.cameras.size() * options.frames.size(),
                 args->stability ? " and temporal stability" : "",
                 args->baseline.empty() ? cuda::describe(device) : "cpu (a baseline)");
    eval::EvalResult result = eval::evaluate_views(scene, renderer, options);
    if (args->baseline.empty()) result.near = near_plane;
    eval::write_json(result, args->out, /*replace=*/args->force);
    if (!result.note.empty()) spdlog::info("{}", result.note);
    // A value with `digits` decimals, or null.
    const auto text = [](const std::optional<double>& v, int digits) {
      return v ? fmt::format("{:.{}f}", *v, digits) : std::string("null");
    };
    // One row per kind of view, so that a training camera's held-out frames (time filled in) and
    // a test camera (a view no training camera had) are never read as one figure.
    spdlog::info("{:<34} {:>5}  {:>7}  {:>6}  {:>6}  {:>10}", "", "views",
                 result.masked ? "psnr*" : "psnr", "ssim", "lpips", "whole psnr");
    const auto row = [&](const char* what, const eval::Summary& s) {
      spdlog::info("{:<34} {:>5}  {:>7.3f}  {:>6.4f}  {:>6}  {:>10.3f}", what, s.views, s.psnr,
                   s.ssim, text(s.lpips, 4), s.whole.psnr);
    };
    if (result.train_views) row("training cameras, held-out frames", *result.train_views);
    if (result.test_views) row("test cameras (novel views)", *result.test_views);
    if (result.train_views && result.test_views)
      row("all views", {result.per_view.size(), result.psnr, result.ssim, result.lpips,
                        result.masked, result.whole});
    spdlog::info("{}-> {}", result.masked ? "* inside the masks; " : "", args->out);
    if (const auto& s = result.stability) {
      spdlog::info("stability: largest change {} levels (mean over cameras {})", text(s->max, 3),
                   text(s->mean, 3));
      if (!s->seams.empty())
        spdlog::info("stability at the {} seams: {} levels; at the other training frames: {}",
                     s->seams.size(), text(s->max_at_seams, 3), text(s->max_at_training_frames, 3));
    }
  });
}

}  // namespace retimegs::app
