// retimegs train --scene SCENE --out RUN [--train-frames even|all]
//                [--preset fast|default|quality|paper] [--iters N] [--cap N] [--config FILE]
//                [--ablate LIST] [--baseline stgs]
//                [--seed S] [--threads T] [--device cpu|cuda|auto] [--window A:B] [--downscale F]
//                [--resume]
#include <fstream>
#include <memory>
#include <optional>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/train_run/run.hpp"

namespace retimegs::app {

void add_train_command(CLI::App& app) {
  struct Args {
    std::string scene, out, frames = "even", preset = "default", config, ablate, baseline, window;
    std::optional<int> iters;
    std::optional<std::size_t> cap;
    std::optional<std::uint64_t> seed;
    std::string device;  // add_device_option's default
    int threads = 0;
    double downscale = 1.0;
    bool resume = false, force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "train",
      "Optimise the 4D model of a scene: RUN/model.rgs, RUN/config.json, RUN/log.jsonl, "
      "RUN/checkpoints/.");
  cmd->add_option("--scene", args->scene, "scene folder")->required();
  cmd->add_option("--out", args->out, "run folder")->required();
  cmd->add_option("--train-frames", args->frames,
                  "even: train on frames 0, 2, 4, ... (odd frames held out); all: every frame")
      ->check(CLI::IsMember({"even", "all"}))
      ->capture_default_str();
  cmd->add_option(
         "--preset", args->preset,
         "preset: " + train::describe_presets() +
             "; --config, --iters and --cap override it. Every preset trains over a random "
             "background colour per step on a capture without masks (a matte for render "
             "--alpha), over black on one with masks; the config's random_background chooses")
      ->capture_default_str();
  cmd->add_option("--iters", args->iters,
                  "iterations (milestones scale with it); with --resume, the new total to "
                  "continue to");
  cmd->add_option("--config", args->config, "JSON file overriding any hyper-parameter")
      ->check(input_file("a config"));
  cmd->add_option("--ablate", args->ablate, "comma-separated: " + train::ablation_names());
  cmd->add_option("--baseline", args->baseline, "stgs: the SpacetimeGaussians representation")
      ->check(CLI::IsMember({"stgs"}));
  cmd->add_option("--cap", args->cap, "primitive budget (MCMC cap)");
  cmd->add_option("--seed", args->seed, "random seed")->default_str("0")->check(whole_number());
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  cmd->add_option("--window", args->window,
                  "A:B: train only scene frames A..B (training frames; their flows and points), "
                  "a window of a long clip for `retimegs merge`");
  cmd->add_option("--downscale", args->downscale,
                  "train on the images at 1/F of their size (intrinsics, masks and flows follow; "
                  "gsplat's --data_factor); the model renders at any size")
      ->capture_default_str();
  add_device_option(*cmd, args->device);
  auto* resume = cmd->add_flag("--resume", args->resume, "continue RUN from its latest checkpoint");
  cmd->add_flag("--force", args->force,
                "start afresh over an existing run (its model, config, log and checkpoints are "
                "removed first)")
      ->excludes(resume);
  cmd->callback([args] {
    set_threads(args->threads);
    // The run's outputs (removed by --force) must not be the scene's or the config's files.
    std::vector<InputPath> inputs = scene_inputs(args->scene);
    inputs.push_back({args->config, "config file"});
    const std::filesystem::path out = args->out;
    check_output_overlap(out, "--out", inputs);
    for (const char* name : {"model.rgs", "config.json", "log.jsonl", "checkpoints"})
      check_output_overlap(out / name, "--out", inputs);
    train::TrainRun run;
    run.out = args->out;
    run.resume = args->resume;
    run.iters = args->iters;
    run.force = args->force;
    run.device = cuda::resolve_device(args->device);
    run.downscale = args->downscale;
    run.frames = io::parse_frame_selection(args->frames, "--train-frames");
    if (!args->window.empty()) run.window = io::parse_frame_window(args->window, "--window");
    train::TrainConfig& config = run.config;
    config = training_config(args->preset, args->config, args->iters, args->cap, args->seed);
    if (!args->baseline.empty()) config.stgs_baseline = true;
    config.ablate = train::parse_ablations(args->ablate, config.ablate, "--ablate");
    const io::Scene scene = media::read_scene(args->scene);
    train::train(scene, run);
  });
}

}  // namespace retimegs::app
