// The CUDA rasteriser's pipeline: project (one thread per Gaussian) -> bin (CUB scan and radix
// sort) -> blend (blend.cu), and back. The per-Gaussian math is render/formulas.hpp's, as in the
// CPU's project_lanes.cpp and bin_tiles.cpp.
#include "retimegs/cuda/rasterize.hpp"

#include <cuda_runtime.h>

#include <bit>
#include <climits>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include "blend.hpp"
#include "launch.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/cuda/check.hpp"
#include "retimegs/render/formulas.hpp"
#include "retimegs/render/project.hpp"

namespace retimegs::cuda {
namespace {

constexpr unsigned kFullWarp = 0xffffffffu;

// summary[]: whether some input failed check_gaussians, and the OR and AND of the depth bits of
// the binned Gaussians (the sort's key bits in which they differ).
enum Summary { kInvalid, kDepthOr, kDepthAnd, kSummaryWords };

struct ProjectParams {
  PinholeT<float> camera;
  render::FovGuardT<float> lim;
  render::RenderOptions options;
  int n, channels, tiles_x, tiles_y;
};

__device__ inline bool finite(float x) {
  return isfinite(x);
}

// One thread per Gaussian: project_gaussian (the CPU's rules), its blend_tile_rect, the blend
// record, and the checks of check_gaussians (flagged; the host names the value).
__global__ void __launch_bounds__(kThreads)
    project_kernel(ProjectParams p, const float* __restrict__ means,
                   const float* __restrict__ log_scales, const float* __restrict__ quats,
                   const float* __restrict__ opacities, const float* __restrict__ features,
                   float* __restrict__ means2d, float* __restrict__ conics,
                   float* __restrict__ depths, std::int32_t* __restrict__ radii,
                   int4* __restrict__ rects, std::int64_t* __restrict__ tile_counts,
                   float* __restrict__ records, std::uint32_t* __restrict__ summary) {
  const std::size_t i = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  const bool active = i < std::size_t(p.n);
  bool invalid = false;
  std::uint32_t depth_bits_or = 0, depth_bits_and = ~0u;
  if (active) {
    const float* mean = &means[3 * i];
    const float* quat = &quats[4 * i];
    const float* log_scale = &log_scales[3 * i];
    const float opacity = opacities[i];
    bool valid = opacity >= 0.0f && opacity <= 1.0f;
    for (int k = 0; k < 3; ++k) valid &= finite(mean[k]) && finite(log_scale[k]);
    for (int k = 0; k < 4; ++k) valid &= finite(quat[k]);
    valid &= quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3] > 0;
    for (int c = 0; c < p.channels; ++c) valid &= finite(features[i * p.channels + c]);
    invalid = !valid;

    const float scale[3] = {render::exp_approx(log_scale[0]), render::exp_approx(log_scale[1]),
                            render::exp_approx(log_scale[2])};
    const render::Splat2dT<float> s =
        render::project_gaussian(mean, quat, scale, opacity, p.camera, p.lim, p.options);
    render::TileRect rect;
    if (s.radius > 0) {
      rect = render::radius_tile_rect(s.mean2d[0], s.mean2d[1], s.radius, p.tiles_x, p.tiles_y);
      // The tight bound where it applies (blend_tile_rect; bin_tiles' lanes take the same rect).
      if (p.options.tight_tile_bounds && p.options.min_alpha > 0) {
        float ext[2];
        render::alpha_extent_of_level(s.conic, logf(opacity / p.options.min_alpha), ext);
        rect = render::cut_tile_rect(rect, s.mean2d, ext);
      }
    }
    const bool visible = s.radius > 0;
    means2d[2 * i] = visible ? s.mean2d[0] : 0.0f;
    means2d[2 * i + 1] = visible ? s.mean2d[1] : 0.0f;
    for (int k = 0; k < 3; ++k) conics[3 * i + k] = visible ? s.conic[k] : 0.0f;
    depths[i] = visible ? s.depth : 0.0f;
    radii[i] = s.radius;
    const int area = rect.area() > 0 ? rect.area() : 0;
    rects[i] = area > 0 ? make_int4(rect.x0, rect.y0, rect.x1, rect.y1) : make_int4(0, 0, 0, 0);
    tile_counts[i] = area;
    if (visible) {
      const render::BlendConicT<float> bc = render::blend_conic(s.conic, opacity);
      float4* r = reinterpret_cast<float4*>(&records[kRecordFloats * i]);
      r[0] = make_float4(s.mean2d[0], s.mean2d[1], bc.half_a, bc.b);
      r[1] = make_float4(bc.half_c, bc.log2_opacity, opacity, s.depth);
    }
    if (area > 0) depth_bits_or = depth_bits_and = __float_as_uint(s.depth);
  }
  if (i == std::size_t(p.n)) tile_counts[i] = 0;  // the scan's last entry is then the total
  // Warp first, then one atomic per warp.
  invalid = __any_sync(kFullWarp, invalid);
  depth_bits_or = __reduce_or_sync(kFullWarp, depth_bits_or);
  depth_bits_and = __reduce_and_sync(kFullWarp, depth_bits_and);
  if (threadIdx.x % 32 == 0) {
    if (invalid) atomicOr(&summary[kInvalid], 1u);
    atomicOr(&summary[kDepthOr], depth_bits_or);
    atomicAnd(&summary[kDepthAnd], depth_bits_and);
  }
}

// Keys of every (tile, Gaussian) intersection: tile << 32 | depth bits (a positive float's bits
// sort as its value), in Gaussian order, each Gaussian's tiles row by row.
__global__ void __launch_bounds__(kThreads)
    emit_kernel(int n, int tiles_x, const int4* __restrict__ rects,
                const std::int64_t* __restrict__ tile_offsets, const float* __restrict__ depths,
                std::uint64_t* __restrict__ keys, std::int32_t* __restrict__ values) {
  const std::size_t i = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (i >= std::size_t(n)) return;
  const int4 r = rects[i];
  if (r.z <= r.x) return;
  const std::uint64_t depth_bits = __float_as_uint(depths[i]);
  std::int64_t k = tile_offsets[i];
  for (int ty = r.y; ty < r.w; ++ty)
    for (int tx = r.x; tx < r.z; ++tx, ++k) {
      keys[k] = std::uint64_t(ty * tiles_x + tx) << 32 | depth_bits;
      values[k] = std::int32_t(i);
    }
}

// isect_offsets[t] = the first sorted intersection of a tile >= t, for t in [0, tiles]: entry
// k in [0, M] fills the tiles after its predecessor's up to its own (M: past the last tile).
__global__ void __launch_bounds__(kThreads)
    tile_ranges_kernel(std::int64_t m, int tiles, const std::uint64_t* __restrict__ keys,
                       std::int32_t* __restrict__ isect_offsets) {
  const std::int64_t k = std::int64_t(blockIdx.x) * kThreads + threadIdx.x;
  if (k > m) return;
  const int tile = k < m ? int(keys[k] >> 32) : tiles;
  const int previous = k > 0 ? int(keys[k - 1] >> 32) : -1;
  for (int t = previous + 1; t <= tile; ++t) isect_offsets[t] = std::int32_t(k);
}

// One thread per Gaussian: render::project_backward's values (zero for culled rows).
__global__ void __launch_bounds__(kThreads)
    project_backward_kernel(ProjectParams p, const float* __restrict__ means,
                            const float* __restrict__ log_scales, const float* __restrict__ quats,
                            const float* __restrict__ conics,
                            const std::int32_t* __restrict__ radii,
                            const float* __restrict__ v_means2d, const float* __restrict__ v_conics,
                            const float* __restrict__ v_depths, float* __restrict__ v_means,
                            float* __restrict__ v_log_scales, float* __restrict__ v_quats) {
  const std::size_t i = std::size_t(blockIdx.x) * kThreads + threadIdx.x;
  if (i >= std::size_t(p.n)) return;
  float v_mean[3] = {}, v_log_scale[3] = {}, v_quat[4] = {};
  if (radii[i] > 0) {
    const float* log_scale = &log_scales[3 * i];
    const float scale[3] = {render::exp_approx(log_scale[0]), render::exp_approx(log_scale[1]),
                            render::exp_approx(log_scale[2])};
    const render::ProjectionGeometryT<float> geo = render::projection_geometry(
        &means[3 * i], &quats[4 * i], scale, p.camera, p.lim, p.options.low_pass);
    render::projection_vjp(geo, p.camera, p.options.centre_depth_offset, &conics[3 * i],
                           &v_conics[3 * i], &v_means2d[2 * i], v_depths[i], v_mean, v_log_scale,
                           v_quat);
  }
  for (int k = 0; k < 3; ++k) v_means[3 * i + k] = v_mean[k];
  for (int k = 0; k < 3; ++k) v_log_scales[3 * i + k] = v_log_scale[k];
  for (int k = 0; k < 4; ++k) v_quats[4 * i + k] = v_quat[k];
}

ProjectParams project_params(const DeviceGaussians& g, const Camera& camera,
                             const render::RenderOptions& options) {
  const PinholeT<float> pinhole(camera);
  return {pinhole,
          render::FovGuardT<float>(pinhole),
          options,
          int(g.size()),
          g.channels,
          render::tile_count(camera.width),
          render::tile_count(camera.height)};
}

template <typename T>
T read_one(const T* device) {
  T host;
  check(cudaMemcpy(&host, device, sizeof(T), cudaMemcpyDeviceToHost), "reading a count back");
  return host;
}

}  // namespace

