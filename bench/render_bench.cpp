// Rasteriser throughput on data/bench-scenes (see bench/README.md): forward, backward and both,
// for scene a (256x256, 50k Gaussians) and scene b (960x540, 300k), at 1 and 2 threads.
//
// Counters: blended = Gaussian-pixel pairs composited (sum of n_contrib; the backward revisits
// exactly these), peer_evaluated = the pairs OpenSplat's CPU forward evaluates on the scene (the
// data README's work count, recounted below); G_.../s/core = count / wall time / threads. BM_Stage
// times one stage (stage 0 project, 1 bin, 2 blend, 3 blend backward, 4 project backward).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "bench_main.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/render/rasterize.hpp"

namespace {

namespace fs = std::filesystem;
using namespace retimegs;

// The peer's forward work on a scene (data/bench-scenes/README.md, "Work counts"): OpenSplat's CPU
// rasteriser takes the Gaussians in depth order and visits every pixel of a box of 3 standard
// deviations + 2 px around each centre that is not yet done; a pixel is done when a Gaussian
// would take its transmittance to <= 1e-4 (alpha clamped to 0.999). The count is of the visits
// to pixels not yet done (9.41 M on scene a, 73.0 M on b, as the README says): the forward work of
// a renderer without tiles or footprints, a property of the scene, not of this renderer. Recounted
// here from our projection (pixel centres at +0.5) so that the figure can be checked against the
// README's.
double peer_evaluated(const render::Projected& p, const std::vector<float>& opacities, int width,
                      int height) {
  std::vector<std::int32_t> order;
  for (std::size_t g = 0; g < p.size(); ++g)
    if (p.radii[g] > 0) order.push_back(std::int32_t(g));
  std::stable_sort(order.begin(), order.end(),
                   [&](std::int32_t x, std::int32_t y) { return p.depths[x] < p.depths[y]; });
  std::vector<float> transmittance(std::size_t(width) * height, 1.0f);
  std::vector<char> done(transmittance.size(), 0);
  double sliced = 0;
  for (const std::int32_t g : order) {
    const float a = p.conics[3 * g], b = p.conics[3 * g + 1], c = p.conics[3 * g + 2];
    const float det = a * c - b * b;  // the covariance is the conic's inverse
    const float u = p.means2d[2 * g], v = p.means2d[2 * g + 1];
    const float half_x = 3.0f * std::sqrt(c / det), half_y = 3.0f * std::sqrt(a / det);
    const int x0 = std::max(0, int(std::floor(u - half_x)) - 2);
    const int x1 = std::min(width, int(std::ceil(u + half_x)) + 2);
    const int y0 = std::max(0, int(std::floor(v - half_y)) - 2);
    const int y1 = std::min(height, int(std::ceil(v + half_y)) + 2);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const std::size_t pixel = std::size_t(y) * width + x;
        if (done[pixel]) continue;
        sliced += 1;
        const float dx = u - (float(x) + 0.5f), dy = v - (float(y) + 0.5f);
        const float sigma = 0.5f * (a * dx * dx + c * dy * dy) + b * dx * dy;
        const float alpha = std::min(0.999f, opacities[g] * std::exp(-sigma));
        if (sigma < 0 || alpha < 1.0f / 255.0f) continue;
        const float next_t = transmittance[pixel] * (1.0f - alpha);
        if (next_t <= 1e-4f) {
          done[pixel] = 1;
          continue;
        }
        transmittance[pixel] = next_t;
      }
  }
  return sliced;
}

struct BenchScene {
  Gaussians gaussians;
  Camera camera;
  std::vector<float> background;  // [3]
  std::vector<float> v_image;     // [H, W, 3] a fixed random upstream gradient
  double peer_evaluated = 0;      // the peer's forward work on this scene (pairs)
};

const BenchScene& load_scene(char name) {
  static std::map<char, BenchScene> cache;
  if (auto it = cache.find(name); it != cache.end()) return it->second;
  const fs::path dir =
      fs::path(RETIMEGS_SHARED_DATA) / "bench-scenes" / (std::string("scene_") + name);
  BenchScene s;
  const auto floats = [&](const char* file) { return io::read_npy(dir / file).to_float(); };
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
  s.peer_evaluated =
      peer_evaluated(render::project_forward(s.gaussians, render::PinholeT<float>(s.camera), {}),
                     s.gaussians.opacities, s.camera.width, s.camera.height);
  return cache.emplace(name, std::move(s)).first->second;
}

double blended_pairs(const render::RenderOutput& out) {
  double sum = 0;
  for (const std::int32_t n : out.blend.n_contrib) sum += n;
  return sum;
}

// blended: pairs composited by this renderer; sliced: the peer's forward work on the scene.
void set_counters(benchmark::State& state, const BenchScene& s, double pairs, int threads) {
  const auto per_core_rate = [&](double count) {
    return benchmark::Counter(count * 1e-9 / threads,
                              benchmark::Counter::kIsIterationInvariantRate);
  };
  state.counters["blended"] = pairs;
  state.counters["G_blended/s/core"] = per_core_rate(pairs);
  state.counters["peer_evaluated"] = s.peer_evaluated;
  state.counters["G_peer_evaluated/s/core"] = per_core_rate(s.peer_evaluated);
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
  set_counters(state, s, pairs, threads);
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
  set_counters(state, s, blended_pairs(out), threads);
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
  // The work of the stages: visible Gaussians (radius > 0) and their tile intersections.
  state.counters["visible"] =
      double(std::count_if(out.projected.radii.begin(), out.projected.radii.end(),
                           [](std::int32_t r) { return r > 0; }));
  state.counters["intersections"] = double(out.bins.num_intersections());
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

RETIMEGS_BENCHMARK_MAIN()
