#pragma once
// The training step as a unit that owns its state on one device (DESIGN.md §3): the primitives,
// their Adam moments and gradients, the per-camera colours, the training images and the
// generator. One step draws a view (or is given one), renders it (train/schedule.hpp decides the
// passes), adds the losses' gradient, steps the optimisers and calls the density strategy.
// The run above it (train_run/run.hpp: schedule of iterations, checkpoints, resume, logs, locks,
// interrupts) sees only this interface and asks for host copies at checkpoints and at the end.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include "retimegs/cuda/device.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"

namespace retimegs::train {

// Wall-clock seconds of one step by stage (training throughput: bench/train_bench).
struct StageSeconds {
  double slice = 0;            // model::slice of every render pass
  double render_forward = 0;   // rasterize_forward
  double losses = 0;           // image and flow losses with their gradient, the log's PSNR
  double render_backward = 0;  // rasterize_backward
  double slice_backward = 0;   // model::slice_backward
  double optimizer = 0;        // regulariser and Adam
  double total = 0;            // the whole step (the rest: view choice, strategy, bookkeeping)
  StageSeconds& operator+=(const StageSeconds& o) {
    slice += o.slice, render_forward += o.render_forward, losses += o.losses;
    render_backward += o.render_backward, slice_backward += o.slice_backward;
    optimizer += o.optimizer, total += o.total;
    return *this;
  }
  double other() const {
    return total - slice - render_forward - losses - render_backward - slice_backward - optimizer;
  }
};

struct StepStats {
  int iteration = 0;
  int camera = 0, frame = 0;  // scene indices of this step's view
  int renders = 0;
  double loss = 0, image_loss = 0, flow_loss = 0;
  // Of the all-primitives render, through the camera's colour correction (core/psnr.hpp: +infinity
  // on a perfect match).
  double psnr = 0;
  double flow_weight = 0, lr_means = 0;
  std::size_t primitives = 0, relocated = 0, added = 0, stretched = 0, pruned = 0;
  std::size_t active = 0;  // rows in the step's active set (model::TemporalIndex)
  StageSeconds seconds;
};

class TrainingStep {
 public:
  virtual ~TrainingStep() = default;

  // Initial primitives (flow-aware, STGS or random fallback); returns the note to log.
  virtual std::string initialize() = 0;
  // Starts from the given primitives instead (fresh optimiser state).
  virtual void initialize(model::Primitives primitives) = 0;
  // One step on a view drawn from the step's generator.
  virtual StepStats step() = 0;
  // One step on view (set.cameras[camera], set.frames[frame]): what step() does once it has drawn.
  virtual StepStats step_view(int camera, int frame) = 0;
  // After the last step: removes train::faint_short_rows at config.final_prune_opacity (not for
  // STGS, whose windows are not intervals), with their optimiser state; returns the note to log.
  virtual std::string finish() = 0;

  virtual int iteration() const = 0;
  virtual std::size_t primitive_count() const = 0;
  // The most device memory the step's buffers held at once, bytes (0 for a step on the host).
  virtual std::size_t device_memory_peak() const { return 0; }
  // A host copy of the model (with the camera colours).
  virtual model::Model host_model() const = 0;

  // A checkpoint folder (train/checkpoint.hpp), written atomically; loading restores the state
  // that a run continues bit for bit.
  virtual void save_checkpoint(const std::filesystem::path& dir) const = 0;
  virtual void load_checkpoint(const std::filesystem::path& dir) = 0;
};

// The step for `config` on `set` (which must outlive it) on `device` (cuda::resolve_device; the
// CUDA step needs a build with the CUDA backend: Error otherwise).
std::unique_ptr<TrainingStep> make_step(const TrainingSet& set, const TrainConfig& config,
                                        cuda::Device device = cuda::Device::kCpu);

}  // namespace retimegs::train
