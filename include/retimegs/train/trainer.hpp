#pragma once
// The RetimeGS optimisation loop (docs/method.md): one (camera, frame) per step, triple rendering
// at interior training frames with flow supervision of each group, L1 + SSIM and regularisers, Adam
// per parameter group, SH degree schedule; MCMC relocation and growth, noise and dynamic
// stretching in the density strategy; checkpoints that resume bit-identically.
//
// A step at training frame i works on its active set, model::TemporalIndex::rows_at(i): the
// rows its renders can draw. Evaluation, the regulariser, Adam (selective), noise and the
// clearing of the gradient buffer cover those rows only, so a step costs what is visible at its
// time. The index is rebuilt whenever the windows may have changed: at the start, after loading
// a checkpoint and after every strategy call that changed the primitives.
//
// Per-camera colour (model::CameraColor, unless ablated): every render pass of a step compares
// exp(m_c) ⊙ RGB + c_c of its camera c with the target; Adam updates (m_c, c_c) at every step of
// camera c. The model stores them by camera name.
#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "retimegs/core/ssim.hpp"
#include "retimegs/model/evaluate.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/temporal_index.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/adam.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"
#include "retimegs/train/strategy.hpp"

namespace retimegs::train {

// Wall-clock seconds of one step by stage (training throughput: bench/train_bench).
struct StageSeconds {
  double evaluate = 0;           // model::evaluate of every render pass
  double render_forward = 0;     // rasterize_forward
  double losses = 0;             // image and flow losses with their gradient, the log's PSNR
  double render_backward = 0;    // rasterize_backward
  double evaluate_backward = 0;  // model::evaluate_backward
  double optimizer = 0;          // regulariser and Adam
  double total = 0;              // the whole step (the rest: view choice, strategy, bookkeeping)
  StageSeconds& operator+=(const StageSeconds& o) {
    evaluate += o.evaluate, render_forward += o.render_forward, losses += o.losses;
    render_backward += o.render_backward, evaluate_backward += o.evaluate_backward;
    optimizer += o.optimizer, total += o.total;
    return *this;
  }
  double other() const {
    return total - evaluate - render_forward - losses - render_backward - evaluate_backward -
           optimizer;
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

class Trainer {
 public:
  Trainer(const TrainingSet& set, const TrainConfig& config);

  // Initial primitives (flow-aware, STGS or random fallback); returns the note to log.
  std::string initialize();
  // Starts from the given primitives instead (fresh optimiser state).
  void initialize(model::Primitives primitives);
  // One step on a view drawn from the generator.
  StepStats step();
  // One step on view (set.cameras[camera], set.frames[frame]): what step() does once it has drawn.
  StepStats step_view(int camera, int frame);

  // After the last step: removes train::faint_short_rows at config.final_prune_opacity (not for
  // STGS, whose windows are not intervals), with their optimiser state; returns the note to log.
  std::string finish();

  int iteration() const { return iteration_; }
  const model::Model& model() const { return model_; }

  // A checkpoint folder (written atomically): model.rgs (with the camera colours), state.json,
  // adam/<field>_{m,v}.npy and adam/camera_color_{m,v}.npy.
  void save_checkpoint(const std::filesystem::path& dir) const;
  void load_checkpoint(const std::filesystem::path& dir);

 private:
  // One render of a step's view: triple rendering renders all primitives, then each group
  // compensated (flow on the groups); otherwise all primitives once.
  struct RenderPass {
    model::Group group;
    bool compensate, flow;
  };

  double flow_weight(int it) const;
  double lr_factor(int it) const;
  void make_optimizers();
  // The temporal index of the current primitives, after putting the rows (with their Adam state)
  // in its locality order.
  void rebuild_index();
  bool camera_color() const { return !config_.ablate.no_camera_color; }
  // The colour correction of training camera slot c.
  model::CameraColor color_of(int c) const;
  // Adam step of camera slot c's correction on the step's gradient color_grads_, then the gauge
  // rule; writes every correction into the model.
  void step_camera_color(int c, double decay);
  // Triple at interior frames (frame index i), one render at the ends and for STGS.
  std::vector<RenderPass> render_passes(int i, bool flow) const;
  // Renders view (camera index c, frame index i), adds its losses against target_ to `stats` (PSNR
  // of the all-primitives render) and their gradient to `grads`.
  // Evaluates only the ascending `active` rows.
  void render_pass(const RenderPass& pass, int c, int i, const std::vector<std::int32_t>& active,
                   double w_flow, StepStats& stats, model::PrimitiveGrads& grads);

  const TrainingSet& set_;
  TrainConfig config_;
  model::Model model_;
  Optimizers adam_;
  model::TemporalIndex index_;
  // The step's gradient, reused across steps: all zero between steps (the optimiser clears the
  // rows it read, the step's active set, in its fields; a representation writes only the fields
  // it optimises; grown rows start zero).
  model::PrimitiveGrads grads_;
  // Reused across steps and passes: the step's view unpacked, a render's RGB copy and the
  // gradient with respect to the render.
  Image target_, rgb_, v_image_;
  // Per-camera colour: parameters [cameras, 6] (m then c, training camera slots), their Adam, the
  // step's gradient [cameras, 6] (zero between steps) and the corrected render (reused).
  std::vector<float> colors_, color_grads_;
  Adam color_adam_;
  Image corrected_;
  SsimTarget ssim_target_;  // target_'s side of SSIM, shared by the step's renders
  model::Shaded shaded_;    // the SH colours of the step's view, shared by its renders
  // Reused likewise, so that a step allocates no large block: the evaluated batch of each group
  // (indexed by model::Group; a group's batch size changes little from step to step), the render
  // with its saved state and the gradient with respect to the batch.
  std::array<model::Evaluated, 3> evaluated_;
  render::RenderOutput render_;
  GaussianGrads v_gaussians_;
  std::unique_ptr<DensityStrategy> strategy_;
  std::mt19937_64 rng_;
  int iteration_ = 0;
};

struct TrainRun {
  std::filesystem::path out;  // RUN/
  TrainConfig config;
  io::FrameSelection frames = io::FrameSelection::kEven;
  // Set: train only the training frames within it; the model keeps the clip's grid and records
  // the window (model/window.hpp), for `merge`.
  std::optional<io::FrameWindow> window;
  bool resume = false;
  // With resume: the new total of iterations (--iters), which replaces config.json's; the
  // schedules follow the new total from the resume point on.
  std::optional<int> iters;
  bool force = false;  // replace an existing run's outputs (not with resume)
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
