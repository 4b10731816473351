// retimegs slurm --scene S --out RUN --windows N [--overlap N] [--train-frames even|all] [--iters
// N]
//                [--preset P] [--config FILE] [--cap N] [--seed S] [--downscale F]
//                [--sbatch-arg ARG ...]
//                [--merge-sbatch-arg ARG ...] [--submit] [--force]
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/cluster/slurm.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::app {

void add_slurm_command(CLI::App& app) {
  struct Args {
    std::string scene, out, frames = "even", preset, config;
    int windows = 0, overlap = cluster::kDefaultWindowOverlap;
    std::optional<int> iters;
    std::optional<std::size_t> cap;
    std::optional<std::uint64_t> seed;
    std::optional<double> downscale;
    std::vector<std::string> sbatch_args, merge_sbatch_args;
    bool submit = false, force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "slurm",
      "Train a long clip as time windows on a Slurm cluster: writes RUN/slurm/train.sbatch (a job "
      "array, one task per window: prepare, then train --window), RUN/slurm/merge.sbatch (merge, "
      "after the array) and RUN/slurm/run_local.sh (the same steps on this machine). "
      "Resubmitting resumes.");
  cmd->add_option("--scene", args->scene, "scene folder (on a file system the nodes share)")
      ->required();
  cmd->add_option("--out", args->out, "run folder: RUN/windows/K, RUN/model.rgs, RUN/slurm/")
      ->required();
  cmd->add_option("--windows", args->windows, "number of time windows (one array task each)")
      ->required();
  cmd->add_option("--overlap", args->overlap,
                  "training intervals each window trains beyond each seam, so that the merge hands "
                  "over between two reconstructions of the same frames (0: windows only share "
                  "their boundary frame)")
      ->default_str(
          fmt::format("{}, or the most the windows allow", cluster::kDefaultWindowOverlap));
  cmd->add_option("--train-frames", args->frames, "even or all, as for train")
      ->check(CLI::IsMember({"even", "all"}))
      ->capture_default_str();
  cmd->add_option("--iters", args->iters, "iterations of each window");
  cmd->add_option("--preset", args->preset, "budget preset of each window (as for train)");
  cmd->add_option("--config", args->config, "training config file of each window")
      ->check(input_file("a config"));
  cmd->add_option("--cap", args->cap, "primitive budget of each window");
  cmd->add_option("--seed", args->seed, "random seed of each window")->check(whole_number());
  cmd->add_option("--downscale", args->downscale,
                  "each window trains on the images at 1/F of their size (as for train)");
  cmd->add_option("--sbatch-arg", args->sbatch_args,
                  "an sbatch option for the window jobs (train.sbatch), repeatable: "
                  "--sbatch-arg=--partition=gpu --sbatch-arg=--gres=gpu:1");
  cmd->add_option("--merge-sbatch-arg", args->merge_sbatch_args,
                  "an sbatch option for the merge job alone (a short CPU job), repeatable: "
                  "--merge-sbatch-arg=--partition=cpu --merge-sbatch-arg=--time=0:30:00");
  cmd->add_flag("--submit", args->submit,
                "submit both jobs with sbatch (merge with --dependency=afterok) and print their "
                "ids");
  cmd->add_flag("--force", args->force,
                "rewrite the run's scripts when they differ (other settings); the same ones are "
                "kept, so that submitting again resumes");
  cmd->callback([args] {
    namespace fs = std::filesystem;
    // RUN receives the windows' runs, their merged model and the scripts: it must be a folder (or
    // not exist yet) and hold none of the scene's files or the config.
    std::vector<InputPath> inputs = scene_inputs(args->scene);
    inputs.push_back({args->scene, "scene"});
    if (!args->config.empty()) inputs.push_back({args->config, "config file"});
    const fs::path run = args->out;
    for (const fs::path& out : {run, run / "slurm", run / "windows", run / "model.rgs"})
      check_output_overlap(out, "--out", inputs);
    if (fs::exists(run) && !fs::is_directory(run))
      fail("--out {}: is not a folder (the run folder of the windows, their merge and the scripts)",
           run.string());
    // Every window's training settings are checked here, as train checks them, so that a typo
    // is refused now rather than by every array task on the cluster.
    training_config(args->preset.empty() ? "default" : args->preset, args->config, args->iters,
                    args->cap, args->seed);
    if (args->downscale) check_downscale(*args->downscale);
    cluster::SlurmJob job;
    job.force = args->force;
    job.binary = std::filesystem::read_symlink("/proc/self/exe");
    job.scene = args->scene;
    job.run = args->out;
    job.windows = args->windows;
    job.overlap = args->overlap;
    job.train_frames = args->frames;
    job.sbatch_args = args->sbatch_args;
    job.merge_sbatch_args = args->merge_sbatch_args;
    if (!args->preset.empty())
      job.train_args.insert(job.train_args.end(), {"--preset", args->preset});
    if (!args->config.empty())
      job.train_args.insert(job.train_args.end(),
                            {"--config", std::filesystem::absolute(args->config).string()});
    if (args->iters)
      job.train_args.insert(job.train_args.end(), {"--iters", std::to_string(*args->iters)});
    if (args->cap)
      job.train_args.insert(job.train_args.end(), {"--cap", std::to_string(*args->cap)});
    if (args->seed)
      job.train_args.insert(job.train_args.end(), {"--seed", std::to_string(*args->seed)});
    if (args->downscale)  // {}: the shortest form that reads back as the same double
      job.train_args.insert(job.train_args.end(),
                            {"--downscale", fmt::format("{}", *args->downscale)});
    const io::Scene scene = media::read_scene(args->scene);
    const cluster::SlurmScripts scripts = cluster::write_slurm_scripts(job, scene);
    std::string windows;
    for (const io::FrameWindow& w : scripts.windows)
      windows += fmt::format("{}{}:{}", windows.empty() ? "" : " ", w.first, w.last);
    spdlog::info("{} windows ({}): {}, {}, {}", scripts.windows.size(), windows,
                 scripts.train.string(), scripts.merge.string(), scripts.local.string());
    if (!args->submit) return;
    const cluster::SubmittedJobs jobs = cluster::submit(scripts);
    std::printf("train %s\nmerge %s\n", jobs.train.c_str(), jobs.merge.c_str());
  });
}

}  // namespace retimegs::app
