// Training throughput (see bench/README.md): one full training step of the RetimeGS recipe at an
// interior training frame (triple render with flow features, losses, backward through the
// rasteriser and the model, regulariser, Adam, noise) at 640x360, on a synthetic model of `total`
// primitives of which `active` belong to the two intervals either side of the step's frame (the
// left and right groups of its triple render; all of them at half opacity in its all-primitives
// render); the others belong to the remaining intervals, invisible at this time. Relocation runs
// every relocate_every steps in training: its cost, measured on the same model, is added to each
// step divided by that period.
//
// The step works on its active set (model::TemporalIndex): evaluation, regulariser, Adam, noise
// and the clearing of the gradient rows cover the `active` primitives, not the `total`.
//
// Counters (milliseconds per step): the stages of train::StageSeconds (losses: image and flow
// losses with their gradients; other: the rest of the step, noise injection and the clearing of
// the gradient rows included), relocation_ms, the amortised relocation, and `active`, the rows in
// the step's active set.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "bench_main.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/core/stopwatch.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train/relocation.hpp"

namespace {

using namespace retimegs;

constexpr int kWidth = 640, kHeight = 360;
constexpr int kCameras = 8, kFrames = 9, kStepFrame = kFrames / 2;
constexpr double kFrameStep = 2;  // training on the even frames of a 17-frame clip

// Cameras on a circle of radius 4 around a 2-unit cube of primitives, with images of a smooth
// pattern and zero flows (every pixel known) at every frame.
train::TrainingSet synthetic_set() {
  train::TrainingSet set;
  set.scene.num_frames = 2 * (kFrames - 1) + 1;
  set.scene.fps = 30;
  set.scene.up = {0, 1, 0};
  for (int c = 0; c < kCameras; ++c) {
    Camera cam;
    cam.name = "cam" + std::to_string(c);
    cam.width = kWidth, cam.height = kHeight;
    cam.fx = cam.fy = 450, cam.cx = kWidth / 2.0, cam.cy = kHeight / 2.0;
    const double a = 2 * M_PI * c / kCameras;
    cam.world_to_camera = look_at({4 * std::cos(a), 0.5, 4 * std::sin(a)}, {0, 0, 0}, {0, 1, 0});
    set.scene.cameras.push_back(cam);
    set.cameras.push_back(c);
  }
  for (int i = 0; i < kFrames; ++i) set.frames.push_back(int(kFrameStep) * i);
  set.grid = {0.0, kFrameStep, kFrames};
  set.scene_extent = 1.1 * 4;
  Image image(kWidth, kHeight, 3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      for (int ch = 0; ch < 3; ++ch)
        image.at(y, x, ch) = float(0.5 + 0.4 * std::sin(0.05 * x + 0.07 * y + 2.1 * ch));
  set.images.assign(kCameras, std::vector<PackedImage>(kFrames, pack(image, "pattern")));
  set.masks.assign(kCameras, std::vector<std::optional<Image>>(kFrames));
  set.forward.assign(kCameras, std::vector<std::optional<Flow>>(kFrames, Flow(kWidth, kHeight)));
  set.backward = set.forward;
  set.points.assign(kFrames, std::nullopt);
  return set;
}

// `total` primitives in the cube, each of one interval [t_k, t_{k+1}] as initialisation makes them;
// `active` of them in the intervals either side of kStepFrame, the rest spread over the others.
// 5 % are dead (opacity under the relocation threshold). The rows come in random order, as
// relocation and growth leave them after a while of training; the trainer puts them in its
// locality order.
model::Primitives synthetic_primitives(std::size_t total, std::size_t active) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> unit(-1, 1), colour(0, 1);
  std::vector<int> far_intervals;
  for (int k = 0; k + 1 < kFrames; ++k)
    if (k != kStepFrame - 1 && k != kStepFrame) far_intervals.push_back(k);
  model::Primitives p;
  p.resize(total);
  for (std::size_t j = 0; j < total; ++j) {
    const int interval =
        j < active ? kStepFrame - 1 + int(j % 2) : far_intervals[j % far_intervals.size()];
    for (int a = 0; a < 3; ++a) {
      p.mu[3 * j + a] = unit(rng);
      p.log_scale[3 * j + a] = std::log(0.02f) + 0.5f * unit(rng);
      p.sh[model::Primitives::kShWidth * j + a] = (colour(rng) - 0.5f) / float(model::kShC0);
      for (int k = 1; k < model::Primitives::kShCoeffs; ++k)
        p.sh[model::Primitives::kShWidth * j + 3 * k + a] = 0.02f * unit(rng);
      for (int r = 0; r < 3; ++r) p.velocity[9 * j + 3 * r + a] = 0.01f * unit(rng);
    }
    for (int a = 0; a < 4; ++a) p.q0[4 * j + a] = a == 0 ? 1 : 0.2f * unit(rng);
    p.opacity_logit[j] = j % 20 == 0 ? -8.0f : unit(rng);
    p.mu_tau[j] = float(kFrameStep * (interval + 0.5));
    p.tau_l[j] = p.tau_r[j] = float(kFrameStep / 2);
  }
  std::vector<std::int32_t> old_from_new(total);
  std::iota(old_from_new.begin(), old_from_new.end(), 0);
  std::shuffle(old_from_new.begin(), old_from_new.end(), rng);
  p.reorder(old_from_new);
  return p;
}

void BM_TrainStep(benchmark::State& state) {
  const auto total = std::size_t(state.range(0)), active = std::size_t(state.range(1));
  set_threads(int(state.range(2)));
  const train::TrainingSet set = synthetic_set();
  train::TrainConfig config;
  config.cap = total;
  config.sh_degree_every = 1;  // the full SH degree from the first steps on, as in most of training
  train::CpuStep trainer(set, config);
  const model::Primitives primitives = synthetic_primitives(total, active);
  trainer.initialize(primitives);
  for (int c = 0; c < 3; ++c) trainer.step_view(c, kStepFrame);  // SH degree 3, warm caches

  double relocation = 0;
  {
    model::Primitives copy = primitives;
    std::mt19937_64 rng(1);
    Stopwatch clock;
    train::relocate(copy, train::RelocationScore::kOpacityTimesDuration, config.min_opacity, rng);
    train::grow(copy, train::RelocationScore::kOpacityTimesDuration, config.cap, config.growth,
                config.min_opacity, rng);
    relocation = clock.lap() / config.scaled(config.relocate_every);
  }

  train::StageSeconds sum;
  double active_rows = 0;
  int camera = 0;
  for (auto _ : state) {
    const train::StepStats s = trainer.step_view(camera, kStepFrame);
    camera = (camera + 1) % kCameras;
    state.SetIterationTime(s.seconds.total + relocation);
    sum.slice += s.seconds.slice;
    sum.render_forward += s.seconds.render_forward;
    sum.losses += s.seconds.losses;
    sum.render_backward += s.seconds.render_backward;
    sum.slice_backward += s.seconds.slice_backward;
    sum.optimizer += s.seconds.optimizer;
    sum.total += s.seconds.total;
    active_rows += double(s.active);
  }
  const double ms = 1e3 / double(state.iterations());
  state.counters["slice_ms"] = sum.slice * ms;
  state.counters["render_fwd_ms"] = sum.render_forward * ms;
  state.counters["losses_ms"] = sum.losses * ms;
  state.counters["render_bwd_ms"] = sum.render_backward * ms;
  state.counters["slice_bwd_ms"] = sum.slice_backward * ms;
  state.counters["adam_ms"] = sum.optimizer * ms;
  state.counters["other_ms"] = sum.other() * ms;
  state.counters["relocation_ms"] = relocation * 1e3;
  state.counters["active"] = active_rows / double(state.iterations());
  state.counters["peak_rss_MB"] = double(peak_rss_bytes()) / 1e6;  // of the process so far
}

BENCHMARK(BM_TrainStep)
    ->ArgNames({"total", "active", "threads"})
    ->ArgsProduct({{50000, 400000}, {50000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime()
    ->MinTime(2.0);

}  // namespace

RETIMEGS_BENCHMARK_MAIN()
