// The CUDA training step (include/retimegs/train/cuda_step.hpp).
#include "retimegs/train/cuda_step.hpp"

#include <cuda_runtime.h>

#include <algorithm>
#include <iterator>
#include <optional>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/core/stopwatch.hpp"
#include "retimegs/cuda/adam.hpp"
#include "retimegs/cuda/buffer.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/losses.hpp"
#include "retimegs/cuda/primitives.hpp"
#include "retimegs/cuda/rasterize.hpp"
#include "retimegs/cuda/slice.hpp"
#include "retimegs/cuda/strategy.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/train/schedule.hpp"
#include "retimegs/train/step_state.hpp"
#include "retimegs/train/strategy.hpp"

namespace retimegs::train {
namespace {

// The numbers a step reads back, one slot each per render pass (device doubles).
enum LossSlot { kImageLoss, kForwardFlowLoss, kBackwardFlowLoss, kSquaredError, kSlotsPerPass };
constexpr std::size_t kPoseSums = 6;
constexpr std::size_t kTimeSums = 1;

// A stage's wall time: the default stream's queue drained first, so that each stage is charged
// its own kernels (a few microseconds per stage, against milliseconds of work). Only that stream:
// the flows' copies (cuda::FlowUploads) run on beside the stages until the flow loss waits.
double lap(Stopwatch& clock) {
  cuda::check(cudaStreamSynchronize(0), "training step");
  return clock.lap();
}

// Every flow of the training set, forward and backward, null where a view has none.
std::vector<const Flow*> all_flows(const TrainingSet& set) {
  std::vector<const Flow*> flows;
  for (const auto* direction : {&set.forward, &set.backward})
    for (const auto& camera : *direction)
      for (const std::optional<Flow>& flow : camera) flows.push_back(flow ? &*flow : nullptr);
  return flows;
}

class CudaStep final : public TrainingStep {
 public:
  CudaStep(const TrainingSet& set, const TrainConfig& config)
      : set_(set),
        config_(config),
        state_(set, config),
        strategy_(config, set.scene_extent),
        flows_(all_flows(set)) {
    images_.resize(set.images.size());
    foreground_.resize(set.images.size());
    for (std::size_t c = 0; c < set.images.size(); ++c) {
      images_[c].resize(set.images[c].size());
      foreground_[c].resize(set.images[c].size());
      for (std::size_t i = 0; i < set.images[c].size(); ++i) {
        images_[c][i].upload(set.images[c][i]);
        if (state_.random_background() && set.masks[c][i])
          foreground_[c][i].upload(foreground_flags(*set.masks[c][i]));
      }
    }
  }

  std::string initialize() override {
    const std::string note = state_.initialize();
    upload();
    return note;
  }
  void initialize(model::Primitives primitives) override {
    state_.initialize(std::move(primitives));
    upload();
  }
  StepStats step() override {
    const auto [c, i] = state_.draw_view();
    return step_view(c, i);
  }
  StepStats step_view(int c, int i) override;
  std::string finish() override {
    download();
    const std::string note = state_.final_prune();
    upload();
    return note;
  }

  int iteration() const override { return state_.iteration; }
  std::size_t primitive_count() const override { return primitives_.size(); }
  std::size_t device_memory_peak() const override { return cuda::device_memory_use().peak; }
  model::Model host_model() const override {
    download();
    return state_.model;
  }
  void save_checkpoint(const std::filesystem::path& dir) const override {
    download();
    state_.save_checkpoint(dir);
  }
  void load_checkpoint(const std::filesystem::path& dir) override {
    state_.load_checkpoint(dir);
    upload();
  }

 private:
  // Relocation's and growth's moves applied to the device rows (RelocatableRows).
  class DeviceRows;
  // The device copy of the host state: primitives, zero gradient, Adam moments, the index's rows.
  void upload();
  // The step's row lists (StepState::rows_of: every frame's, then the unions of views off the
  // grid) uploaded.
  void upload_rows();
  // StepState::rebuild_index on the device rows: the index from their windows, the rows (and their
  // Adam moments) put in its locality order, the index's rows uploaded. The host mirror is left
  // as it was: download() brings it up to date.
  void rebuild_index();
  // The host state brought up to date from the device (primitives and Adam moments).
  void download() const;
  void render_pass(const RenderPass& pass, std::size_t pass_index, int c, int i, double w_flow,
                   StepStats& stats);