void DeviceGaussians::upload(const Gaussians& g) {
  render::check_gaussians(g);
  channels = g.channels;
  means.upload(g.means);
  log_scales.upload(g.log_scales);
  quats.upload(g.quats);
  opacities.upload(g.opacities);
  features.upload(g.features);
}

Gaussians DeviceGaussians::download() const {
  Gaussians g(size(), channels);
  means.download(g.means.data());
  log_scales.download(g.log_scales.data());
  quats.download(g.quats.data());
  opacities.download(g.opacities.data());
  features.download(g.features.data());
  return g;
}

GaussianGrads DeviceGaussianGrads::download() const {
  GaussianGrads g;
  g.channels = channels;
  const auto copy = [](const DeviceBuffer<float>& from, UninitVector<float>& to) {
    to.resize(from.size());
    from.download(to.data());
  };
  copy(v_means, g.v_means);
  copy(v_log_scales, g.v_log_scales);
  copy(v_quats, g.v_quats);
  copy(v_opacities, g.v_opacities);
  copy(v_features, g.v_features);
  copy(v_means2d, g.v_means2d);
  copy(v_conics, g.v_conics);
  copy(v_depths, g.v_depths);
  return g;
}

void rasterize_forward(const DeviceGaussians& g, const Camera& camera, const float* background,
                       const render::RenderOptions& options, DeviceRenderOutput& out) {
  render::check_camera(camera);
  render::check_background(background, g.channels);
  const BlendParams blend =
      blend_params(options, camera.width, camera.height, g.channels, background);
  const ProjectParams p = project_params(g, camera, options);
  const std::size_t n = g.size();
  DeviceRenderScratch& s = out.scratch;

  // Stage 1.
  out.projected.means2d.resize(2 * n);
  out.projected.conics.resize(3 * n);
  out.projected.depths.resize(n);
  out.projected.radii.resize(n);
  s.rects.resize(4 * n);
  s.tile_counts.resize(n + 1);
  s.tile_offsets.resize(n + 1);
  s.records.resize(kRecordFloats * n);
  s.summary.resize(kSummaryWords);
  check(cudaMemset(s.summary.data(), 0, kDepthAnd * sizeof(std::uint32_t)), "cudaMemset");
  check(cudaMemset(s.summary.data() + kDepthAnd, 0xff, sizeof(std::uint32_t)), "cudaMemset");
  project_kernel<<<blocks_for(n + 1), kThreads>>>(
      p, g.means.data(), g.log_scales.data(), g.quats.data(), g.opacities.data(), g.features.data(),
      out.projected.means2d.data(), out.projected.conics.data(), out.projected.depths.data(),
      out.projected.radii.data(), reinterpret_cast<int4*>(s.rects.data()), s.tile_counts.data(),
      s.records.data(), s.summary.data());
  check(cudaGetLastError(), "project launch");

  // Stage 2: offsets of each Gaussian's intersections, then the one read back of the forward.
  with_cub_storage(s.cub_storage, "cub::DeviceScan::ExclusiveSum",
                   [&](void* storage, std::size_t& bytes) {
                     return cub::DeviceScan::ExclusiveSum(storage, bytes, s.tile_counts.data(),
                                                          s.tile_offsets.data(), int(n + 1));
                   });
  const std::int64_t m = read_one(s.tile_offsets.data() + n);
  std::uint32_t summary[kSummaryWords];
  s.summary.download(summary);
  if (summary[kInvalid]) render::check_gaussians(g.download());  // throws, naming the value
  if (m > INT32_MAX) fail("bin_tiles: more than 2^31 tile intersections");
  DeviceTileBins& bins = out.bins;
  bins.tiles_x = p.tiles_x;
  bins.tiles_y = p.tiles_y;
  bins.intersections = m;
  const int tiles = p.tiles_x * p.tiles_y;
  bins.isect_offsets.resize(tiles + 1);
  bins.gaussian_from_isect.resize(m);
  s.keys.resize(m);
  s.keys_alt.resize(m);
  s.values_alt.resize(m);
  if (n > 0) {
    emit_kernel<<<blocks_for(n), kThreads>>>(
        int(n), p.tiles_x, reinterpret_cast<const int4*>(s.rects.data()), s.tile_offsets.data(),
        out.projected.depths.data(), s.keys.data(), bins.gaussian_from_isect.data());
    check(cudaGetLastError(), "emit launch");
  }
  // Radix digits over only the bits in which keys differ: the depth bits from the lowest that
  // varies (the Gaussians' depths share the others), and the tile bits that tile ids use. A
  // stable sort: equal depths keep Gaussian order, as the CPU's.
  const std::uint32_t varying = summary[kDepthOr] & ~summary[kDepthAnd];
  const int begin_bit = varying ? std::countr_zero(varying) : 32;
  const int end_bit = 32 + std::bit_width(unsigned(tiles - 1));
  cub::DoubleBuffer<std::uint64_t> keys(s.keys.data(), s.keys_alt.data());
  cub::DoubleBuffer<std::int32_t> values(bins.gaussian_from_isect.data(), s.values_alt.data());
  if (m > 1 && begin_bit < end_bit) {
    with_cub_storage(s.cub_storage, "cub::DeviceRadixSort::SortPairs",
                     [&](void* storage, std::size_t& bytes) {
                       return cub::DeviceRadixSort::SortPairs(storage, bytes, keys, values, int(m),
                                                              begin_bit, end_bit);
                     });
  }
  if (values.Current() != bins.gaussian_from_isect.data())
    bins.gaussian_from_isect.swap(s.values_alt);
  tile_ranges_kernel<<<blocks_for(std::size_t(m) + 1), kThreads>>>(m, tiles, keys.Current(),
                                                                   bins.isect_offsets.data());
  check(cudaGetLastError(), "tile_ranges launch");

  // Stage 3.
  blend_forward(blend, bins, s.records.data(), g.features.data(), out.blend);
}

