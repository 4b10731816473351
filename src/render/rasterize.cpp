// The rasteriser pipeline: validation, then project -> bin_tiles -> blend, and back.
#include "retimegs/render/rasterize.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>

#include "retimegs/core/error.hpp"

namespace retimegs::render {
namespace {

template <typename T>
void check_size(const std::vector<T>& v, std::size_t expected, const char* field,
                const char* shape) {
  if (v.size() != expected)
    fail("gaussians.{}: has {} values, expected {} ({})", field, v.size(), expected, shape);
}

constexpr std::size_t kParallelValues = 1 << 16;  // below: one thread (fork/join would dominate)

// Whether every value is finite (exponent bits not all ones), as an or-reduction over the bits
// that the compiler vectorises, split over the threads (tens of megabytes per training step); the
// caller then looks for the first bad value only on failure.
template <typename T>
bool all_finite(const std::vector<T>& v) {
  using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  constexpr Bits kExponent = sizeof(T) == 4 ? Bits(0x7f800000u) : Bits(0x7ff0000000000000ull);
  Bits bad = 0;
#pragma omp parallel for simd schedule(static) reduction(| : bad) if (v.size() >= kParallelValues)
  for (std::size_t k = 0; k < v.size(); ++k)
    bad |= Bits((std::bit_cast<Bits>(v[k]) & kExponent) == kExponent);
  return bad == 0;
}

template <typename T>
void check_finite(const std::vector<T>& v, int row_size, const char* field) {
  if (all_finite(v)) return;
  for (std::size_t k = 0; k < v.size(); ++k)
    if (!std::isfinite(v[k]))
      fail("gaussians.{}[{}][{}] is {} (must be finite)", field, k / row_size, k % row_size,
           double(v[k]));
}

BlendInputs blend_inputs(const Gaussians& g, const Camera& camera, const Projected& projected,
                         const float* background) {
  BlendInputs in;
  in.projected = &projected;
  in.opacities = g.opacities.data();
  in.features = g.features.data();
  in.channels = g.channels;
  in.background = background;
  in.width = camera.width;
  in.height = camera.height;
  return in;
}

}  // namespace

template <typename T>
void check_gaussians(const GaussiansT<T>& g) {
  const std::size_t n = g.size();
  if (g.channels < 1) fail("gaussians: channel count must be >= 1, got {}", g.channels);
  check_size(g.means, 3 * n, "means", "[N, 3]");
  check_size(g.log_scales, 3 * n, "log_scales", "[N, 3]");
  check_size(g.quats, 4 * n, "quats", "[N, 4]");
  check_size(g.features, n * g.channels, "features", "[N, C]");
  check_finite(g.means, 3, "means");
  check_finite(g.log_scales, 3, "log_scales");
  check_finite(g.quats, 4, "quats");
  check_finite(g.opacities, 1, "opacities");
  check_finite(g.features, g.channels, "features");
  // Opacities in [0, 1] and non-zero quaternions: a vectorisable pass first, the message second.
  bool bad = false;
#pragma omp parallel for schedule(static) reduction(| : bad) if (n >= kParallelValues)
  for (std::size_t i = 0; i < n; ++i) {
    const T* q = &g.quats[4 * i];
    bad |= !(g.opacities[i] >= 0 && g.opacities[i] <= 1) |
           (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] == 0);
  }
  if (!bad) return;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(g.opacities[i] >= 0 && g.opacities[i] <= 1))
      fail("gaussians.opacities[{}] is {} (must be in [0, 1])", i, double(g.opacities[i]));
    const T* q = &g.quats[4 * i];
    if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] == 0)
      fail("gaussians.quats[{}] is zero (cannot be normalised)", i);
  }
}
template void check_gaussians<float>(const GaussiansT<float>&);
template void check_gaussians<double>(const GaussiansT<double>&);

void check_camera(const Camera& camera) {
  const std::string what = "camera '" + camera.name + "'";
  if (camera.width < 1 || camera.height < 1)
    fail("{}: image size {}x{} is empty", what, camera.width, camera.height);
  if (!(std::isfinite(camera.fx) && std::isfinite(camera.fy) && camera.fx > 0 && camera.fy > 0))
    fail("{}: focal lengths fx = {}, fy = {} must be finite and positive", what, camera.fx,
         camera.fy);
  if (!(std::isfinite(camera.cx) && std::isfinite(camera.cy)))
    fail("{}: principal point ({}, {}) must be finite", what, camera.cx, camera.cy);
  check_rigid(camera.world_to_camera, what + " world_to_camera");
}

RenderOutput rasterize_forward(const Gaussians& gaussians, const Camera& camera,
                               const float* background, const RenderOptions& options) {
  check_gaussians(gaussians);
  check_camera(camera);
  if (background)
    for (int c = 0; c < gaussians.channels; ++c)
      if (!std::isfinite(background[c]))
        fail("background[{}] is {} (must be finite)", c, background[c]);
  RenderOutput out;
  out.projected = project_forward(gaussians, PinholeT<float>(camera), options);
  out.bins =
      bin_tiles(out.projected, gaussians.opacities.data(), camera.width, camera.height, options);
  out.blend =
      blend_forward(blend_inputs(gaussians, camera, out.projected, background), out.bins, options);
  return out;
}

GaussianGrads rasterize_backward(const Gaussians& gaussians, const Camera& camera,
                                 const float* background, const RenderOptions& options,
                                 const RenderOutput& forward, const float* v_image,
                                 const float* v_alpha, const float* v_depth) {
  if (forward.projected.size() != gaussians.size() ||
      forward.blend.final_T.size() != std::size_t(camera.width) * camera.height)
    fail("rasterize_backward: the saved forward does not match these Gaussians and camera");
  GaussianGrads grads;  // each stage sizes (and fills) its own fields
  grads.channels = gaussians.channels;
  blend_backward(blend_inputs(gaussians, camera, forward.projected, background), forward.bins,
                 options, forward.blend, v_image, v_alpha, v_depth, grads);
  project_backward(gaussians, PinholeT<float>(camera), forward.projected, options, grads);
  return grads;
}

}  // namespace retimegs::render
