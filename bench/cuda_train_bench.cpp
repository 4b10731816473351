// The training step's time and memory at the paper's scale, on the GPU and on this machine's CPU
// cores in the same run: 32 cameras x 17 frames at 1024x1024, trained on the 9 even frames, a
// 1 000 000 primitive model, the full recipe (triple rendering at interior frames, the flow loss
// on every group render, SH degree 3, per-camera colour, the regulariser, selective Adam, noise).
// The scene is generated in memory (its flows alone would be 5 GB of .flo files): images of soft
// moving bands, flows of their motion, and a million primitives spread through the cameras' common
// view with windows of one to all intervals, as a trained model's mix of moving and static
// content. Steps are timed by the wall clock around step() (the step reads its losses back, so
// each step ends with the device idle); peak GPU memory is the most cudaMemGetInfo showed in use
// after any step, less what was in use before the step was made.
//
//   build/bench/cuda_train_bench [--primitives N] [--size W] [--gpu-steps N] [--cpu-steps N]
//   (lines "headline: ..." feed scripts/gpu_check.sh)
#include <cuda_runtime_api.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numbers>
#include <random>
#include <string>

#include <omp.h>

#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/cuda/losses.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/train/step.hpp"

namespace {

using namespace retimegs;

struct Settings {
  int cameras = 32, frames = 17, size = 1024;
  std::size_t primitives = 1000000;
  int gpu_steps = 30, cpu_steps = 3;
};

// A band pattern moving right by `shift` pixels per frame, different per camera: smooth, so that
// its flow (the shift everywhere) is exact.
Image band_image(int size, int camera, double frame, double shift) {
  Image image(size, size, 3);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double phase = (x - shift * frame) * 0.02 + y * 0.013 + camera;
      for (int c = 0; c < 3; ++c) image.at(y, x, c) = float(0.5 + 0.4 * std::sin(phase + 2.1 * c));
    }
  return image;
}

train::TrainingSet paper_scale_set(const Settings& s) {
  io::Scene scene;
  scene.num_frames = s.frames;
  scene.fps = 30;
  scene.up = {0, -1, 0};
  for (int c = 0; c < s.cameras; ++c) {
    const double angle = 2 * std::numbers::pi * c / s.cameras;
    Camera cam;
    cam.name = "cam" + std::to_string(c);
    cam.width = cam.height = s.size;
    cam.fx = cam.fy = 1.2 * s.size;
    cam.cx = cam.cy = 0.5 * s.size;
    cam.world_to_camera =
        look_at({4 * std::sin(angle), -0.8, -4 * std::cos(angle)}, {0, 0, 0}, scene.up);
    scene.cameras.push_back(cam);
  }
  train::TrainingSet set =
      train::unloaded_training_set(scene, io::training_views(scene, io::FrameSelection::kEven));
  const std::size_t nc = set.cameras.size(), nf = set.frames.size();
  constexpr double kShift = 3;  // pixels per scene frame
#pragma omp parallel for collapse(2) schedule(dynamic)
  for (std::size_t c = 0; c < nc; ++c)
    for (std::size_t i = 0; i < nf; ++i) {
      set.images[c][i] = pack(band_image(s.size, int(c), set.frames[i], kShift), "bench image");
      const auto flow = [&](double frames) {
        Flow f(s.size, s.size);
        for (std::size_t p = 0; p < f.pixels(); ++p) f.uv[2 * p] = float(kShift * frames);
        return f;
      };
      if (i + 1 < nf) set.forward[c][i] = flow(set.grid.step);
      if (i > 0) set.backward[c][i] = flow(-set.grid.step);
    }
  return set;
}

