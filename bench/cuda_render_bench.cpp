// Rasteriser throughput on the GPU beside the CPU renderer on all cores, on the same scenes:
// composited Gaussian-pixel pairs per second (the sum of n_contrib, as render_bench.cpp counts
// them; the backward revisits exactly these), forward and backward. The median of several timed
// runs after a warm-up; GPU times by CUDA events around the device work alone (the scene is
// resident), CPU times by the wall clock. Scenes: the paper's scale (1 M Gaussians, 1024x1024,
// C = 7: RGB + 4 flow channels, as training renders) and a smaller one (100 k, 512x512, C = 3).
//
//   build/bench/cuda_render_bench            (lines "headline: ..." feed scripts/gpu_check.sh)
#include <cuda_runtime_api.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <omp.h>

#include "retimegs/cuda/check.hpp"
#include "retimegs/cuda/device.hpp"
#include "retimegs/cuda/rasterize.hpp"
#include "retimegs/render/rasterize.hpp"

namespace {

using namespace retimegs;

struct Scene {
  const char* name;
  int n, width, height, channels;
  int gpu_runs, cpu_runs;
};

// n Gaussians in front of a camera at the origin, spread over the image (and 10 % beyond), at
// depths 2 to 8, footprints of 0.5 to 3 pixels sigma, random rotations, opacities 0.05 to 0.95:
// at 1 M on 1024x1024, tens of Gaussians per pixel, as a trained scene at the paper's budget.
Gaussians scene_gaussians(const Camera& camera, const Scene& s) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  Gaussians g(std::size_t(s.n), s.channels);
  for (int i = 0; i < s.n; ++i) {
    const float z = 2.0f + 6.0f * u01(rng);
    const float u = (-0.1f + 1.2f * u01(rng)) * float(camera.width);
    const float v = (-0.1f + 1.2f * u01(rng)) * float(camera.height);
    g.means[3 * i] = (u - float(camera.cx)) / float(camera.fx) * z;
    g.means[3 * i + 1] = (v - float(camera.cy)) / float(camera.fy) * z;
    g.means[3 * i + 2] = z;
    for (int k = 0; k < 3; ++k)
      g.log_scales[3 * i + k] = std::log((0.5f + 2.5f * u01(rng)) * z / float(camera.fx));
    for (int k = 0; k < 4; ++k) g.quats[4 * i + k] = normal(rng);
    g.opacities[i] = 0.05f + 0.9f * u01(rng);
    for (int c = 0; c < s.channels; ++c) g.features[std::size_t(i) * s.channels + c] = u01(rng);
  }
  return g;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Seconds of f() on the GPU: the median over `runs` after one warm-up.
template <typename F>
double gpu_seconds(int runs, F&& f) {
  cudaEvent_t start, stop;
  cuda::check(cudaEventCreate(&start), "cudaEventCreate");
  cuda::check(cudaEventCreate(&stop), "cudaEventCreate");
  f();
  std::vector<double> times;
  for (int r = 0; r < runs; ++r) {
    cuda::check(cudaEventRecord(start), "cudaEventRecord");
    f();
    cuda::check(cudaEventRecord(stop), "cudaEventRecord");
    cuda::check(cudaEventSynchronize(stop), "cudaEventSynchronize");
    float ms = 0;
    cuda::check(cudaEventElapsedTime(&ms, start, stop), "cudaEventElapsedTime");
    times.push_back(ms * 1e-3);
  }
  cudaEventDestroy(start);
  cudaEventDestroy(stop);
  return median(times);
}

template <typename F>
double cpu_seconds(int runs, F&& f) {
  f();
  std::vector<double> times;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return median(times);
}

void run(const Scene& s) {
  Camera camera;
  camera.name = s.name;
  camera.width = s.width;
  camera.height = s.height;
  camera.fx = camera.fy = 0.9 * s.width;
  camera.cx = 0.5 * s.width;
  camera.cy = 0.5 * s.height;
  const Gaussians g = scene_gaussians(camera, s);
  const std::vector<float> background(s.channels, 0.25f);
  const render::RenderOptions options;
  const std::size_t pixels = std::size_t(s.width) * s.height;
  std::vector<float> v_image(pixels * s.channels);
  std::mt19937 rng(2);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  for (float& v : v_image) v = normal(rng);

  // GPU: the scene and the upstream gradient resident, outputs reused across runs.
  cuda::DeviceGaussians dg;
  dg.upload(g);
  cuda::DeviceBuffer<float> dv_image;
  dv_image.upload(v_image);
  cuda::DeviceRenderOutput out;
  cuda::DeviceGaussianGrads grads;
  const double gpu_forward = gpu_seconds(
      s.gpu_runs, [&] { cuda::rasterize_forward(dg, camera, background.data(), options, out); });
  const double gpu_backward = gpu_seconds(s.gpu_runs, [&] {
    cuda::rasterize_backward(dg, camera, background.data(), options, out, dv_image.data(), nullptr,
                             nullptr, grads);
  });
  render::RenderOutput gpu_host;
  cuda::download(out, gpu_host);

  // CPU, all cores.
  render::RenderOutput cpu_out;
  GaussianGrads cpu_grads;
  const double cpu_forward = cpu_seconds(s.cpu_runs, [&] {
    render::rasterize_forward(g, camera, background.data(), options, cpu_out);
  });
  const double cpu_backward = cpu_seconds(s.cpu_runs, [&] {
    render::rasterize_backward(g, camera, background.data(), options, cpu_out, v_image.data(),
                               cpu_grads);
  });

  double pairs = 0, gpu_pairs = 0;
  for (const std::int32_t c : cpu_out.blend.n_contrib) pairs += c;
  for (const std::int32_t c : gpu_host.blend.n_contrib) gpu_pairs += c;
  const auto rate = [&](double seconds) { return pairs / seconds * 1e-9; };
  std::printf(
      "%s: %d Gaussians, %dx%d, C = %d, %.1f M composited pairs (GPU %.1f M), %zu tile "
      "intersections\n",
      s.name, s.n, s.width, s.height, s.channels, pairs * 1e-6, gpu_pairs * 1e-6,
      std::size_t(out.bins.intersections));
  std::printf("  GPU forward  %8.3f ms  %7.2f G pairs/s   (median of %d)\n", gpu_forward * 1e3,
              rate(gpu_forward), s.gpu_runs);
  std::printf("  GPU backward %8.3f ms  %7.2f G pairs/s\n", gpu_backward * 1e3, rate(gpu_backward));
  std::printf("  CPU forward  %8.1f ms  %7.3f G pairs/s   (%d threads, median of %d)\n",
              cpu_forward * 1e3, rate(cpu_forward), omp_get_max_threads(), s.cpu_runs);
  std::printf("  CPU backward %8.1f ms  %7.3f G pairs/s\n", cpu_backward * 1e3, rate(cpu_backward));
  std::printf("headline: %s forward GPU %.2f G pairs/s (%.2f ms), CPU %.3f (%.0f ms): %.0fx\n",
              s.name, rate(gpu_forward), gpu_forward * 1e3, rate(cpu_forward), cpu_forward * 1e3,
              cpu_forward / gpu_forward);
  std::printf("headline: %s backward GPU %.2f G pairs/s (%.2f ms), CPU %.3f (%.0f ms): %.0fx\n",
              s.name, rate(gpu_backward), gpu_backward * 1e3, rate(cpu_backward),
              cpu_backward * 1e3, cpu_backward / gpu_backward);
  std::fflush(stdout);
}

}  // namespace

int main() {
  const cuda::DeviceQuery query = cuda::query_device();
  if (!query.usable()) {
    std::printf("cuda_render_bench: no GPU (%s)\n", query.reason.c_str());
    return 0;
  }
  std::printf("card: %s, CPU renderer on %d threads\n", query.device->name.c_str(),
              omp_get_max_threads());
  try {
    run({"small 100k 512x512 C=3", 100000, 512, 512, 3, 20, 5});
    run({"paper 1M 1024x1024 C=7", 1000000, 1024, 1024, 7, 10, 3});
  } catch (const std::exception& e) {
    std::printf("cuda_render_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