  const TrainingSet& set_;
  TrainConfig config_;
  // The host mirror: authoritative after upload() until the next step, brought back by download().
  mutable StepState state_;
  McmcStrategy strategy_;

  cuda::DevicePrimitives primitives_;
  cuda::DevicePrimitiveGrads grads_;    // zero between steps, as the CPU step's
  std::vector<cuda::DeviceAdam> adam_;  // one per state_.adam group, in its order
  // Every row list's rows (StepState::rows_of) one after another; list l's are
  // [row_offsets_[l], row_offsets_[l + 1]).
  cuda::DeviceBuffer<std::int32_t> rows_;
  std::vector<std::size_t> row_offsets_;
  cuda::DeviceBuffer<std::int32_t> row_scratch_;  // index arrays of reshaping: moves, orders
  cuda::DeviceBuffer<float> value_scratch_;

  std::vector<std::vector<cuda::DevicePackedImage>> images_;  // [camera slot][frame slot]
  // With random backgrounds, each view's mask as foreground_flags (empty where it has none).
  std::vector<std::vector<cuda::DeviceBuffer<std::uint8_t>>> foreground_;
  cuda::FlowUploads flows_;  // the step's view's
  cuda::DeviceSsimTarget target_;
  cuda::LossScratch loss_scratch_;
  // [passes, kSlotsPerPass], the regulariser, then the pose correction's sums [kPoseSums]
  // (cuda::camera_pose_sums) and d loss / d t [kTimeSums] (cuda::slice_time_sum).
  cuda::DeviceBuffer<double> losses_;
  double* pose_sums() { return losses_.data() + losses_.size() - kPoseSums - kTimeSums; }
  double* time_sum() { return losses_.data() + losses_.size() - kTimeSums; }
  Camera camera_;  // the step's camera, through its pose correction
  cuda::DeviceBuffer<float> color_, v_color_, corrected_, v_image_;
  cuda::DeviceShaded shaded_;
  std::array<cuda::DeviceTimeSlice, 3> slices_;  // by model::Group, as the CPU step's
  cuda::DeviceRenderOutput render_;
  cuda::DeviceGaussianGrads v_gaussians_;
};

// The device buffers of an optimised field and its gradient, by the optimiser group's name.
std::pair<float*, float*> field_and_gradient(cuda::DevicePrimitives& p,
                                             cuda::DevicePrimitiveGrads& g,
                                             const std::string& name) {
  const std::pair<const char*, std::pair<cuda::DeviceBuffer<float>*, cuda::DeviceBuffer<float>*>>
      fields[] = {{"mu", {&p.mu, &g.v_mu}},
                  {"velocity", {&p.velocity, &g.v_velocity}},
                  {"log_scale", {&p.log_scale, &g.v_log_scale}},
                  {"q0", {&p.q0, &g.v_q0}},
                  {"q1", {&p.q1, &g.v_q1}},
                  {"sh", {&p.sh, &g.v_sh}},
                  {"opacity_logit", {&p.opacity_logit, &g.v_opacity_logit}},
                  {"mu_tau", {&p.mu_tau, &g.v_mu_tau}},
                  {"temporal_log_scale", {&p.temporal_log_scale, &g.v_temporal_log_scale}}};
  for (const auto& [field, buffers] : fields)
    if (name == field) return {buffers.first->data(), buffers.second->data()};
  fail("CUDA training step: no optimised field '{}'", name);
}

template <typename T>
std::vector<T> joined(std::vector<T> a, const std::vector<T>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

class CudaStep::DeviceRows final : public RelocatableRows {
 public:
  explicit DeviceRows(CudaStep& step) : step_(step) {}

  RelocationFields fields() override {
    const cuda::DevicePrimitives& p = step_.primitives_;
    opacity_logit_ = p.opacity_logit.download();
    tau_l_ = p.tau_l.download();
    tau_r_ = p.tau_r.download();
    return {opacity_logit_.data(), tau_l_.data(), tau_r_.data(), p.size()};
  }

  void apply(const RowMoves& moves) override {
    cuda::DevicePrimitives& p = step_.primitives_;
    if (moves.rows != p.size()) {
      p.resize(moves.rows);
      step_.grads_.resize_zero(moves.rows);
      for (cuda::DeviceAdam& adam : step_.adam_) adam.resize(moves.rows);
    }
    cuda::DeviceBuffer<std::int32_t>& rows = step_.row_scratch_;
    cuda::DeviceBuffer<float>& values = step_.value_scratch_;
    const std::size_t n = moves.sources.size();
    rows.upload(moves.sources);
    values.upload(joined(moves.source_logit, moves.source_log_scale_shift));
    cuda::correct_sources(p, rows.data(), values.data(), values.data() + n, n);
    const std::vector<std::int32_t> touched = moves.touched();  // to, then from
    rows.upload(touched);
    p.copy_rows(rows.data(), rows.data() + moves.to.size(), moves.to.size());
    for (cuda::DeviceAdam& adam : step_.adam_) adam.reset_rows(rows.data(), rows.size());
  }

 private:
  CudaStep& step_;
  std::vector<float> opacity_logit_, tau_l_, tau_r_;
};

void CudaStep::upload() {
  primitives_.upload(state_.model.primitives);
  grads_.resize_zero(primitives_.size());
  // Assigned into the same DeviceAdams, which keep their allocations where large enough.
  adam_.resize(std::size_t(std::distance(state_.adam.begin(), state_.adam.end())));
  std::size_t k = 0;
  for (const auto& [name, adam] : state_.adam) adam_[k++].assign(adam);
  upload_rows();
}

void CudaStep::rebuild_index() {
  std::vector<float> mu_tau = primitives_.mu_tau.download(), tau_l = primitives_.tau_l.download(),
                     tau_r = primitives_.tau_r.download();
  const auto index = [&] {
    return model::TemporalIndex(
        model::WindowFields<float>{mu_tau.data(), tau_l.data(), tau_r.data(), mu_tau.size()},
        state_.model.config, state_.model.grid);
  };
  state_.set_index(index());
  const std::vector<std::int32_t> old_from_new = state_.index.locality_order();
  if (!std::is_sorted(old_from_new.begin(), old_from_new.end())) {
    row_scratch_.upload(old_from_new);
    primitives_.reorder(row_scratch_.data(), old_from_new.size());
    for (cuda::DeviceAdam& adam : adam_) adam.reorder(row_scratch_.data(), old_from_new.size());
    for (std::vector<float>* field : {&mu_tau, &tau_l, &tau_r})
      model::reorder_rows(*field, 1, old_from_new);
    state_.set_index(index());
  }
  upload_rows();
}

void CudaStep::upload_rows() {
  std::vector<std::int32_t> rows;
  row_offsets_.assign(1, 0);
  for (int f = 0; f < state_.row_lists(); ++f) {
    const std::vector<std::int32_t>& frame = state_.rows_of(f);
    rows.insert(rows.end(), frame.begin(), frame.end());
    row_offsets_.push_back(rows.size());
  }
  // A frame's list is never a null pointer, which the kernels read as "every row".
  if (rows.empty()) rows.push_back(0);
  rows_.upload(rows);
}

void CudaStep::download() const {
  primitives_.download(state_.model.primitives);
  std::size_t k = 0;
  for (auto& [name, adam] : state_.adam) adam_[k++].download(adam);
}

void CudaStep::render_pass(const RenderPass& pass, std::size_t pass_index, int c, int i,
                           double w_flow, StepStats& stats) {
  const Camera& camera = camera_;
  const model::Model& m = state_.model;
  const double t = state_.view_time(c, i);  // the view's own time (t_i on the grid)
  const int list = state_.row_list(c, i);
  cuda::DeviceSliceOptions options;
  options.group = pass.group;
  options.compensate = pass.compensate;
  options.flow_features = pass.flow;
  options.rows = rows_.data() + row_offsets_[list];
  options.row_count = row_offsets_[list + 1] - row_offsets_[list];
  Stopwatch clock;
  cuda::DeviceTimeSlice& slice = slices_[int(pass.group)];
  cuda::slice(primitives_, m.config, m.grid, t, camera, options, slice, &shaded_);
  stats.seconds.slice += lap(clock);
  const int channels = slice.gaussians.channels;
  // RGB over the step's background, the flow channels over 0 (none: all black).
  std::vector<float> background(channels, 0.0f);
  const std::optional<Rgb> colour = state_.background();
  if (colour) std::copy(colour->begin(), colour->end(), background.begin());
  const float* backdrop = colour ? background.data() : nullptr;
  render::RenderOptions render_options;
  render_options.near_plane = set_.near_plane;
  cuda::rasterize_forward(slice.gaussians, camera, backdrop, render_options, render_);
  stats.seconds.render_forward += lap(clock);

  const int w = camera.width, h = camera.height;
  v_image_.resize(std::size_t(w) * h * channels);
  v_image_.fill_bytes(0);
  double* losses = losses_.data() + pass_index * kSlotsPerPass;
  const float* rgb = render_.blend.image.data();
  // What the camera would have recorded: the render through the camera's colour correction.
  const float* seen = rgb;
  int seen_channels = channels;
  if (state_.camera_color()) {
    corrected_.resize(std::size_t(w) * h * 3);
    cuda::apply_camera_color(rgb, channels, w, h, color_.data(), corrected_.data());
    seen = corrected_.data(), seen_channels = 3;
  }
  if (pass.image)
    cuda::image_loss(seen, seen_channels, target_, config_.ssim_lambda, 1.0, v_image_.data(),
                     channels, losses + kImageLoss, loss_scratch_);
  if (pass.image && state_.camera_color())
    cuda::apply_camera_color_backward(rgb, channels, w, h, color_.data(), v_image_.data(), channels,
                                      v_color_.data(), loss_scratch_);
  if (pass.flow) {
    if (set_.forward[c][i])
      cuda::flow_loss(rgb, channels, model::kForwardFlowChannel, flows_.forward(), w_flow,
                      v_image_.data(), losses + kForwardFlowLoss, loss_scratch_);
    if (set_.backward[c][i])
      cuda::flow_loss(rgb, channels, model::kBackwardFlowChannel, flows_.backward(), w_flow,
                      v_image_.data(), losses + kBackwardFlowLoss, loss_scratch_);
  }
  if (pass.group == model::Group::kAll)
    cuda::squared_error(seen, seen_channels, target_, losses + kSquaredError, loss_scratch_);
  stats.seconds.losses += lap(clock);
  cuda::rasterize_backward(slice.gaussians, camera, backdrop, render_options, render_,
                           v_image_.data(), nullptr, nullptr, v_gaussians_);
  if (state_.refines_at(stats.iteration))
    cuda::camera_pose_sums(slice.gaussians, v_gaussians_, pose_sums(), loss_scratch_);
  if (state_.clock_refines_at(stats.iteration, c))
    cuda::slice_time_sum(primitives_, m.config, m.grid, t, camera, options, slice, v_gaussians_,
                         time_sum(), loss_scratch_.partials);
  stats.seconds.render_backward += lap(clock);
  cuda::slice_backward(primitives_, m.config, m.grid, t, camera, options, slice, v_gaussians_,
                       grads_, &shaded_);
  stats.seconds.slice_backward += lap(clock);
}

StepStats CudaStep::step_view(int c, int i) {
  Stopwatch step_clock;
  StepStats stats = state_.begin_step(c, i);
  const int it = stats.iteration;
  model::Model& m = state_.model;

  const model::Representation representation = m.config.representation;
  const double w_flow = flow_weight(config_, representation, it);
  const std::vector<RenderPass> passes = render_passes(
      config_, representation, i, int(set_.frames.size()), w_flow > 0, state_.on_grid(c, i));
  Stopwatch clock;
  // The flows first: their copies run beside the kernels until the flow loss.
  if (std::any_of(passes.begin(), passes.end(), [](const RenderPass& p) { return p.flow; })) {
    const auto& forward = set_.forward[c][i];
    const auto& backward = set_.backward[c][i];
    flows_.start(forward ? &*forward : nullptr, backward ? &*backward : nullptr);
  }
  const std::optional<Rgb> colour = state_.background();
  if (colour && set_.masks[c][i])
    target_.assign(images_[c][i], foreground_[c][i].data(), state_.seen_by(c, *colour));
  else
    target_.assign(images_[c][i]);
  const std::size_t slots = passes.size() * kSlotsPerPass + 1;
  losses_.resize(slots + kPoseSums + kTimeSums);
  losses_.fill_bytes(0);
  if (state_.camera_color()) {
    const model::CameraColor color = state_.color_of(c);
    float values[kColorWidth];
    std::copy(color.m.begin(), color.m.end(), values);
    std::copy(color.c.begin(), color.c.end(), values + 3);
    color_.upload(values, kColorWidth);
    v_color_.resize(kColorWidth);
    v_color_.fill_bytes(0);
  }
  stats.seconds.losses += lap(clock);  // the SSIM loss's target side and the view's inputs
  const int list = state_.row_list(c, i);
  const std::int32_t* rows = rows_.data() + row_offsets_[list];
  const std::size_t count = row_offsets_[list + 1] - row_offsets_[list];
  stats.active = count;
  camera_ = state_.camera(c);
  const Camera& camera = camera_;
  const double t = state_.view_time(c, i);
  cuda::shade(primitives_, m.config, m.grid, t, camera, rows, count, shaded_);
  stats.seconds.slice += lap(clock);
  for (std::size_t k = 0; k < passes.size(); ++k) render_pass(passes[k], k, c, i, w_flow, stats);
  stats.renders = int(passes.size());
  clock.lap();
  cuda::shade_backward(primitives_, m.config, m.grid, t, camera, rows, count, shaded_, grads_);
  stats.seconds.slice_backward += lap(clock);
  double* reg = losses_.data() + slots - 1;
  cuda::regularizer(primitives_, rows, count, config_.opacity_reg, config_.scale_reg, reg,
                    loss_scratch_);
  cuda::regularizer_backward(primitives_, rows, count, config_.opacity_reg, config_.scale_reg,
                             grads_);

  // Optimiser step at the CPU step's rates.
  const double decay = lr_factor(config_, it);
  const double means = means_decay(config_, it);
  std::size_t k = 0;
  for (const auto& [name, adam] : state_.adam) {
    const auto [values, gradient] = field_and_gradient(primitives_, grads_, name);
    adam_[k].step_and_clear(values, gradient, state_.adam.rate(k, means, decay), rows, count);
    ++k;
  }
  if (const auto tie = state_.end_tie()) cuda::tie_end_velocities(primitives_, rows, count, *tie);
  // The step's numbers, and the camera colour's gradient for its Adam step on the host.
  const std::vector<double> sums = losses_.download();
  if (state_.camera_color()) {
    v_color_.download(state_.color_grad(c));
    state_.step_camera_color(c, decay);
  }
  double pose_reg = 0;
  if (state_.refines_at(it)) {
    const double* p = &sums[slots];
    state_.add_pose_gradient(
        c, model::pose_gradient(camera, state_.pose_of(c), {p[0], p[1], p[2]}, {p[3], p[4], p[5]}));
    pose_reg = state_.step_camera_pose(c, decay);
  }
  if (state_.clock_refines_at(it, c)) {
    state_.add_time_gradient(c, sums[slots + kPoseSums]);
    state_.step_clock(c, decay);
  }
  for (std::size_t p = 0; p < passes.size(); ++p) {
    const double* s = &sums[p * kSlotsPerPass];
    stats.image_loss += s[kImageLoss];
    stats.flow_loss += s[kForwardFlowLoss] + s[kBackwardFlowLoss];
    if (passes[p].group == model::Group::kAll)
      stats.psnr =
          psnr_from_squared_error(s[kSquaredError], std::size_t(camera.width) * camera.height * 3);
  }
  stats.loss = stats.image_loss + w_flow * stats.flow_loss + sums[slots - 1] + pose_reg;
  stats.flow_weight = w_flow;
  stats.lr_means = state_.adam.means_rate(means, decay);
  stats.seconds.optimizer = lap(clock);

  // The strategy: noise here, with its key drawn first as McmcStrategy::after_step draws it;
  // relocation and growth on the device rows (decided on the host from three of their fields);
  // stretching, which reads whole rows every stretch_every steps, on a host copy.
  cuda::inject_noise(primitives_, rows, count, stats.lr_means, state_.rng());
  if (strategy_.stretches_at(it, representation)) {
    download();
    const DensityChanges changes = strategy_.reshape(it, m, state_.adam, state_.rng);
    stats.relocated = changes.relocated, stats.added = changes.added;
    stats.stretched = changes.stretched, stats.pruned = changes.pruned;
    if (changes.relocated || changes.added || changes.stretched || changes.pruned) {
      state_.rebuild_index();
      upload();
    }
  } else if (strategy_.relocates_at(it)) {
    DeviceRows device_rows(*this);
    const DensityChanges changes =
        strategy_.relocate_and_grow(device_rows, representation, state_.rng);
    stats.relocated = changes.relocated, stats.added = changes.added;
    if (changes.relocated || changes.added) rebuild_index();
  }
  stats.primitives = primitives_.size();
  stats.seconds.total = lap(step_clock);
  return stats;
}

}  // namespace

std::unique_ptr<TrainingStep> make_cuda_step(const TrainingSet& set, const TrainConfig& config) {
  return std::make_unique<CudaStep>(set, config);
}

}  // namespace retimegs::train
