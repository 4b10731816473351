#pragma once
// Scenes for the render tests: the gsplat reference cases and seeded random scenes.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/gaussians.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/render/options.hpp"
#include "test_util.hpp"

namespace retimegs::test {

inline std::vector<float> npy_floats(const std::filesystem::path& path) {
  return io::read_npy(path).to_float();
}
inline std::vector<std::int32_t> npy_ints(const std::filesystem::path& path) {
  return io::read_npy(path).to_int();
}

// One case of data/gsplat-reference: inputs and camera.
struct GsplatCase {
  std::filesystem::path dir;
  Gaussians gaussians;
  Camera camera;
  std::vector<float> background;  // [3]
};

inline const char* kGsplatCases[] = {"case1_n500_128x96", "case2_n2000_160x120",
                                     "case3_n5000_160x120"};

inline GsplatCase load_gsplat_case(const std::string& name) {
  GsplatCase k;
  k.dir = shared_data() / "gsplat-reference" / name;
  const auto scales = npy_floats(k.dir / "scales.npy");
  k.gaussians.channels = 3;
  k.gaussians.means = npy_floats(k.dir / "means.npy");
  k.gaussians.log_scales.resize(scales.size());
  std::transform(scales.begin(), scales.end(), k.gaussians.log_scales.begin(),
                 [](float s) { return std::log(s); });
  k.gaussians.quats = npy_floats(k.dir / "quats.npy");
  k.gaussians.opacities = npy_floats(k.dir / "opacities.npy");
  k.gaussians.features = npy_floats(k.dir / "colors.npy");
  const auto viewmat = npy_floats(k.dir / "viewmat.npy");
  const auto intrinsics = npy_floats(k.dir / "intrinsics.npy");
  const auto size = npy_ints(k.dir / "image_size.npy");
  k.camera.name = name;
  k.camera.width = size[0];
  k.camera.height = size[1];
  k.camera.fx = intrinsics[0];
  k.camera.fy = intrinsics[1];
  k.camera.cx = intrinsics[2];
  k.camera.cy = intrinsics[3];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) k.camera.world_to_camera(r, c) = viewmat[4 * r + c];
  k.background = npy_floats(k.dir / "background.npy");
  return k;
}

// Render options under which the loss is smooth in every input, for finite differences: no alpha
// cut-off, no early termination; the depth pass on.
inline render::RenderOptions smooth_options() {
  render::RenderOptions o;
  o.min_alpha = 0;
  o.min_transmittance = 0;
  o.render_depth = true;
  return o;
}

// A camera at the origin looking down +z (OpenCV), focal 0.9 * width.
inline Camera test_camera(int width, int height) {
  Camera c;
  c.name = "test";
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.9 * width;
  c.cx = 0.5 * width + 0.25;
  c.cy = 0.5 * height - 0.125;
  return c;
}

// n Gaussians in front of `camera` at depths [2, 5], their centres spread over the image plus a
// 20 % border (some straddle the edges), footprints of about 0.5 to `max_sigma_px` pixels,
// random rotations (unnormalised), opacities in [0.05, max_opacity] and features in [-0.5, 1.5].
template <typename T>
GaussiansT<T> random_gaussians(const Camera& camera, int n, int channels, unsigned seed,
                               double max_sigma_px = 4.0, double max_opacity = 0.95) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  GaussiansT<T> g(std::size_t(n), channels);
  for (int i = 0; i < n; ++i) {
    const double z = 2.0 + 3.0 * u01(rng);
    const double u = (-0.2 + 1.4 * u01(rng)) * camera.width;
    const double v = (-0.2 + 1.4 * u01(rng)) * camera.height;
    const Eigen::Vector3d x = camera.unproject({u, v}, z);
    for (int k = 0; k < 3; ++k) g.means[3 * i + k] = T(x[k]);
    for (int k = 0; k < 3; ++k) {
      const double sigma_px = 0.5 + (max_sigma_px - 0.5) * u01(rng);
      g.log_scales[3 * i + k] = T(std::log(sigma_px * z / camera.fx));
    }
    for (int k = 0; k < 4; ++k) g.quats[4 * i + k] = T(normal(rng) * 0.8);
    g.opacities[i] = T(0.05 + (max_opacity - 0.05) * u01(rng));
    for (int c = 0; c < channels; ++c) g.features[i * channels + c] = T(-0.5 + 2.0 * u01(rng));
  }
  return g;
}

template <typename To, typename From>
GaussiansT<To> cast_gaussians(const GaussiansT<From>& g) {
  GaussiansT<To> out(g.size(), g.channels);
  const auto cast = [](const std::vector<From>& a, std::vector<To>& b) {
    std::transform(a.begin(), a.end(), b.begin(), [](From x) { return To(x); });
  };
  cast(g.means, out.means);
  cast(g.log_scales, out.log_scales);
  cast(g.quats, out.quats);
  cast(g.opacities, out.opacities);
  cast(g.features, out.features);
  return out;
}

inline std::vector<double> random_values(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> v(n);
  for (double& x : v) x = normal(rng);
  return v;
}

// a, b: vectors of any arithmetic type and allocator.
template <typename VectorA, typename VectorB>
double max_abs_diff(const VectorA& a, const VectorB& b) {
  EXPECT_EQ(a.size(), b.size());
  double m = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    m = std::max(m, std::abs(double(a[i]) - double(b[i])));
  return m;
}

template <typename Vector>
double max_abs(const Vector& a) {
  double m = 0;
  for (const auto x : a) m = std::max(m, std::abs(double(x)));
  return m;
}

}  // namespace retimegs::test
