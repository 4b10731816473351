#include "retimegs/train/cpu_step.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "retimegs/core/psnr.hpp"
#include "retimegs/core/stopwatch.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/losses.hpp"

namespace retimegs::train {
namespace fs = std::filesystem;

namespace {

// Makes `image` a zero image of the given shape, keeping its allocation; zeroed on all threads.
void zero_image(Image& image, int width, int height, int channels) {
  image.width = width, image.height = height, image.channels = channels;
  image.data.resize(std::size_t(width) * height * channels);
  float* data = image.data.data();
  const std::ptrdiff_t size = std::ptrdiff_t(image.data.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t k = 0; k < size; ++k) data[k] = 0;
}

}  // namespace

CpuStep::CpuStep(const TrainingSet& set, const TrainConfig& config)
    : set_(set),
      config_(config),
      state_(set, config),
      strategy_(std::make_unique<McmcStrategy>(config, set.scene_extent)) {}

void CpuStep::render_pass(const RenderPass& pass, int c, int i,
                          const std::vector<std::int32_t>& active, double w_flow, StepStats& stats,
                          model::PrimitiveGrads& grads) {
  const Camera& camera = camera_;
  const double t = state_.view_time(c, i);  // the view's own time (t_i on the grid)
  const Image& target = target_;
  model::SliceOptions eo;
  eo.group = pass.group;
  eo.compensate = pass.compensate;
  eo.flow_features = pass.flow;
  eo.rows = &active;
  Stopwatch clock;
  model::TimeSlice& e = slices_[int(pass.group)];
  model::slice(state_.model.primitives, state_.model.config, state_.model.grid, t, camera, eo, e,
               &shaded_);
  stats.seconds.slice += clock.lap();
  const int channels = e.gaussians.channels;
  // RGB over the step's background, the flow channels over 0.
  std::vector<float> background(channels, 0.0f);
  if (const std::optional<Rgb> colour = state_.background())
    std::copy(colour->begin(), colour->end(), background.begin());
  render::RenderOptions render_options;
  render_options.near_plane = set_.near_plane;
  render::RenderOutput& out = render_;
  render::rasterize_forward(e.gaussians, camera, background.data(), render_options, out);
  stats.seconds.render_forward += clock.lap();
  Image& v_image = v_image_;
  zero_image(v_image, camera.width, camera.height, channels);
  const Image& rgb = rgb_of(out.blend.image, rgb_);
  // What the camera would have recorded: the render through the camera's colour correction.
  const Image* seen = &rgb;
  model::CameraColor color;
  if (state_.camera_color()) {
    color = state_.color_of(c);
    model::apply_camera_color(rgb, color, corrected_);
    seen = &corrected_;
  }
  if (pass.image)
    stats.image_loss += image_loss(*seen, ssim_target_, config_.ssim_lambda, 1.0, v_image);
  if (pass.image && state_.camera_color()) {
    model::CameraColor v_color;
    model::apply_camera_color_backward(rgb, color, v_image, v_color);
    float* g = state_.color_grad(c);
    for (int k = 0; k < 3; ++k) g[k] += v_color.m[k], g[3 + k] += v_color.c[k];
  }
  if (pass.flow) {
    if (const auto& f = set_.forward[c][i])
      stats.flow_loss +=
          flow_loss(out.blend.image, model::kForwardFlowChannel, *f, w_flow, v_image);
    if (const auto& f = set_.backward[c][i])
      stats.flow_loss +=
          flow_loss(out.blend.image, model::kBackwardFlowChannel, *f, w_flow, v_image);
  }
  if (pass.group == model::Group::kAll) stats.psnr = psnr(*seen, target);
  stats.seconds.losses += clock.lap();
  GaussianGrads& vg = v_gaussians_;
  render::rasterize_backward(e.gaussians, camera, background.data(), render_options, out,
                             v_image.data.data(), vg);
  if (state_.refines_at(stats.iteration))
    state_.add_pose_gradient(c, model::camera_pose_vjp(e.gaussians, vg, camera, state_.pose_of(c)));
  if (state_.clock_refines_at(stats.iteration, c))
    state_.add_time_gradient(c, model::slice_time_vjp(state_.model.primitives, state_.model.config,
                                                      state_.model.grid, t, camera, eo, e, vg));
  stats.seconds.render_backward += clock.lap();
  model::slice_backward(state_.model.primitives, state_.model.config, state_.model.grid, t, camera,
                        eo, e, vg, grads, &shaded_);
  stats.seconds.slice_backward += clock.lap();
}

StepStats CpuStep::step() {
  const auto [c, i] = state_.draw_view();
  return step_view(c, i);
}

StepStats CpuStep::step_view(int c, int i) {
  Stopwatch step_clock;
  StepStats stats = state_.begin_step(c, i);
  const int it = stats.iteration;
  model::Primitives& p = state_.model.primitives;

  // Renders, losses and their gradient.
  const model::Representation representation = state_.model.config.representation;
  const double w_flow = flow_weight(config_, representation, it);
  const std::vector<RenderPass> passes = render_passes(
      config_, representation, i, int(set_.frames.size()), w_flow > 0, state_.on_grid(c, i));
  unpack(set_.images[c][i], target_);
  if (const std::optional<Rgb> colour = state_.background())
    if (const std::optional<Image>& mask = set_.masks[c][i])
      replace_background(target_, *mask, state_.seen_by(c, *colour));
  Stopwatch target_clock;
  ssim_target_.assign(target_);
  stats.seconds.losses += target_clock.lap();  // the SSIM loss's target side, for all renders
  const std::vector<std::int32_t>& active = state_.rows_of(state_.row_list(c, i));
  stats.active = active.size();
  model::PrimitiveGrads& grads = grads_;
  grads.resize(p.size());
  camera_ = state_.camera(c);
  const Camera& camera = camera_;
  Stopwatch shade_clock;
  const double t = state_.view_time(c, i);
  model::shade(p, state_.model.config, state_.model.grid, t, camera, active, shaded_);
  stats.seconds.slice += shade_clock.lap();
  for (const RenderPass& pass : passes) render_pass(pass, c, i, active, w_flow, stats, grads);
  stats.renders = int(passes.size());
  shade_clock.lap();
  model::shade_backward(p, state_.model.config, state_.model.grid, t, camera, active, shaded_,
                        grads);
  stats.seconds.slice_backward += shade_clock.lap();
  Stopwatch clock;
  const double reg = regularizer(p, active, config_.opacity_reg, config_.scale_reg);
  regularizer_backward(p, active, config_.opacity_reg, config_.scale_reg, grads);
  stats.loss = stats.image_loss + w_flow * stats.flow_loss + reg;
  stats.flow_weight = w_flow;

  // Optimiser step, then relocation, growth, noise and stretching.
  const double decay = lr_factor(config_, it);
  const double means = means_decay(config_, it);
  state_.adam.step(p, grads, active, means, decay);
  if (const auto tie = state_.end_tie())
    for (const std::int32_t r : active)
      model::tie_end_velocities(*tie, p.mu_tau[r], &p.velocity[9 * std::size_t(r)]);
  if (state_.camera_color()) state_.step_camera_color(c, decay);
  if (state_.refines_at(it)) stats.loss += state_.step_camera_pose(c, decay);
  if (state_.clock_refines_at(it, c)) state_.step_clock(c, decay);
  stats.lr_means = state_.adam.means_rate(means, decay);
  stats.seconds.optimizer = clock.lap();
  const DensityChanges changes =
      strategy_->after_step(it, stats.lr_means, active, state_.model, state_.adam, state_.rng);
  stats.relocated = changes.relocated, stats.added = changes.added;
  stats.stretched = changes.stretched, stats.pruned = changes.pruned;
  if (changes.relocated || changes.added || changes.stretched || changes.pruned)
    state_.rebuild_index();
  stats.primitives = p.size();
  stats.seconds.total = step_clock.lap();
  return stats;
}

}  // namespace retimegs::train
