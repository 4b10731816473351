// Rasteriser throughput on data/bench-scenes (see bench/README.md): forward, backward and both,
// for scene a (256x256, 50k Gaussians) and scene b (960x540, 300k), at 1 and 2 threads.
//
// Counters: blended = Gaussian-pixel pairs composited (sum of n_contrib; the backward revisits
// exactly these), G_blended/s/core = blended / wall time / threads. BM_Stage times one stage
// (stage 0 project, 1 bin, 2 blend, 3 blend backward, 4 project backward).
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "retimegs/core/memory.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/data/npy.hpp"
#include "retimegs/render/rasterize.hpp"

namespace {

namespace fs = std::filesystem;
using namespace retimegs;

struct BenchScene {
  Gaussians gaussians;
  Camera camera;
  std::vector<float> background;  // [3]
  std::vector<float> v_image;     // [H, W, 3] a fixed random upstream gradient
};

const BenchScene& load_scene(char name) {
  static std::map<char, BenchScene> cache;
  if (auto it = cache.find(name); it != cache.end()) return it->second;
  const fs::path dir =
      fs::path(RETIMEGS_SHARED_DATA) / "bench-scenes" / (std::string("scene_") + name);
  BenchScene s;
  const auto floats = [&](const char* file) { return data::read_npy(dir / file).to_float(); };
  s.gaussians.channels = 3;
  s.gaussians.means = floats("means.npy");
  s.gaussians.log_scales = floats("log_scales.npy");
  s.gaussians.quats = floats("quats_wxyz.npy");
  s.gaussians.features = floats("rgb.npy");
  s.gaussians.opacities = floats("opacity_logit.npy");
  for (float& o : s.gaussians.opacities) o = 1.0f / (1.0f + std::exp(-o));
  std::ifstream in(dir / "camera.json");
  const auto json = nlohmann::json::parse(in);
  s.camera.name = std::string("scene_") + name;
  s.camera.width = json.at("width");
  s.camera.height = json.at("height");
  s.camera.fx = json.at("fx");
  s.camera.fy = json.at("fy");
  s.camera.cx = json.at("cx");
  s.camera.cy = json.at("cy");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) s.camera.world_to_camera(r, c) = json.at("world_to_camera")[r][c];
  s.background = json.at("background").get<std::vector<float>>();
  std::mt19937 rng(7);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  s.v_image.resize(std::size_t(s.camera.width) * s.camera.height * 3);
  for (float& v : s.v_image) v = normal(rng);
  return cache.emplace(name, std::move(s)).first->second;
}

double blended_pairs(const render::RenderOutput& out) {
  double sum = 0;
  for (const std::int32_t n : out.blend.n_contrib) sum += n;
  return sum;
}

void set_counters(benchmark::State& state, double pairs, int threads) {
  state.counters["blended"] = pairs;
  state.counters["G_blended/s/core"] =
      benchmark::Counter(pairs * 1e-9 / threads, benchmark::Counter::kIsIterationInvariantRate);
}

char scene_of(const benchmark::State& state) {
  return char('a' + state.range(0));
}

void BM_Forward(benchmark::State& state) {
  const BenchScene& s = load_scene(scene_of(state));
  const int threads = int(state.range(1));
  set_threads(threads);
  double pairs = 0;
  for (auto _ : state) {
    const auto out = render::rasterize_forward(s.gaussians, s.camera, s.background.data());
    pairs = blended_pairs(out);
    benchmark::DoNotOptimize(out.blend.image.data.data());
  }
  set_counters(state, pairs, threads);
}

void BM_Backward(benchmark::State& state) {
  const BenchScene& s = load_scene(scene_of(state));
  const int threads = int(state.range(1));
  set_threads(threads);
  const render::RenderOptions options;
  const auto out = render::rasterize_forward(s.gaussians, s.camera, s.background.data(), options);
  for (auto _ : state) {
    const auto grads = render::rasterize_backward(s.gaussians, s.camera, s.background.data(),
                                                  options, out, s.v_image.data());
    benchmark::DoNotOptimize(grads.v_means.data());
  }
  set_counters(state, blended_pairs(out), threads);
}

void BM_ForwardBackward(benchmark::State& state) {
  const BenchScene& s = load_scene(scene_of(state));
  const int threads = int(state.range(1));
  set_threads(threads);
  const render::RenderOptions options;
  for (auto _ : state) {
    const auto out = render::rasterize_forward(s.gaussians, s.camera, s.background.data(), options);
    const auto grads = render::rasterize_backward(s.gaussians, s.camera, s.background.data(),
                                                  options, out, s.v_image.data());
    benchmark::DoNotOptimize(grads.v_means.data());
  }
}

// One stage at a time (inputs prepared outside the timed loop), to see where the time goes.
enum Stage { kProject, kBin, kBlend, kBlendBackward, kProjectBackward };

void BM_Stage(benchmark::State& state) {
  const BenchScene& s = load_scene(scene_of(state));
  const int threads = int(state.range(1));
  const auto stage = Stage(state.range(2));
  set_threads(threads);
  const render::RenderOptions options;
  const render::PinholeT<float> camera(s.camera);
  const auto out = render::rasterize_forward(s.gaussians, s.camera, s.background.data(), options);
  render::BlendInputs in;
  in.projected = &out.projected;
  in.opacities = s.gaussians.opacities.data();
  in.features = s.gaussians.features.data();
  in.channels = 3;
  in.background = s.background.data();
  in.width = s.camera.width;
  in.height = s.camera.height;
  GaussianGrads grads;
  render::blend_backward(in, out.bins, options, out.blend, s.v_image.data(), nullptr, nullptr,
                         grads);
  for (auto _ : state) {
    switch (stage) {
      case kProject:
        benchmark::DoNotOptimize(render::project_forward(s.gaussians, camera, options));
        break;
      case kBin:
        benchmark::DoNotOptimize(render::bin_tiles(out.projected, s.gaussians.opacities.data(),
                                                   s.camera.width, s.camera.height, options));
        break;
      case kBlend:
        benchmark::DoNotOptimize(render::blend_forward(in, out.bins, options));
        break;
      case kBlendBackward:
        render::blend_backward(in, out.bins, options, out.blend, s.v_image.data(), nullptr, nullptr,
                               grads);
        break;
      case kProjectBackward:
        render::project_backward(s.gaussians, camera, out.projected, options, grads);
        break;
    }
  }
}

void scenes_and_threads(benchmark::internal::Benchmark* b) {
  b->ArgNames({"scene", "threads"});
  for (int scene : {0, 1})
    for (int threads : {1, 2}) b->Args({scene, threads});
  b->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
}

BENCHMARK(BM_Forward)->Apply(scenes_and_threads);
BENCHMARK(BM_Backward)->Apply(scenes_and_threads);
BENCHMARK(BM_ForwardBackward)->Apply(scenes_and_threads);
BENCHMARK(BM_Stage)
    ->ArgNames({"scene", "threads", "stage"})
    ->ArgsProduct({{0, 1}, {1, 2}, {kProject, kBin, kBlend, kBlendBackward, kProjectBackward}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

}  // namespace

// As the retimegs program does: freed blocks stay in the heap between iterations.
int main(int argc, char** argv) {
  retimegs::keep_freed_memory();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