// Primitives in a ball of radius 1 about the origin, each visible over a run of 1 to all training
// intervals, with moderate footprints, random rotations, SH and opacities.
model::Primitives bench_primitives(const train::TrainingSet& set, std::size_t n) {
  model::Primitives p;
  p.resize(n);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1, 1), u01(0, 1);
  std::normal_distribution<float> normal(0, 1);
  const int intervals = set.grid.count - 1;
  for (std::size_t i = 0; i < n; ++i) {
    float x, y, z;
    do x = u(rng), y = u(rng), z = u(rng);
    while (x * x + y * y + z * z > 1);
    p.mu[3 * i] = x, p.mu[3 * i + 1] = y, p.mu[3 * i + 2] = z;
    for (int k = 0; k < 9; ++k) p.velocity[9 * i + k] = 0.01f * normal(rng);
    for (int k = 0; k < 3; ++k) p.log_scale[3 * i + k] = std::log(0.004f + 0.01f * u01(rng));
    for (int k = 0; k < 4; ++k) p.q0[4 * i + k] = normal(rng);
    for (int k = 0; k < model::Primitives::kShWidth; ++k)
      p.sh[model::Primitives::kShWidth * i + k] = (k < 3 ? 0.5f : 0.05f) * normal(rng);
    p.opacity_logit[i] = 2 * u(rng);
    const int span = 1 + int(u01(rng) * intervals * 0.999f);
    const int start = int(u01(rng) * (intervals - span + 0.999f));
    const double t0 = set.grid.at(start), t1 = set.grid.at(start + span);
    p.mu_tau[i] = float(0.5 * (t0 + t1));
    p.tau_l[i] = p.tau_r[i] = float(0.5 * (t1 - t0));
  }
  return p;
}

std::size_t gpu_memory_in_use() {
  std::size_t free = 0, total = 0;
  cuda::check(cudaMemGetInfo(&free, &total), "cudaMemGetInfo");
  return total - free;
}

struct Timing {
  double ms_per_step = 0;
  double active = 0;            // mean active rows
  train::StageSeconds seconds;  // summed over the timed steps
};

// The mean stage times in ms. On the GPU they are host times around asynchronous launches unless
// CUDA_LAUNCH_BLOCKING=1 makes every launch wait for its kernel.
void print_stages(const char* device, const Timing& t, int steps) {
  const auto ms = [&](double seconds) { return seconds * 1e3 / steps; };
  const train::StageSeconds& s = t.seconds;
  std::printf(
      "%s stages (ms/step): slice %.2f, forward %.2f, losses %.2f, backward %.2f, slice backward "
      "%.2f, optimizer %.2f, other %.2f\n",
      device, ms(s.slice), ms(s.render_forward), ms(s.losses), ms(s.render_backward),
      ms(s.slice_backward), ms(s.optimizer), ms(s.other()));
}

Timing time_steps(train::TrainingStep& step, int warmup, int steps, std::size_t* peak) {
  for (int k = 0; k < warmup; ++k) step.step();
  Timing t;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) {
    const train::StepStats stats = step.step();
    t.active += double(stats.active) / steps;
    t.seconds += stats.seconds;
    if (peak) *peak = std::max(*peak, gpu_memory_in_use());
  }
  t.ms_per_step =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() /
      steps;
  return t;
}

// Relocation and growth (decided on the host from three fields of every row, applied on the
// device, then the temporal index rebuilt and the rows reordered): steps with a reshape every 10th
// iteration, the model free to grow, against the steps between them.
void time_reshapes(const train::TrainingSet& set, train::TrainConfig config,
                   const model::Primitives& primitives) {
  config.relocate_start = 5;
  config.relocate_every = 10;
  config.cap = 2 * primitives.size();
  const std::unique_ptr<train::TrainingStep> step =
      train::make_step(set, config, cuda::Device::kCuda);
  step->initialize(primitives);
  double reshape_ms = 0, other_ms = 0;
  int reshapes = 0, others = 0;
  std::size_t added = 0;
  for (int k = 0; k < 30; ++k) {
    const auto start = std::chrono::steady_clock::now();
    const train::StepStats stats = step->step();
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (stats.iteration % config.relocate_every == 0 && stats.iteration > config.relocate_start) {
      reshape_ms += ms, ++reshapes, added += stats.added;
    } else if (k >= 5) {
      other_ms += ms, ++others;
    }
  }
  std::printf(
      "headline: relocation and growth: %.1f ms a reshape step (%d, %zu rows added in all, %zu "
      "primitives after), %.1f ms the others\n",
      reshape_ms / std::max(reshapes, 1), reshapes, added, step->primitive_count(),
      other_ms / std::max(others, 1));
  std::fflush(stdout);
}

