#include "retimegs/train/cpu_step.hpp"

#include <algorithm>
#include <cmath>

#include "retimegs/core/error.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/core/stopwatch.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/checkpoint.hpp"
#include "retimegs/train/initialize.hpp"
#include "retimegs/train/losses.hpp"
#include "retimegs/train/relocation.hpp"

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

constexpr int kColorWidth = 6;  // a camera colour's parameters: m[3], then c[3]

}  // namespace

CpuStep::CpuStep(const TrainingSet& set, const TrainConfig& config)
    : set_(set),
      config_(config),
      strategy_(std::make_unique<McmcStrategy>(config, set.scene_extent)),
      rng_(config.seed) {
  model_.grid = set.grid;
  model_.config = config.model_config();
  // A window trains as a clip of its own, its ends open (model/window.hpp).
  if (set.clip_grid) model_.config = model::window_config(model_.config, *set.clip_grid, set.grid);
  model_.training_config = to_json(config);
  if (camera_color()) {
    const std::size_t cameras = set.cameras.size();
    colors_.assign(cameras * kColorWidth, 0.0f);  // the identity: gain 1, offset 0
    color_grads_.assign(cameras * kColorWidth, 0.0f);
    color_adam_ = Adam(cameras, kColorWidth);
    for (const int camera : set.cameras) model_.camera_colors[set.scene.cameras[camera].name] = {};
  }
}

model::CameraColor CpuStep::color_of(int c) const {
  model::CameraColor color;
  const float* p = &colors_[std::size_t(c) * kColorWidth];
  std::copy_n(p, 3, color.m.begin());
  std::copy_n(p + 3, 3, color.c.begin());
  return color;
}

void CpuStep::step_camera_color(int c, double decay) {
  const std::vector<std::int32_t> row = {c};
  color_adam_.step(colors_.data(), color_grads_.data(), config_.lr_camera_color * decay, &row);
  std::fill_n(&color_grads_[std::size_t(c) * kColorWidth], kColorWidth, 0.0f);
  // Gauge: a common gain and offset can move between the model's colours and every camera's
  // correction without changing a training render, so nothing in the loss pins it. The rule keeps
  // the mean of m and of c over the training cameras at zero (subtracted after every step): the
  // model's colours are then those of the average camera (geometric mean gain, mean offset), which
  // is what a camera without a correction (a test camera, a path) is rendered with.
  const std::size_t cameras = set_.cameras.size();
  for (int k = 0; k < kColorWidth; ++k) {
    double mean = 0;
    for (std::size_t j = 0; j < cameras; ++j) mean += colors_[j * kColorWidth + k];
    mean /= double(cameras);
    for (std::size_t j = 0; j < cameras; ++j) colors_[j * kColorWidth + k] -= float(mean);
  }
  for (std::size_t j = 0; j < cameras; ++j)
    model_.camera_colors[set_.scene.cameras[set_.cameras[j]].name] = color_of(int(j));
}

std::string CpuStep::initialize() {
  InitOptions options;
  options.use_flow = !config_.ablate.no_flow_init;
  options.static_once = !config_.ablate.no_static_init;
  options.representation = model_.config.representation;
  options.max_primitives = config_.cap;
  options.initial_opacity = config_.init_opacity;
  options.seed = config_.seed;
  options.stretch_color = config_.stretch_color;
  options.stretch_speed = config_.stretch_speed;
  std::string note;
  model_.primitives = train::initialize(set_, options, note);
  make_optimizers();
  rebuild_index();
  return note;
}

void CpuStep::initialize(model::Primitives primitives) {
  model_.primitives = std::move(primitives);
  make_optimizers();
  rebuild_index();
}

void CpuStep::rebuild_index() {
  index_ = model::TemporalIndex(model_.primitives, model_.config, model_.grid);
  const std::vector<std::int32_t> old_from_new = index_.locality_order();
  if (std::is_sorted(old_from_new.begin(), old_from_new.end())) return;  // the identity
  model_.primitives.reorder(old_from_new);
  adam_.reorder(old_from_new);  // the gradient rows are all zero between steps
  index_ = model::TemporalIndex(model_.primitives, model_.config, model_.grid);
}

void CpuStep::make_optimizers() {
  adam_ = Optimizers(model_.primitives, model_.config.representation, config_, set_.scene_extent,
                     set_.grid.step);
}

