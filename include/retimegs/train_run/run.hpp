#pragma once
// The `train` command's run (DESIGN.md §3): the run folder, its lock and temporaries, the
// configuration, resume from the newest checkpoint, the loop over iterations with its progress
// bar, log lines, checkpoint cadence and interrupts. It drives a train::TrainingStep and knows
// nothing of where the step's arrays live.
#include <filesystem>
#include <optional>

#include "retimegs/cuda/device.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/train/config.hpp"

namespace retimegs::train {

struct TrainRun {
  std::filesystem::path out;  // RUN/
  TrainConfig config;
  io::FrameSelection frames = io::FrameSelection::kEven;
  // Set: train only the training frames within it; the model keeps the clip's grid and records
  // the window (model/window.hpp), for `merge`.
  std::optional<io::FrameWindow> window;
  // Train on the images at 1/downscale of their size (load_training_set); >= 1.
  double downscale = 1.0;
  bool resume = false;
  // With resume: the new total of iterations (--iters), which replaces config.json's; the
  // schedules follow the new total from the resume point on.
  std::optional<int> iters;
  bool force = false;  // replace an existing run's outputs (not with resume)
  // Where the steps run (cuda::resolve_device). Checkpoints are the same on both devices: a run
  // resumes on either.
  cuda::Device device = cuda::Device::kCpu;
  bool progress = true;
};

// The `train` command: RUN/model.rgs, RUN/config.json, RUN/log.jsonl, RUN/checkpoints/. Returns
// the final model.
//
// Every input is read before RUN is created; RUN is locked (core/folder_lock.hpp) for the whole
// run, and temporaries left by a kill are removed at the start. A checkpoint is written every
// config.checkpoint_every steps and at the last step. On Ctrl-C / SIGTERM the current step
// finishes, a checkpoint is written and Interrupted is thrown naming it.
model::Model train(const io::Scene& scene, const TrainRun& run);

}  // namespace retimegs::train