// The view's two flows copied to the device, ms per step over 20 views: from pageable host memory
// (DeviceFlow::upload) and as the step copies them, page-locked (cuda::FlowUploads), which it
// overlaps with the kernels before the flow loss.
void time_flow_uploads(const train::TrainingSet& set) {
  constexpr int kViews = 20;
  std::vector<const Flow*> flows;
  for (int k = 0; k < kViews; ++k) {
    const std::size_t c = std::size_t(k) % set.cameras.size(), i = 1;
    flows.push_back(&*set.forward[c][i]);
    flows.push_back(&*set.backward[c][i]);
  }
  const auto ms_per_view = [&](auto&& copy) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < kViews; ++k) copy(k);
    cuda::check(cudaDeviceSynchronize(), "flow uploads");
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
               .count() /
           kViews;
  };
  cuda::DeviceFlow forward, backward;
  const double pageable = ms_per_view([&](int k) {
    forward.upload(*flows[2 * k]);
    backward.upload(*flows[2 * k + 1]);
  });
  cuda::FlowUploads uploads(flows);
  const double locked = ms_per_view([&](int k) {
    uploads.start(flows[2 * k], flows[2 * k + 1]);
    uploads.forward();
  });
  std::printf("headline: the view's flows copied: %.2f ms a step pageable, %.2f ms page-locked\n",
              pageable, locked);
}

// The benchmark; its figures on stdout.
int run(const Settings& s) {
  const cuda::DeviceQuery gpu = cuda::query_device();
  if (!gpu.usable()) {
    std::printf("no usable GPU: %s\n", gpu.reason.c_str());
    return 0;
  }
  std::printf("device: %s; host: %d threads\n", gpu.device->name.c_str(), omp_get_max_threads());
  const train::TrainingSet set = paper_scale_set(s);
  const model::Primitives primitives = bench_primitives(set, s.primitives);
  train::TrainConfig config;  // the paper's recipe and schedule
  config.cap = s.primitives;
  config.sh_degree_every = 1;  // SH degree 3 from the fourth step, as late in training
  std::printf("scene: %d cameras x %zu training frames at %dx%d, %zu primitives\n", s.cameras,
              set.frames.size(), s.size, s.size, s.primitives);

  const std::size_t before = gpu_memory_in_use();
  std::size_t peak = before;
  Timing gpu_time;
  {
    const std::unique_ptr<train::TrainingStep> step =
        train::make_step(set, config, cuda::Device::kCuda);
    step->initialize(primitives);
    gpu_time = time_steps(*step, 5, s.gpu_steps, &peak);
  }
  // The GPU's figures first: the CPU steps that follow take minutes at this scale.
  const double peak_gb = double(peak - before) / 1e9;
  std::printf(
      "headline: train step %zu prims %dx%d: gpu %.1f ms/step (mean active %.0f), peak %.2f GB\n",
      s.primitives, s.size, s.size, gpu_time.ms_per_step, gpu_time.active, peak_gb);
  print_stages("gpu", gpu_time, s.gpu_steps);
  std::fflush(stdout);
  time_flow_uploads(set);
  time_reshapes(set, config, primitives);
  if (s.cpu_steps <= 0) return 0;
  std::unique_ptr<train::TrainingStep> cpu = train::make_step(set, config, cuda::Device::kCpu);
  cpu->initialize(primitives);
  const Timing cpu_time = time_steps(*cpu, 1, s.cpu_steps, nullptr);

  print_stages("cpu", cpu_time, s.cpu_steps);
  std::printf("headline: cpu (%d threads) %.0f ms/step over %d steps: gpu %.1fx faster\n",
              omp_get_max_threads(), cpu_time.ms_per_step, s.cpu_steps,
              cpu_time.ms_per_step / gpu_time.ms_per_step);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string flag = argv[a];
    const long value = std::strtol(argv[a + 1], nullptr, 10);
    if (flag == "--primitives")
      s.primitives = std::size_t(value);
    else if (flag == "--size")
      s.size = int(value);
    else if (flag == "--gpu-steps")
      s.gpu_steps = int(value);
    else if (flag == "--cpu-steps")
      s.cpu_steps = int(value);
    else {
      std::fprintf(stderr, "cuda_train_bench: unknown option %s\n", flag.c_str());
      return 2;
    }
  }
  try {
    return run(s);
  } catch (const std::exception& e) {
    std::printf("cuda_train_bench: %s\n", e.what());
    return 1;
  }
}