void rasterize_backward(const DeviceGaussians& g, const Camera& camera, const float* background,
                        const render::RenderOptions& options, DeviceRenderOutput& forward,
                        const float* v_image, const float* v_alpha, const float* v_depth,
                        DeviceGaussianGrads& grads) {
  const std::size_t n = g.size();
  if (!v_image) fail("rasterize_backward: v_image is required");
  if (v_depth && !options.render_depth)
    fail("blend_backward: v_depth given but the forward did not render depth");
  if (forward.projected.radii.size() != n ||
      forward.blend.final_T.size() != std::size_t(camera.width) * camera.height)
    fail("rasterize_backward: the saved forward does not match these Gaussians and camera");
  const BlendParams blend =
      blend_params(options, camera.width, camera.height, g.channels, background);
  const ProjectParams p = project_params(g, camera, options);
  grads.channels = g.channels;
  grads.v_means.resize(3 * n);
  grads.v_log_scales.resize(3 * n);
  grads.v_quats.resize(4 * n);
  // The blend adds into these.
  grads.v_means2d.resize(2 * n);
  grads.v_conics.resize(3 * n);
  grads.v_opacities.resize(n);
  grads.v_features.resize(n * g.channels);
  grads.v_depths.resize(n);
  for (DeviceBuffer<float>* b :
       {&grads.v_means2d, &grads.v_conics, &grads.v_opacities, &grads.v_features, &grads.v_depths})
    b->fill_bytes(0);
  blend_backward(blend, forward.bins, forward.scratch.records.data(), g.features.data(),
                 forward.blend, v_image, v_alpha, v_depth, grads);
  if (n > 0) {
    project_backward_kernel<<<blocks_for(n), kThreads>>>(
        p, g.means.data(), g.log_scales.data(), g.quats.data(), forward.projected.conics.data(),
        forward.projected.radii.data(), grads.v_means2d.data(), grads.v_conics.data(),
        grads.v_depths.data(), grads.v_means.data(), grads.v_log_scales.data(),
        grads.v_quats.data());
    check(cudaGetLastError(), "project_backward launch");
  }
}

