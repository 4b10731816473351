#include "retimegs/train/trainer.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/model/evaluate.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/train/initialize.hpp"
#include "retimegs/train/losses.hpp"
#include "retimegs/train/relocation.hpp"
#include "retimegs/train/stretch.hpp"

namespace retimegs::train {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

struct RenderPass {
  model::Group group;
  bool compensate, flow;
};

// Field name -> (parameters, gradient) of the optimised fields of `rep`.
std::vector<std::tuple<std::string, std::vector<float>*, std::vector<float>*>> optimised_fields(
    model::Primitives& p, model::PrimitiveGrads& g, model::Representation rep) {
  std::vector<std::tuple<std::string, std::vector<float>*, std::vector<float>*>> out = {
      {"mu", &p.mu, &g.v_mu},
      {"velocity", &p.velocity, &g.v_velocity},
      {"log_scale", &p.log_scale, &g.v_log_scale},
      {"q0", &p.q0, &g.v_q0},
      {"q1", &p.q1, &g.v_q1},
      {"sh", &p.sh, &g.v_sh},
      {"opacity_logit", &p.opacity_logit, &g.v_opacity_logit}};
  if (rep == model::Representation::kStgs) {
    out.emplace_back("mu_tau", &p.mu_tau, &g.v_mu_tau);
    out.emplace_back("temporal_log_scale", &p.temporal_log_scale, &g.v_temporal_log_scale);
  }
  return out;
}

int field_width(const model::Primitives& p, const std::string& name) {
  for (const auto& f : p.fields())
    if (name == f.name) return f.width;
  fail("unknown field '{}'", name);
}

}  // namespace

Trainer::Trainer(const TrainingSet& set, const TrainConfig& config)
    : set_(set), config_(config), rng_(config.seed) {
  model_.grid = set.grid;
  model_.config = config.model_config();
  model_.training_config = to_json(config);
}

std::string Trainer::initialize() {
  InitOptions options;
  options.use_flow = !config_.ablate.no_flow_init;
  options.representation = model_.config.representation;
  options.max_primitives = config_.cap;
  options.initial_opacity = config_.init_opacity;
  options.seed = config_.seed;
  std::string note;
  model_.primitives = train::initialize(set_, options, note);
  make_optimizers();
  return note;
}