void CpuStep::render_pass(const RenderPass& pass, int c, int i,
                          const std::vector<std::int32_t>& active, double w_flow, StepStats& stats,
                          model::PrimitiveGrads& grads) {
  const Camera& camera = set_.scene.cameras[set_.cameras[c]];
  const double t = set_.grid.at(i);
  const Image& target = target_;
  model::SliceOptions eo;
  eo.group = pass.group;
  eo.compensate = pass.compensate;
  eo.flow_features = pass.flow;
  eo.rows = &active;
  Stopwatch clock;
  model::TimeSlice& e = slices_[int(pass.group)];
  model::slice(model_.primitives, model_.config, model_.grid, t, camera, eo, e, &shaded_);
  stats.seconds.slice += clock.lap();
  const int channels = e.gaussians.channels;
  const std::vector<float> background(channels, 0.0f);
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
  if (camera_color()) {
    color = color_of(c);
    model::apply_camera_color(rgb, color, corrected_);
    seen = &corrected_;
  }
  stats.image_loss += image_loss(*seen, ssim_target_, config_.ssim_lambda, 1.0, v_image);
  if (camera_color()) {
    model::CameraColor v_color;
    model::apply_camera_color_backward(rgb, color, v_image, v_color);
    float* g = &color_grads_[std::size_t(c) * kColorWidth];
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
  stats.seconds.render_backward += clock.lap();
  model::slice_backward(model_.primitives, model_.config, model_.grid, t, camera, eo, e, vg, grads,
                        &shaded_);
  stats.seconds.slice_backward += clock.lap();
}

std::string CpuStep::finish() {
  model::Primitives& p = model_.primitives;
  if (model_.config.representation == model::Representation::kStgs ||
      !(config_.final_prune_opacity > 0))
    return "final prune: off";
  const std::vector<std::int32_t> pruned =
      faint_short_rows(p, model_.grid, config_.final_prune_opacity);
  // The kept rows first, in their order, then the pruned ones, which the resize drops.
  std::vector<std::int32_t> old_from_new;
  old_from_new.reserve(p.size());
  std::vector<bool> drop(p.size(), false);
  for (const std::int32_t r : pruned) drop[std::size_t(r)] = true;
  for (std::size_t r = 0; r < p.size(); ++r)
    if (!drop[r]) old_from_new.push_back(std::int32_t(r));
  const std::size_t kept = old_from_new.size();
  old_from_new.insert(old_from_new.end(), pruned.begin(), pruned.end());
  p.reorder(old_from_new);
  adam_.reorder(old_from_new);
  p.resize(kept);
  adam_.resize(kept);
  rebuild_index();
  return fmt::format(
      "final prune: {} faint primitives (opacity < {}) that span one interval removed, {} left",
      pruned.size(), config_.final_prune_opacity, kept);
}

StepStats CpuStep::step() {
  const int nc = int(set_.cameras.size()), nf = int(set_.frames.size());
  std::uniform_int_distribution<int> pick_camera(0, nc - 1), pick_frame(0, nf - 1);
  const int c = pick_camera(rng_), i = pick_frame(rng_);
  return step_view(c, i);
}

StepStats CpuStep::step_view(int c, int i) {
  if (c < 0 || c >= int(set_.cameras.size()) || i < 0 || i >= int(set_.frames.size()))
    fail("training step: no view (camera {}, frame {}) among {} cameras x {} frames", c, i,
         set_.cameras.size(), set_.frames.size());
  Stopwatch step_clock;
  const int it = ++iteration_;
  StepStats stats;
  stats.iteration = it;
  model::Primitives& p = model_.primitives;
  model_.config.sh_degree = sh_degree(config_, it);
  stats.camera = set_.cameras[c], stats.frame = set_.frames[i];

  // Renders, losses and their gradient.
  const model::Representation representation = model_.config.representation;
  const double w_flow = flow_weight(config_, representation, it);
  const std::vector<RenderPass> passes =
      render_passes(config_, representation, i, int(set_.frames.size()), w_flow > 0);
  unpack(set_.images[c][i], target_);
  Stopwatch target_clock;
  ssim_target_.assign(target_);
  stats.seconds.losses += target_clock.lap();  // the SSIM loss's target side, for all renders
  const std::vector<std::int32_t>& active = index_.rows_at(i);
  stats.active = active.size();
  model::PrimitiveGrads& grads = grads_;
  grads.resize(p.size());
  const Camera& camera = set_.scene.cameras[set_.cameras[c]];
  Stopwatch shade_clock;
  model::shade(p, model_.config, model_.grid, set_.grid.at(i), camera, active, shaded_);
  stats.seconds.slice += shade_clock.lap();
  for (const RenderPass& pass : passes) render_pass(pass, c, i, active, w_flow, stats, grads);
  stats.renders = int(passes.size());
  shade_clock.lap();
  model::shade_backward(p, model_.config, model_.grid, set_.grid.at(i), camera, active, shaded_,
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
  adam_.step(p, grads, active, means, decay);
  if (camera_color()) step_camera_color(c, decay);
  stats.lr_means = adam_.means_rate(means, decay);
  stats.seconds.optimizer = clock.lap();
  const DensityChanges changes =
      strategy_->after_step(it, stats.lr_means, active, model_, adam_, rng_);
  stats.relocated = changes.relocated, stats.added = changes.added;
  stats.stretched = changes.stretched, stats.pruned = changes.pruned;
  if (changes.relocated || changes.added || changes.stretched || changes.pruned) rebuild_index();
  stats.primitives = p.size();
  stats.seconds.total = step_clock.lap();
  return stats;
}

void CpuStep::save_checkpoint(const fs::path& dir) const {
  NamedAdams optimizers;
  for (const auto& [name, adam] : adam_) optimizers.emplace_back(name, &adam);
  if (camera_color()) optimizers.emplace_back(kCameraColorAdam, &color_adam_);
  write_checkpoint(dir, model_, iteration_, rng_, optimizers);
}

void CpuStep::load_checkpoint(const fs::path& dir) {
  Checkpoint checkpoint(dir, set_.grid);
  model_ = std::move(checkpoint.model);
  iteration_ = checkpoint.iteration;
  rng_ = checkpoint.rng;
  make_optimizers();
  for (auto& [name, adam] : adam_) checkpoint.read_adam(name, adam);
  if (camera_color()) {
    for (std::size_t j = 0; j < set_.cameras.size(); ++j) {
      const std::string& name = set_.scene.cameras[set_.cameras[j]].name;
      const model::CameraColor* color = model::find_camera_color(model_, name);
      if (!color)
        fail("{}: the checkpoint's model has no colour correction of training camera '{}'",
             dir.string(), name);
      std::copy(color->m.begin(), color->m.end(), &colors_[j * kColorWidth]);
      std::copy(color->c.begin(), color->c.end(), &colors_[j * kColorWidth + 3]);
    }
    checkpoint.read_adam(kCameraColorAdam, color_adam_);
  }
  rebuild_index();
}

std::unique_ptr<TrainingStep> make_step(const TrainingSet& set, const TrainConfig& config) {
  return std::make_unique<CpuStep>(set, config);
}

}  // namespace retimegs::train
