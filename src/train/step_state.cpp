#include "retimegs/train/step_state.hpp"

#include <algorithm>
#include <iterator>

#include <fmt/format.h>

#include "retimegs/core/error.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/train/checkpoint.hpp"
#include "retimegs/train/initialize.hpp"
#include "retimegs/train/relocation.hpp"
#include "retimegs/train/schedule.hpp"

namespace retimegs::train {
namespace fs = std::filesystem;

bool refine_cameras(const TrainConfig& config, const TrainingSet& set) {
  return config.refine_cameras.value_or(set.scene.calibration == io::CalibrationSource::kUser);
}

bool refine_clocks(const TrainConfig& config, const TrainingSet& set) {
  return config.refine_clocks.value_or(set.scene.clock_source == io::ClockSource::kEstimated);
}

StepState::StepState(const TrainingSet& set, const TrainConfig& config)
    : rng(config.seed), set_(set), config_(config) {
  config_.random_background = train::random_background(config, set);
  config_.refine_cameras = train::refine_cameras(config, set);
  config_.refine_clocks = train::refine_clocks(config, set);
  model.grid = set.grid;
  model.config = config.model_config();
  // A window trains as a clip of its own, its ends open (model/window.hpp).
  if (set.clip_grid) model.config = model::window_config(model.config, *set.clip_grid, set.grid);
  model.training_config = to_json(config_);
  const std::size_t cameras = set.cameras.size();
  if (refine_clocks()) {
    // The anchors: training cameras on the scene's clock.
    const auto anchor = [&](std::size_t c) {
      return set.scene.clocks.empty() || set.scene.clocks[set.cameras[c]].is_default();
    };
    bool anchored = false;
    for (std::size_t c = 0; c < cameras; ++c) anchored |= anchor(c);
    clock_refined_.assign(cameras, 0);
    for (std::size_t c = 0; c < cameras; ++c) clock_refined_[c] = !anchored || !anchor(c);
    clocks_.assign(cameras, 0.0f);
    clock_grads_.assign(cameras, 0.0f);
    clock_adam_ = Adam(cameras, 1);
    for (std::size_t c = 0; c < cameras; ++c)
      if (clock_refined_[c]) model.camera_clocks[set.scene.cameras[set.cameras[c]].name] = 0;
  }
  // A moving clock may take a view between any two adjacent training times.
  const bool moving = std::any_of(clock_refined_.begin(), clock_refined_.end(),
                                  [](char refined) { return refined != 0; });
  for (int a = 0; moving && a + 1 < set.grid.count; ++a) between_.push_back(a);
  for (std::size_t c = 0; c < cameras; ++c)
    for (std::size_t i = 0; i < set.frames.size(); ++i)
      if (const auto [a, b] = set.slots_around(int(c), int(i)); a != b) between_.push_back(a);
  std::sort(between_.begin(), between_.end());
  between_.erase(std::unique(between_.begin(), between_.end()), between_.end());
  if (camera_color()) {
    colors_.assign(cameras * kColorWidth, 0.0f);  // the identity: gain 1, offset 0
    color_grads_.assign(cameras * kColorWidth, 0.0f);
    color_adam_ = Adam(cameras, kColorWidth);
    for (const int camera : set.cameras) model.camera_colors[set.scene.cameras[camera].name] = {};
  }
  if (refine_cameras()) {
    poses_.assign(cameras * kPoseWidth, 0.0f);  // the identity
    pose_grads_.assign(cameras * kPoseWidth, 0.0f);
    pose_adam_ = Adam(cameras, kPoseWidth);
    for (const int camera : set.cameras) model.camera_poses[set.scene.cameras[camera].name] = {};
  }
}

model::CameraPose StepState::pose_of(int c) const {
  model::CameraPose pose;
  if (!refine_cameras()) return pose;
  const float* p = &poses_[std::size_t(c) * kPoseWidth];
  for (int k = 0; k < 3; ++k)
    pose.rotation[k] = p[k], pose.translation[k] = double(p[3 + k]) * set_.scene_extent;
  return pose;
}

Camera StepState::camera(int c) const {
  const Camera& camera = set_.scene.cameras[set_.cameras[c]];
  return refine_cameras() ? model::corrected(camera, pose_of(c)) : camera;
}

bool StepState::refines_at(int step) const {
  return refine_cameras() && step > config_.scaled(config_.camera_refine_start);
}

void StepState::add_pose_gradient(int c, const std::array<double, 6>& gradient) {
  float* g = &pose_grads_[std::size_t(c) * kPoseWidth];
  for (int k = 0; k < 3; ++k)
    g[k] += float(gradient[k]), g[3 + k] += float(gradient[3 + k] * set_.scene_extent);
}

double StepState::step_camera_pose(int c, double decay) {
  const double w = config_.camera_pose_reg;
  float* p = &poses_[std::size_t(c) * kPoseWidth];
  float* g = &pose_grads_[std::size_t(c) * kPoseWidth];
  double reg = 0;
  for (int k = 0; k < kPoseWidth; ++k) {
    reg += w * double(p[k]) * p[k];
    g[k] += float(2 * w * p[k]);
  }
  const std::vector<std::int32_t> row = {c};
  pose_adam_.step(poses_.data(), pose_grads_.data(), config_.lr_camera_pose * decay, &row);
  std::fill_n(g, kPoseWidth, 0.0f);
  remove_rig_motion();
  for (std::size_t j = 0; j < set_.cameras.size(); ++j)
    model.camera_poses[set_.scene.cameras[set_.cameras[j]].name] = pose_of(int(j));
  return reg;
}

void StepState::remove_rig_motion() {
  // Gauge: moving the world by a small similarity G (rotation θ, shift x, scale s) while the scene
  // follows by G⁻¹ leaves every image as it was; to first order it is the correction
  // (ω_c, τ_c) = (R_c θ, R_c x + t_c × R_c θ + s t_c) of every camera c (world_to_camera (R_c,
  // t_c); a scale of camera space does not change a projection, so s appears as the shift s t_c).
  // Nothing in the loss pins it, so the corrections' least-squares fit of it is subtracted after
  // every step, as the colours' mean is: the rig stays where the calibration put it, and what
  // remains is each camera's motion relative to the others.
  const std::size_t cameras = set_.cameras.size();
  const double extent = set_.scene_extent;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(kPoseWidth * cameras, 7);
  Eigen::VectorXd b(kPoseWidth * cameras);
  for (std::size_t j = 0; j < cameras; ++j) {
    const Camera& camera = set_.scene.cameras[set_.cameras[j]];
    const Eigen::Matrix3d r = camera.rotation();
    const Eigen::Vector3d t = camera.translation() / extent;  // τ is stored in extents
    Eigen::Matrix3d t_cross;
    t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    a.block<3, 3>(kPoseWidth * j, 0) = r;
    a.block<3, 3>(kPoseWidth * j + 3, 0) = t_cross * r;
    a.block<3, 3>(kPoseWidth * j + 3, 3) = r;
    a.block<3, 1>(kPoseWidth * j + 3, 6) = t;
    for (int k = 0; k < kPoseWidth; ++k) b[kPoseWidth * j + k] = poses_[kPoseWidth * j + k];
  }
  const Eigen::VectorXd rig = a.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd rest = b - a * rig;
  for (std::size_t k = 0; k < poses_.size(); ++k) poses_[k] = float(rest[k]);
}

bool StepState::clock_refines_at(int step, int c) const {
  return clock_refined(c) && step > config_.scaled(config_.clock_refine_start);
}

void StepState::step_clock(int c, double decay) {
  const std::vector<std::int32_t> row = {c};
  clock_adam_.step(clocks_.data(), clock_grads_.data(), config_.lr_time_offset * decay, &row);
  clock_grads_[c] = 0;
  const std::size_t cameras = set_.cameras.size();
  if (std::all_of(clock_refined_.begin(), clock_refined_.end(), [](char r) { return r != 0; })) {
    // Gauge without an anchor: a common shift of every clock is one of the scene's time, which
    // the model would follow; the corrections' mean is held at zero.
    double mean = 0;
    for (const float delta : clocks_) mean += delta;
    mean /= double(cameras);
    for (float& delta : clocks_) delta = float(delta - mean);
  }
  for (std::size_t j = 0; j < cameras; ++j)
    if (clock_refined_[j])
      model.camera_clocks[set_.scene.cameras[set_.cameras[j]].name] = clocks_[j];
}

model::CameraColor StepState::color_of(int c) const {
  model::CameraColor color;
  const float* p = &colors_[std::size_t(c) * kColorWidth];
  std::copy_n(p, 3, color.m.begin());
  std::copy_n(p + 3, 3, color.c.begin());
  return color;
}

void StepState::step_camera_color(int c, double decay) {
  const std::vector<std::int32_t> row = {c};
  color_adam_.step(colors_.data(), color_grads_.data(), config_.lr_camera_color * decay, &row);
  std::fill_n(color_grad(c), kColorWidth, 0.0f);
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
    model.camera_colors[set_.scene.cameras[set_.cameras[j]].name] = color_of(int(j));
}

std::optional<Rgb> StepState::background() const {
  if (!random_background()) return std::nullopt;
  return step_background(config_.seed, iteration);
}

Rgb StepState::seen_by(int c, const Rgb& background) const {
  return camera_color() ? seen_background(background, color_of(c)) : background;
}

std::optional<model::EndTie<float>> StepState::end_tie() const {
  if (!config_.tie_end_velocities || model.config.representation == model::Representation::kStgs)
    return std::nullopt;
  // The clip's ends: a window's own ends have flows beyond them (model/window.hpp).
  const model::TimeGrid& clip = set_.clip_grid ? *set_.clip_grid : set_.grid;
  return model::EndTie<float>{float(clip.step / 2), float(clip.first), float(clip.last()),
                              float(model.config.epsilon)};
}

std::string StepState::initialize() {
  std::string note;
  model.primitives =
      train::initialize(set_, init_options(config_, model.config.representation), note);
  make_optimizers();
  rebuild_index();
  return note;
}

void StepState::initialize(model::Primitives primitives) {
  model.primitives = std::move(primitives);
  make_optimizers();
  rebuild_index();
}

void StepState::rebuild_index() {
  set_index(model::TemporalIndex(model.primitives, model.config, model.grid));
  const std::vector<std::int32_t> old_from_new = index.locality_order();
  if (std::is_sorted(old_from_new.begin(), old_from_new.end())) return;  // the identity
  model.primitives.reorder(old_from_new);
  adam.reorder(old_from_new);  // the gradient rows are all zero between steps
  set_index(model::TemporalIndex(model.primitives, model.config, model.grid));
}

void StepState::set_index(model::TemporalIndex new_index) {
  index = std::move(new_index);
  between_rows_.resize(between_.size());
  for (std::size_t k = 0; k < between_.size(); ++k) {
    const std::vector<std::int32_t>&a = index.rows_at(between_[k]),
          &b = index.rows_at(between_[k] + 1);
    std::vector<std::int32_t>& rows = between_rows_[k];
    rows.clear();
    std::set_union(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(rows));
  }
}

int StepState::row_list(int c, int i) const {
  const double t = view_time(c, i);
  const auto [a, b] = t == set_.grid.at(i) ? std::pair{i, i} : set_.slots_at(t);
  if (a == b) return a;
  const auto it = std::lower_bound(between_.begin(), between_.end(), a);
  return index.frames() + int(it - between_.begin());
}

const std::vector<std::int32_t>& StepState::rows_of(int list) const {
  return list < index.frames() ? index.rows_at(list)
                               : between_rows_.at(std::size_t(list - index.frames()));
}

void StepState::make_optimizers() {
  adam = Optimizers(model.primitives, model.config.representation, config_, set_.scene_extent,
                    set_.grid.step);
}

std::string StepState::final_prune() {
  model::Primitives& p = model.primitives;
  if (model.config.representation == model::Representation::kStgs ||
      !(config_.final_prune_opacity > 0))
    return "final prune: off";
  const std::vector<std::int32_t> pruned =
      faint_short_rows(p, model.grid, config_.final_prune_opacity);
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
  adam.reorder(old_from_new);
  p.resize(kept);
  adam.resize(kept);
  rebuild_index();
  return fmt::format(
      "final prune: {} faint primitives (opacity < {}) that span one interval removed, {} left",
      pruned.size(), config_.final_prune_opacity, kept);
}

std::pair<int, int> StepState::draw_view() {
  const int nc = int(set_.cameras.size()), nf = int(set_.frames.size());
  std::uniform_int_distribution<int> pick_camera(0, nc - 1), pick_frame(0, nf - 1);
  const int c = pick_camera(rng), i = pick_frame(rng);
  return {c, i};
}

StepStats StepState::begin_step(int c, int i) {
  if (c < 0 || c >= int(set_.cameras.size()) || i < 0 || i >= int(set_.frames.size()))
    fail("training step: no view (camera {}, frame {}) among {} cameras x {} frames", c, i,
         set_.cameras.size(), set_.frames.size());
  StepStats stats;
  stats.iteration = ++iteration;
  model.config.sh_degree = sh_degree(config_, iteration);
  stats.camera = set_.cameras[c], stats.frame = set_.frames[i];
  return stats;
}

void StepState::save_checkpoint(const fs::path& dir) const {
  NamedAdams optimizers;
  for (const auto& [name, group] : adam) optimizers.emplace_back(name, &group);
  if (camera_color()) optimizers.emplace_back(kCameraColorAdam, &color_adam_);
  if (refine_cameras()) optimizers.emplace_back(kCameraPoseAdam, &pose_adam_);
  if (!clock_refined_.empty()) optimizers.emplace_back(kCameraClockAdam, &clock_adam_);
  write_checkpoint(dir, model, iteration, rng, optimizers);
}

void StepState::load_checkpoint(const fs::path& dir) {
  Checkpoint checkpoint(dir, set_.grid);
  model = std::move(checkpoint.model);
  iteration = checkpoint.iteration;
  rng = checkpoint.rng;
  make_optimizers();
  for (auto& [name, group] : adam) checkpoint.read_adam(name, group);
  if (camera_color()) {
    for (std::size_t j = 0; j < set_.cameras.size(); ++j) {
      const std::string& name = set_.scene.cameras[set_.cameras[j]].name;
      const model::CameraColor* color = model::find_camera_color(model, name);
      if (!color)
        fail("{}: the checkpoint's model has no colour correction of training camera '{}'",
             dir.string(), name);
      std::copy(color->m.begin(), color->m.end(), &colors_[j * kColorWidth]);
      std::copy(color->c.begin(), color->c.end(), &colors_[j * kColorWidth + 3]);
    }
    checkpoint.read_adam(kCameraColorAdam, color_adam_);
  }
  if (refine_cameras()) {
    for (std::size_t j = 0; j < set_.cameras.size(); ++j) {
      const std::string& name = set_.scene.cameras[set_.cameras[j]].name;
      const model::CameraPose* pose = model::find_camera_pose(model, name);
      if (!pose)
        fail(
            "{}: the checkpoint's model has no pose correction of training camera '{}' (the run "
            "refines its cameras: its config's refine_cameras)",
            dir.string(), name);
      for (int k = 0; k < 3; ++k) {
        poses_[j * kPoseWidth + k] = float(pose->rotation[k]);
        poses_[j * kPoseWidth + 3 + k] = float(pose->translation[k] / set_.scene_extent);
      }
    }
    checkpoint.read_adam(kCameraPoseAdam, pose_adam_);
  }
  if (!clock_refined_.empty()) {
    for (std::size_t j = 0; j < set_.cameras.size(); ++j) {
      if (!clock_refined_[j]) continue;
      const std::string& name = set_.scene.cameras[set_.cameras[j]].name;
      if (!model.camera_clocks.count(name))
        fail(
            "{}: the checkpoint's model has no clock correction of training camera '{}' (the run "
            "refines its clocks: its config's refine_clocks)",
            dir.string(), name);
      clocks_[j] = float(model.camera_clocks.at(name));
    }
    checkpoint.read_adam(kCameraClockAdam, clock_adam_);
  }
  rebuild_index();
}

}  // namespace retimegs::train