void Trainer::make_optimizers() {
  adam_.clear();
  model::PrimitiveGrads unused;
  for (const auto& [name, params, grads] :
       optimised_fields(model_.primitives, unused, model_.config.representation)) {
    std::vector<float> column_scale;
    if (name == "sh") {  // higher SH bands learn at 1/20 of the DC rate
      column_scale.assign(model::Primitives::kShWidth, float(config_.lr_sh_rest_factor));
      std::fill_n(column_scale.begin(), 3, 1.0f);
    }
    adam_.emplace(name, Adam(model_.primitives.size(), field_width(model_.primitives, name), {},
                             column_scale));
  }
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

StepStats Trainer::step() {
  const int it = ++iteration_;
  StepStats stats;
  stats.iteration = it;
  model::Primitives& p = model_.primitives;
  const model::Representation rep = model_.config.representation;
  const bool stgs = rep == model::Representation::kStgs;
  model_.config.sh_degree =
      std::min(config_.max_sh_degree, it / config_.scaled(config_.sh_degree_every));

  // The view of this step.
  const int nc = int(set_.cameras.size()), nf = int(set_.frames.size());
  std::uniform_int_distribution<int> pick_camera(0, nc - 1), pick_frame(0, nf - 1);
  const int c = pick_camera(rng_), i = pick_frame(rng_);
  stats.camera = set_.cameras[c], stats.frame = set_.frames[i];
  const Camera& camera = set_.scene.cameras[set_.cameras[c]];
  const double t = set_.grid.at(i);
  const Image& target = set_.images[c][i];

  // Renders: triple at interior frames (flow on the two groups), one at the ends.
  const double w_flow = flow_weight(it);
  const bool flow = w_flow > 0;
  std::vector<RenderPass> passes;
  if (!stgs && !config_.ablate.no_triple && i > 0 && i + 1 < nf)
    passes = {{model::Group::kAll, false, false},
              {model::Group::kLeft, true, flow},
              {model::Group::kRight, true, flow}};
  else
    passes = {{model::Group::kAll, false, flow}};

  model::PrimitiveGrads grads(p.size());
  const render::RenderOptions render_options;
  for (std::size_t k = 0; k < passes.size(); ++k) {
    const RenderPass& pass = passes[k];
    model::EvaluateOptions eo;
    eo.group = pass.group;
    eo.compensate = pass.compensate;
    eo.flow_features = pass.flow;
    const model::Evaluated e = model::evaluate(p, model_.config, model_.grid, t, camera, eo);
    const int channels = e.gaussians.channels;
    const std::vector<float> background(channels, 0.0f);
    const render::RenderOutput out =
        render::rasterize_forward(e.gaussians, camera, background.data(), render_options);
    Image v_image(camera.width, camera.height, channels);
    stats.image_loss += image_loss(out.blend.image, target, config_.ssim_lambda, 1.0, v_image);
    if (pass.flow) {
      if (const auto& f = set_.forward[c][i])
        stats.flow_loss +=
            flow_loss(out.blend.image, model::kForwardFlowChannel, *f, w_flow, v_image);
      if (const auto& f = set_.backward[c][i])
        stats.flow_loss +=
            flow_loss(out.blend.image, model::kBackwardFlowChannel, *f, w_flow, v_image);
    }
    if (k == 0) stats.psnr = psnr(out.blend.image, target);
    const GaussianGrads vg = render::rasterize_backward(e.gaussians, camera, background.data(),
                                                        render_options, out, v_image.data.data());
    model::evaluate_backward(p, model_.config, model_.grid, t, camera, eo, e, vg, grads);
  }
  stats.renders = int(passes.size());

  const double reg = regularizer(p, config_.opacity_reg, config_.scale_reg);
  regularizer_backward(p, config_.opacity_reg, config_.scale_reg, grads);
  stats.loss = stats.image_loss + w_flow * stats.flow_loss + reg;
  stats.flow_weight = w_flow;

  // Adam.
  const double decay = lr_factor(it);
  const double extent = set_.scene_extent, dt = set_.grid.step;
  const double means_decay = std::pow(config_.lr_means_final, double(it) / config_.iters);
  const double lr_means = config_.lr_means * extent * means_decay * decay;
  const std::map<std::string, double> lr = {
      {"mu", lr_means},
      {"velocity", config_.lr_velocity * extent / dt * means_decay * decay},
      {"log_scale", config_.lr_scales * decay},
      {"q0", config_.lr_quats * decay},
      {"q1", config_.lr_quat_rate / dt * decay},
      {"sh", config_.lr_sh0 * decay},
      {"opacity_logit", config_.lr_opacities * decay},
      {"mu_tau", config_.lr_temporal_center * decay},
      {"temporal_log_scale", config_.lr_temporal_scale * decay}};
  for (auto& [name, params, g] : optimised_fields(p, grads, rep))
    adam_.at(name).step(params->data(), g->data(), lr.at(name));
  stats.lr_means = lr_means;
  inject_noise(p, lr_means, rng_);

  // Relocation and growth.
  if (it % config_.scaled(config_.relocate_every) == 0 &&
      it > config_.scaled(config_.relocate_start) && it < config_.scaled(config_.relocate_stop)) {
    const Relocation moved = relocate(p, rep, config_.min_opacity, rng_);
    const Relocation grown = grow(p, rep, config_.cap, config_.growth, config_.min_opacity, rng_);
    for (auto& [name, adam] : adam_) {
      adam.reset_rows(moved.touched);
      adam.resize(p.size());
      adam.reset_rows(grown.touched);
    }
    stats.relocated = moved.moved, stats.added = grown.added;
  }
  // Dynamic stretching.
  if (!stgs && !config_.ablate.no_stretch && it % config_.scaled(config_.stretch_every) == 0 &&
      it < config_.iters) {
    const StretchSettings settings{config_.stretch_distance * extent, config_.stretch_color,
                                   config_.stretch_speed * extent};
    const StretchResult s = stretch(p, model_.config, model_.grid, settings, rng_);
    stats.stretched = s.stretched, stats.pruned = s.pruned;
  }
  stats.primitives = p.size();
  return stats;
}

void Trainer::save_checkpoint(const fs::path& dir) const {
  AtomicDirectory out(dir, /*replace=*/true);
  model::write_model(out.temp_path() / "model.rgs", model_);
  std::ostringstream rng;
  rng << rng_;
  json state = {
      {"iteration", iteration_}, {"rng", rng.str()}, {"sh_degree", model_.config.sh_degree}};
  for (const auto& [name, adam] : adam_) {
    state["adam_steps"][name] = adam.steps();
    const std::size_t rows = adam.rows();
    const std::size_t width = rows ? adam.m().size() / rows : 0;
    io::write_npy(out.temp_path() / "adam" / (name + "_m.npy"), {rows, width}, adam.m());
    io::write_npy(out.temp_path() / "adam" / (name + "_v.npy"), {rows, width}, adam.v());
  }
  std::ofstream(out.temp_path() / "state.json") << state.dump(2) << "\n";
  out.commit();
}

void Trainer::load_checkpoint(const fs::path& dir) {
  model_ = model::read_model(dir / "model.rgs");
  json state;
  try {
    std::ifstream in(dir / "state.json");
    state = json::parse(in);
    iteration_ = state.at("iteration").get<int>();
    std::istringstream(state.at("rng").get<std::string>()) >> rng_;
    model_.config.sh_degree = state.at("sh_degree").get<int>();
  } catch (const json::exception& e) {
    fail("{}: malformed checkpoint state: {}", (dir / "state.json").string(), e.what());
  }
  make_optimizers();
  for (auto& [name, adam] : adam_) {
    const auto m = io::read_npy(dir / "adam" / (name + "_m.npy")).to_float();
    const auto v = io::read_npy(dir / "adam" / (name + "_v.npy")).to_float();
    if (m.size() != adam.m().size() || v.size() != adam.v().size())
      fail("{}: optimizer state of '{}' does not match the model", dir.string(), name);
    adam.m() = m, adam.v() = v;
    adam.step_count() = state["adam_steps"].value(name, std::int64_t(0));
  }
}

model::Model train(const io::Scene& scene, const TrainRun& run) {
  const fs::path checkpoints = run.out / "checkpoints";
  TrainConfig config = run.config;
  fs::path latest;
  if (run.resume) {
    if (!fs::exists(run.out / "config.json"))
      fail("{}: nothing to resume (no config.json)", run.out.string());
    std::ifstream in(run.out / "config.json");
    std::stringstream text;
    text << in.rdbuf();
    config = config_from_json(text.str(), TrainConfig{}, (run.out / "config.json").string());
    if (fs::exists(checkpoints))
      for (const auto& e : fs::directory_iterator(checkpoints))
        if (e.is_directory() && e.path().filename().string().rfind("iter_", 0) == 0 &&
            (latest.empty() || e.path().filename() > latest.filename()))
          latest = e.path();
  } else if (fs::exists(run.out / "model.rgs") || fs::exists(checkpoints)) {
    fail(
        "{}: a training run is already there (pass --resume to continue it, or choose another "
        "folder)",
        run.out.string());
  }
  fs::create_directories(run.out);
  const TrainingSet set = load_training_set(scene, run.frames);
  Trainer trainer(set, config);
  if (!latest.empty()) {
    trainer.load_checkpoint(latest);
    spdlog::info("resuming from {} (iteration {})", latest.string(), trainer.iteration());
  } else {
    spdlog::info("{}", trainer.initialize());
    AtomicFile cfg(run.out / "config.json");
    std::ofstream(cfg.temp_path()) << to_json(config) << "\n";
    cfg.commit();
  }
  spdlog::info(
      "training {} primitives (cap {}) on {} cameras x {} frames, {} flow files, {} "
      "iterations",
      trainer.model().primitives.size(), config.cap, set.cameras.size(), set.frames.size(),
      set.flow_files(), config.iters);
  std::ofstream log(run.out / "log.jsonl", std::ios::app);
  Progress progress("train", std::size_t(config.iters), run.progress);
  progress.tick(std::size_t(trainer.iteration()));
  double psnr_avg = 0, loss_avg = 0;
  while (trainer.iteration() < config.iters) {
    const StepStats s = trainer.step();
    constexpr double kSmoothing = 0.05;  // exponential moving average for the progress line
    psnr_avg = s.iteration == 1 ? s.psnr : (1 - kSmoothing) * psnr_avg + kSmoothing * s.psnr;
    loss_avg = s.iteration == 1 ? s.loss : (1 - kSmoothing) * loss_avg + kSmoothing * s.loss;
    if (s.iteration % 10 == 0 || s.relocated || s.stretched)
      log << json{{"iteration", s.iteration},
                  {"camera", s.camera},
                  {"frame", s.frame},
                  {"loss", s.loss},
                  {"image_loss", s.image_loss},
                  {"flow_loss", s.flow_loss},
                  {"flow_weight", s.flow_weight},
                  {"psnr", s.psnr},
                  {"primitives", s.primitives},
                  {"relocated", s.relocated},
                  {"added", s.added},
                  {"stretched", s.stretched},
                  {"pruned", s.pruned}}
                 .dump()
          << "\n";
    progress.tick(1, fmt::format("loss {:.4f} psnr {:.2f} n {}", loss_avg, psnr_avg, s.primitives));
    if (s.iteration % config.checkpoint_every == 0 && s.iteration < config.iters) {
      log.flush();
      trainer.save_checkpoint(checkpoints / fmt::format("iter_{:06d}", s.iteration));
    }
  }
  progress.finish();
  model::write_model(run.out / "model.rgs", trainer.model());
  spdlog::info("model: {} ({} primitives)", (run.out / "model.rgs").string(),
               trainer.model().primitives.size());
  return trainer.model();
}

}  // namespace retimegs::train
