#pragma once
// The training step on the CPU (train/step.hpp): the RetimeGS step of docs/method.md on one
// (camera, frame) view: triple rendering at interior training frames with flow supervision of
// each group, L1 + SSIM and regularisers, Adam per parameter group, SH degree schedule
// (train/schedule.hpp); MCMC relocation and growth, noise and dynamic stretching in the density
// strategy. Threads: OpenMP.
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
#include <random>
#include <string>
#include <vector>

#include "retimegs/core/ssim.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/temporal_index.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/adam.hpp"
#include "retimegs/train/config.hpp"
#include "retimegs/train/dataset.hpp"
#include "retimegs/train/schedule.hpp"
#include "retimegs/train/step.hpp"
#include "retimegs/train/step_state.hpp"
#include "retimegs/train/strategy.hpp"

namespace retimegs::train {

class CpuStep final : public TrainingStep {
 public:
  CpuStep(const TrainingSet& set, const TrainConfig& config);

  std::string initialize() override { return state_.initialize(); }
  void initialize(model::Primitives primitives) override {
    state_.initialize(std::move(primitives));
  }
  StepStats step() override;
  StepStats step_view(int camera, int frame) override;
  std::string finish() override { return state_.final_prune(); }

  int iteration() const override { return state_.iteration; }
  std::size_t primitive_count() const override { return state_.model.primitives.size(); }
  model::Model host_model() const override { return state_.model; }
  // The model itself: the CPU step's state is on the host.
  const model::Model& model() const { return state_.model; }

  void save_checkpoint(const std::filesystem::path& dir) const override {
    state_.save_checkpoint(dir);
  }
  void load_checkpoint(const std::filesystem::path& dir) override { state_.load_checkpoint(dir); }

 private:
  // Renders view (camera index c, frame index i), adds its losses against target_ to `stats` (PSNR
  // of the all-primitives render) and their gradient to `grads`.
  // Slices only the ascending `active` rows.
  void render_pass(const RenderPass& pass, int c, int i, const std::vector<std::int32_t>& active,
                   double w_flow, StepStats& stats, model::PrimitiveGrads& grads);

  const TrainingSet& set_;
  TrainConfig config_;
  StepState state_;
  // The step's gradient, reused across steps: all zero between steps (the optimiser clears the
  // rows it read, the step's active set, in its fields; a representation writes only the fields
  // it optimises; grown rows start zero).
  model::PrimitiveGrads grads_;
  // Reused across steps and passes: the step's view unpacked, a render's RGB copy and the
  // gradient with respect to the render.
  Image target_, rgb_, v_image_;
  Camera camera_;           // the step's camera, through its pose correction
  Image corrected_;         // the render through its camera's colour correction (reused)
  SsimTarget ssim_target_;  // target_'s side of SSIM, shared by the step's renders
  model::Shaded shaded_;    // the SH colours of the step's view, shared by its renders
  // Reused likewise, so that a step allocates no large block: the sliced batch of each group
  // (indexed by model::Group; a group's batch size changes little from step to step), the render
  // with its saved state and the gradient with respect to the batch.
  std::array<model::TimeSlice, 3> slices_;
  render::RenderOutput render_;
  GaussianGrads v_gaussians_;
  std::unique_ptr<DensityStrategy> strategy_;
};

}  // namespace retimegs::train
