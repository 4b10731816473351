#include "retimegs/train/trainer.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/folder_lock.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/core/stopwatch.hpp"
#include "retimegs/io/json_file.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/evaluate.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/initialize.hpp"
#include "retimegs/train/losses.hpp"
#include "retimegs/train/relocation.hpp"

namespace retimegs::train {
namespace fs = std::filesystem;
using json = nlohmann::json;

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

Trainer::Trainer(const TrainingSet& set, const TrainConfig& config)
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

model::CameraColor Trainer::color_of(int c) const {
  model::CameraColor color;
  const float* p = &colors_[std::size_t(c) * kColorWidth];
  std::copy_n(p, 3, color.m.begin());
  std::copy_n(p + 3, 3, color.c.begin());
  return color;
}

void Trainer::step_camera_color(int c, double decay) {
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

std::string Trainer::initialize() {
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

void Trainer::initialize(model::Primitives primitives) {
  model_.primitives = std::move(primitives);
  make_optimizers();
  rebuild_index();
}

void Trainer::rebuild_index() {
  index_ = model::TemporalIndex(model_.primitives, model_.config, model_.grid);
  const std::vector<std::int32_t> old_from_new = index_.locality_order();
  if (std::is_sorted(old_from_new.begin(), old_from_new.end())) return;  // the identity
  model_.primitives.reorder(old_from_new);
  adam_.reorder(old_from_new);  // the gradient rows are all zero between steps
  index_ = model::TemporalIndex(model_.primitives, model_.config, model_.grid);
}

void Trainer::make_optimizers() {
  adam_ = Optimizers(model_.primitives, model_.config.representation, config_, set_.scene_extent,
                     set_.grid.step);
}

double Trainer::flow_weight(int it) const {
  if (config_.ablate.no_flow_loss || model_.config.representation == model::Representation::kStgs)
    return 0;
  const double s = std::min(1.0, double(it) / config_.scaled(config_.flow_decay_until));
  return std::exp(std::log(config_.flow_weight_start) +
                  s * (std::log(config_.flow_weight_end) - std::log(config_.flow_weight_start)));
}

double Trainer::lr_factor(int it) const {
  const int start = config_.scaled(config_.lr_decay_start);
  if (it <= start || config_.iters <= start) return 1.0;
  return std::pow(config_.lr_decay_final, double(it - start) / double(config_.iters - start));
}

std::vector<Trainer::RenderPass> Trainer::render_passes(int i, bool flow) const {
  const int nf = int(set_.frames.size());
  if (model_.config.representation != model::Representation::kStgs && !config_.ablate.no_triple &&
      i > 0 && i + 1 < nf)
    return {{model::Group::kAll, false, false},
            {model::Group::kLeft, true, flow},
            {model::Group::kRight, true, flow}};
  return {{model::Group::kAll, false, flow}};
}

void Trainer::render_pass(const RenderPass& pass, int c, int i,
                          const std::vector<std::int32_t>& active, double w_flow, StepStats& stats,
                          model::PrimitiveGrads& grads) {
  const Camera& camera = set_.scene.cameras[set_.cameras[c]];
  const double t = set_.grid.at(i);
  const Image& target = target_;
  model::EvaluateOptions eo;
  eo.group = pass.group;
  eo.compensate = pass.compensate;
  eo.flow_features = pass.flow;
  eo.rows = &active;
  Stopwatch clock;
  model::Evaluated& e = evaluated_[int(pass.group)];
  model::evaluate(model_.primitives, model_.config, model_.grid, t, camera, eo, e, &shaded_);
  stats.seconds.evaluate += clock.lap();
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
  model::evaluate_backward(model_.primitives, model_.config, model_.grid, t, camera, eo, e, vg,
                           grads, &shaded_);
  stats.seconds.evaluate_backward += clock.lap();
}

std::string Trainer::finish() {
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

StepStats Trainer::step() {
  const int nc = int(set_.cameras.size()), nf = int(set_.frames.size());
  std::uniform_int_distribution<int> pick_camera(0, nc - 1), pick_frame(0, nf - 1);
  const int c = pick_camera(rng_), i = pick_frame(rng_);
  return step_view(c, i);
}

StepStats Trainer::step_view(int c, int i) {
  if (c < 0 || c >= int(set_.cameras.size()) || i < 0 || i >= int(set_.frames.size()))
    fail("training step: no view (camera {}, frame {}) among {} cameras x {} frames", c, i,
         set_.cameras.size(), set_.frames.size());
  Stopwatch step_clock;
  const int it = ++iteration_;
  StepStats stats;
  stats.iteration = it;
  model::Primitives& p = model_.primitives;
  model_.config.sh_degree =
      std::min(config_.max_sh_degree, it / config_.scaled(config_.sh_degree_every));
  stats.camera = set_.cameras[c], stats.frame = set_.frames[i];

  // Renders, losses and their gradient.
  const double w_flow = flow_weight(it);
  const std::vector<RenderPass> passes = render_passes(i, w_flow > 0);
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
  stats.seconds.evaluate += shade_clock.lap();
  for (const RenderPass& pass : passes) render_pass(pass, c, i, active, w_flow, stats, grads);
  stats.renders = int(passes.size());
  shade_clock.lap();
  model::shade_backward(p, model_.config, model_.grid, set_.grid.at(i), camera, active, shaded_,
                        grads);
  stats.seconds.evaluate_backward += shade_clock.lap();
  Stopwatch clock;
  const double reg = regularizer(p, active, config_.opacity_reg, config_.scale_reg);
  regularizer_backward(p, active, config_.opacity_reg, config_.scale_reg, grads);
  stats.loss = stats.image_loss + w_flow * stats.flow_loss + reg;
  stats.flow_weight = w_flow;

  // Optimiser step, then relocation, growth, noise and stretching.
  const double decay = lr_factor(it);
  const double means_decay = std::pow(config_.lr_means_final, double(it) / config_.iters);
  adam_.step(p, grads, active, means_decay, decay);
  if (camera_color()) step_camera_color(c, decay);
  stats.lr_means = adam_.means_rate(means_decay, decay);
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

namespace {

constexpr const char* kColorAdam = "camera_color";  // the camera colours' Adam in a checkpoint

// Writes `adam`'s moments to dir/adam/<name>_{m,v}.npy and its step count to state.
void save_adam(const fs::path& dir, const std::string& name, const Adam& adam, json& state) {
  state["adam_steps"][name] = adam.steps();
  const std::size_t rows = adam.rows();
  const std::size_t width = rows ? adam.m().size() / rows : 0;
  io::write_npy(dir / "adam" / (name + "_m.npy"), {rows, width}, adam.m());
  io::write_npy(dir / "adam" / (name + "_v.npy"), {rows, width}, adam.v());
}

}  // namespace

void Trainer::save_checkpoint(const fs::path& dir) const {
  AtomicDirectory out(dir, /*replace=*/true);
  model::write_model(out.temp_path() / "model.rgs", model_);
  std::ostringstream rng;
  rng << rng_;
  json state = {
      {"iteration", iteration_}, {"rng", rng.str()}, {"sh_degree", model_.config.sh_degree}};
  for (const auto& [name, adam] : adam_) save_adam(out.temp_path(), name, adam, state);
  if (camera_color()) save_adam(out.temp_path(), kColorAdam, color_adam_, state);
  write_text_file(out.temp_path() / "state.json", state.dump(2) + "\n");
  out.commit();
}

namespace {

// The value at `key` ("rng", "adam_steps/mu") of a checkpoint's state.json `file` as a T; throws
// Error naming the file and the key when it is missing or of another type.
template <typename T>
T state_value(const json& state, const std::string& key, const fs::path& file) {
  const json::json_pointer pointer("/" + key);
  if (!state.contains(pointer)) fail("{}: checkpoint state lacks '{}'", file.string(), key);
  try {
    return state.at(pointer).get<T>();
  } catch (const json::exception&) {
    fail("{}: checkpoint state '{}' has the wrong type: {}", file.string(), key,
         state.at(pointer).dump());
  }
}

// Reads what save_adam wrote into `adam`, which has the expected shape; throws Error naming the
// folder or the state file when it does not match.
void load_adam(const fs::path& dir, const std::string& name, const json& state,
               const fs::path& file, Adam& adam) {
  const auto m = io::read_npy(dir / "adam" / (name + "_m.npy")).to_float();
  const auto v = io::read_npy(dir / "adam" / (name + "_v.npy")).to_float();
  if (m.size() != adam.m().size() || v.size() != adam.v().size())
    fail("{}: optimizer state of '{}' does not match the model", dir.string(), name);
  adam.m() = m, adam.v() = v;
  adam.step_count() = state_value<std::int64_t>(state, "adam_steps/" + name, file);
}

}  // namespace

void Trainer::load_checkpoint(const fs::path& dir) {
  model_ = model::read_model(dir / "model.rgs");
  if (model_.grid.first != set_.grid.first || model_.grid.step != set_.grid.step ||
      model_.grid.count != set_.grid.count)
    fail(
        "{}: the checkpoint trained {} frames from frame {} (step {}), this run trains {} from "
        "frame {} (step {}): resume with the same --window and --train-frames",
        dir.string(), model_.grid.count, model_.grid.first, model_.grid.step, set_.grid.count,
        set_.grid.first, set_.grid.step);
  const fs::path file = dir / "state.json";
  const json state = io::read_json_file(file, "checkpoint state");
  iteration_ = state_value<int>(state, "iteration", file);
  if (!(std::istringstream(state_value<std::string>(state, "rng", file)) >> rng_))
    fail("{}: checkpoint state 'rng' is not a generator state", file.string());
  model_.config.sh_degree = state_value<int>(state, "sh_degree", file);
  make_optimizers();
  for (auto& [name, adam] : adam_) load_adam(dir, name, state, file, adam);
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
    load_adam(dir, kColorAdam, state, file, color_adam_);
  }
  rebuild_index();
}

namespace {

// A kill leaves the temporary sibling of the file or checkpoint being written
// (".<name>.tmp<pid>", core/atomic_file.hpp); with the run folder locked none is in use.
void remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<fs::path> stale;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 1 && name[0] == '.' && name.find(".tmp") != std::string::npos)
      stale.push_back(e.path());
  }
  for (const fs::path& p : stale) {
    fs::remove_all(p, ec);
    if (ec)
      fail("{}: cannot remove a temporary left by an interrupted run: {}", p.string(),
           ec.message());
    spdlog::info("removed {} (left by an interrupted run)", p.string());
  }
}

// The newest RUN/checkpoints/iter_NNNNNN, or empty.
fs::path latest_checkpoint(const fs::path& checkpoints) {
  fs::path latest;
  std::error_code ec;
  if (fs::is_directory(checkpoints, ec))
    for (const auto& e : fs::directory_iterator(checkpoints))
      if (e.is_directory() && e.path().filename().string().rfind("iter_", 0) == 0 &&
          (latest.empty() || e.path().filename() > latest.filename()))
        latest = e.path();
  return latest;
}

// Keeps the lines of log.jsonl up to `iteration`: a run resumed from a checkpoint writes the
// steps after it again.
void trim_log(const fs::path& log, int iteration) {
  std::error_code ec;
  if (!fs::is_regular_file(log, ec)) return;
  std::ifstream in(log);
  std::string line, kept;
  while (std::getline(in, line)) {
    const json entry = json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (entry.is_object() && entry.value("iteration", 0) <= iteration) kept += line + "\n";
  }
  in.close();
  write_text_file(log, kept);
}

// A run folder that holds a run: its model, checkpoints or config.
bool holds_run(const fs::path& out) {
  std::error_code ec;
  return fs::exists(out / "model.rgs", ec) || fs::exists(out / "checkpoints", ec) ||
         fs::exists(out / "config.json", ec);
}

}  // namespace

model::Model train(const io::Scene& scene, const TrainRun& run) {
  const fs::path checkpoints = run.out / "checkpoints";
  std::error_code ec;
  if (fs::exists(run.out, ec) && !fs::is_directory(run.out, ec))
    fail("{}: the run folder is a file", run.out.string());
  // Checked again once the folder is locked; here so that a refusal comes before the images load.
  if (!run.resume && !run.force && holds_run(run.out))
    fail(
        "{}: a training run is already there (pass --resume to continue it, --force to start "
        "afresh, or choose another folder)",
        run.out.string());
  // Every input is read before the run folder is created or changed: a bad scene leaves nothing.
  const TrainingSet set = load_training_set(scene, run.frames, run.window);
  const bool created = !fs::exists(run.out, ec);
  fs::create_directories(run.out, ec);
  if (ec) fail("{}: cannot create the run folder: {}", run.out.string(), ec.message());
  // Until config.json is committed, a failure removes the folder this run created.
  struct RemoveUnlessCommitted {
    fs::path dir;
    bool armed;
    ~RemoveUnlessCommitted() {
      std::error_code ignored;
      if (armed) fs::remove_all(dir, ignored);
    }
  } cleanup{run.out, created};
  const FolderLock lock(run.out, "run folder");
  remove_stale_temporaries(run.out);
  remove_stale_temporaries(checkpoints);

  TrainConfig config = run.config;
  fs::path latest;
  if (run.resume && fs::exists(run.out / "config.json")) {
    config = config_from_json(read_text_file(run.out / "config.json", "run config"), TrainConfig{},
                              (run.out / "config.json").string());
    latest = latest_checkpoint(checkpoints);
    if (run.iters) {
      config.iters = *run.iters;  // continue to the new total
      check_config(config, "--iters");
    }
  } else if (run.resume) {
    // Killed before config.json was written: nothing was trained, so the run starts afresh.
    if (fs::exists(checkpoints) || fs::exists(run.out / "model.rgs"))
      fail("{}: cannot resume: the run has no config.json (start afresh with --force)",
           run.out.string());
    spdlog::info("{}: nothing to resume yet (no config.json): starting afresh", run.out.string());
  } else if (holds_run(run.out)) {
    if (!run.force)
      fail(
          "{}: a training run is already there (pass --resume to continue it, --force to start "
          "afresh, or choose another folder)",
          run.out.string());
    for (const char* name : {"model.rgs", "config.json", "log.jsonl", "checkpoints"})
      fs::remove_all(run.out / name);
  }
  Trainer trainer(set, config);
  if (!latest.empty()) {
    trainer.load_checkpoint(latest);
    if (trainer.iteration() > config.iters)
      fail("{}: the run is at step {} already; --iters {} must not be smaller", run.out.string(),
           trainer.iteration(), config.iters);
    trim_log(run.out / "log.jsonl", trainer.iteration());
    if (run.iters) write_text_file(run.out / "config.json", to_json(config) + "\n");
    spdlog::info("resuming from {} (iteration {} of {})", latest.string(), trainer.iteration(),
                 config.iters);
  } else {
    const std::string note = trainer.initialize();
    fs::remove(run.out / "log.jsonl", ec);  // of a run killed before its first checkpoint
    write_text_file(run.out / "config.json", to_json(config) + "\n");
    spdlog::info("{}", note);
  }
  cleanup.armed = false;
  spdlog::info(
      "training {} primitives (cap {}) on {} cameras x {} frames ({:.0f} MB of images), {} flow "
      "files, {} iterations",
      trainer.model().primitives.size(), config.cap, set.cameras.size(), set.frames.size(),
      double(set.image_bytes()) / 1e6, set.flow_files(), config.iters);
  std::ofstream log(run.out / "log.jsonl", std::ios::app);
  if (!log) fail("{}: cannot open the training log", (run.out / "log.jsonl").string());
  const auto flush_log = [&] {
    log.flush();
    if (!log) fail("{}: write failed (disk full?)", (run.out / "log.jsonl").string());
  };
  const auto checkpoint_dir = [&](int iteration) {
    return checkpoints / fmt::format("iter_{:06d}", iteration);
  };
  // The loop handles Ctrl-C itself (below): its bar must not throw.
  Progress progress("train", std::size_t(config.iters), run.progress, /*interruptible=*/false);
  progress.tick(std::size_t(trainer.iteration()));
  double psnr_avg = 0, loss_avg = 0;
  StageSeconds since_log;  // summed over the steps since the last log line
  int steps_since_log = 0;
  const int start = trainer.iteration();
  while (trainer.iteration() < config.iters) {
    if (const int signal = interrupt_signal()) {
      // The step that was running when the signal came has finished: keep it.
      progress.finish();
      flush_log();
      const int it = trainer.iteration();
      if (it == 0)
        throw Interrupted(signal, fmt::format("interrupted by {} before the first step; resume "
                                              "with --resume (it starts afresh)",
                                              signal_name(signal)));
      if (!fs::exists(checkpoint_dir(it))) trainer.save_checkpoint(checkpoint_dir(it));
      throw Interrupted(signal,
                        fmt::format("interrupted at step {}; checkpoint written to {}; resume with "
                                    "--resume",
                                    it, checkpoint_dir(it).string()));
    }
    const StepStats s = trainer.step();
    since_log += s.seconds, ++steps_since_log;
    constexpr double kSmoothing = 0.05;  // exponential moving average for the progress line
    const bool first = s.iteration == start + 1;
    psnr_avg = first ? s.psnr : (1 - kSmoothing) * psnr_avg + kSmoothing * s.psnr;
    loss_avg = first ? s.loss : (1 - kSmoothing) * loss_avg + kSmoothing * s.loss;
    if (s.iteration % 10 == 0 || s.relocated || s.stretched) {
      const double ms = 1e3 / steps_since_log;
      log << json{{"iteration", s.iteration},
                  {"camera", s.camera},
                  {"frame", s.frame},
                  {"loss", s.loss},
                  {"image_loss", s.image_loss},
                  {"flow_loss", s.flow_loss},
                  {"flow_weight", s.flow_weight},
                  {"psnr", s.psnr},
                  {"primitives", s.primitives},
                  {"active", s.active},
                  {"relocated", s.relocated},
                  {"added", s.added},
                  {"stretched", s.stretched},
                  {"pruned", s.pruned},
                  {"ms_per_step",
                   {{"evaluate", since_log.evaluate * ms},
                    {"render_forward", since_log.render_forward * ms},
                    {"losses", since_log.losses * ms},
                    {"render_backward", since_log.render_backward * ms},
                    {"evaluate_backward", since_log.evaluate_backward * ms},
                    {"optimizer", since_log.optimizer * ms},
                    {"other", since_log.other() * ms},
                    {"total", since_log.total * ms}}}}
                 .dump()
          << "\n";
      since_log = {}, steps_since_log = 0;
    }
    progress.tick(1, fmt::format("loss {:.4f} psnr {:.2f} n {}", loss_avg, psnr_avg, s.primitives));
    // Also at the last step, before the final prune: a later --resume --iters N continues from
    // there.
    if (s.iteration % config.checkpoint_every == 0 || s.iteration == config.iters) {
      flush_log();
      trainer.save_checkpoint(checkpoint_dir(s.iteration));
    }
  }
  progress.finish();
  flush_log();
  spdlog::info("{}", trainer.finish());
  // A window's model is stored on the clip's grid with its window, for merge.
  const model::Model model =
      set.clip_grid ? model::with_window(trainer.model(), *set.clip_grid, config.model_config())
                    : trainer.model();
  model::write_model(run.out / "model.rgs", model);
  spdlog::info("model: {} ({} primitives); peak memory {:.0f} MB", (run.out / "model.rgs").string(),
               model.primitives.size(), double(peak_rss_bytes()) / 1e6);
  return model;
}

}  // namespace retimegs::train