void download(const DeviceRenderOutput& device, render::RenderOutput& host) {
  const auto copy = [](const auto& from, auto& to) {
    to.resize(from.size());
    from.download(to.data());
  };
  copy(device.projected.means2d, host.projected.means2d);
  copy(device.projected.conics, host.projected.conics);
  copy(device.projected.depths, host.projected.depths);
  copy(device.projected.radii, host.projected.radii);
  host.bins.tiles_x = device.bins.tiles_x;
  host.bins.tiles_y = device.bins.tiles_y;
  copy(device.bins.isect_offsets, host.bins.isect_offsets);
  copy(device.bins.gaussian_from_isect, host.bins.gaussian_from_isect);
  const DeviceBlendOutput& b = device.blend;
  host.blend.image.width = b.width;
  host.blend.image.height = b.height;
  host.blend.image.channels = b.channels;
  copy(b.image, host.blend.image.data);
  copy(b.alpha, host.blend.alpha);
  copy(b.depth, host.blend.depth);
  copy(b.final_T, host.blend.final_T);
  copy(b.last_contributor, host.blend.last_contributor);
  copy(b.n_contrib, host.blend.n_contrib);
  host.blend.footprint_blocks.clear();
  host.blend.records.clear();
}

}  // namespace retimegs::cuda
