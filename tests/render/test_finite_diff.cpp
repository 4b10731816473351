// Vector-Jacobian products against central finite differences, in double precision, on tiny
// scenes. The alpha cut-off and early termination are switched off here (min_alpha = 0,
// min_transmittance = 0, opacities under the clamp) so that the loss is smooth.
#include <gtest/gtest.h>

#include <functional>
#include <span>
#include <string>

#include "render_test_util.hpp"
#include "retimegs/render/reference.hpp"

namespace retimegs::test {
namespace {

constexpr double kStep = 1e-6;  // central differences: truncation ~h^2, round-off ~1e-16 / h

// d loss / d x[i] for every i, by central differences.
std::vector<double> central_differences(std::span<double> x, const std::function<double()>& loss) {
  std::vector<double> g(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double saved = x[i];
    x[i] = saved + kStep;
    const double plus = loss();
    x[i] = saved - kStep;
    const double minus = loss();
    x[i] = saved;
    g[i] = (plus - minus) / (2 * kStep);
  }
  return g;
}

void expect_gradient(const char* name, std::span<const double> analytic,
                     const std::vector<double>& numeric) {
  ASSERT_EQ(analytic.size(), numeric.size()) << name;
  const double scale = max_abs(numeric);
  ASSERT_GT(scale, 1e-3) << name << ": the test scene does not exercise this gradient";
  double worst = 0;
  for (std::size_t i = 0; i < analytic.size(); ++i) {
    const double err = std::abs(analytic[i] - numeric[i]);
    EXPECT_LE(err, 1e-6 * scale + 1e-5 * std::abs(numeric[i]))
        << name << "[" << i << "]: analytic " << analytic[i] << ", numeric " << numeric[i];
    worst = std::max(worst, err / scale);
  }
  std::printf("%-14s max |analytic - numeric| / max |numeric| = %.2g\n", name, worst);
}

double dot(std::span<const double> a, std::span<const double> b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

struct TinyScene {
  Camera camera = test_camera(16, 12);  // one tile, so the tile footprint never moves
  GaussiansT<double> g;
  std::vector<double> background = {0.3, 0.6, 0.1};
  std::vector<double> v_image, v_alpha, v_depth;

  explicit TinyScene(unsigned seed) {
    g = random_gaussians<double>(camera, 6, 3, seed, /*max_sigma_px=*/3.0, /*max_opacity=*/0.9);
    const std::size_t pixels = std::size_t(camera.width) * camera.height;
    v_image = random_values(pixels * 3, seed + 100);
    v_alpha = random_values(pixels, seed + 200);
    v_depth = random_values(pixels, seed + 300);
  }
  double loss(const render::ReferenceOutput& out) const {
    return dot(out.image, v_image) + dot(out.alpha, v_alpha) + dot(out.depth, v_depth);
  }
};

TEST(RenderFiniteDiff, ProjectionBackward) {
  const Camera camera = test_camera(40, 30);
  GaussiansT<double> g = random_gaussians<double>(camera, 8, 3, 5, 6.0);
  const render::PinholeT<double> pinhole(camera);
  const render::RenderOptions options;
  const std::size_t n = g.size();
  const auto v_means2d = random_values(2 * n, 1), v_conics = random_values(3 * n, 2),
             v_depths = random_values(n, 3);
  const auto loss = [&] {
    const auto p = render::project_forward(g, pinhole, options);
    for (std::size_t i = 0; i < n; ++i) EXPECT_GT(p.radii[i], 0) << "Gaussian " << i;
    return dot(p.means2d, v_means2d) + dot(p.conics, v_conics) + dot(p.depths, v_depths);
  };
  GaussianGradsT<double> grads(n, 3);
  grads.v_means2d.assign(v_means2d.begin(), v_means2d.end());
  grads.v_conics.assign(v_conics.begin(), v_conics.end());
  grads.v_depths.assign(v_depths.begin(), v_depths.end());
  render::project_backward(g, pinhole, render::project_forward(g, pinhole, options), options,
                           grads);
  expect_gradient("v_means", grads.v_means, central_differences(g.means, loss));
  expect_gradient("v_log_scales", grads.v_log_scales, central_differences(g.log_scales, loss));
  expect_gradient("v_quats", grads.v_quats, central_differences(g.quats, loss));
}

TEST(RenderFiniteDiff, BlendBackwardFor2DIntermediates) {
  for (const unsigned seed : {1u, 2u}) {
    TinyScene s(seed);
    const auto options = smooth_options();
    auto projected = render::project_forward(s.g, render::PinholeT<double>(s.camera), options);
    const auto loss = [&] {
      return s.loss(render::reference_blend_forward(projected, s.g, s.camera.width, s.camera.height,
                                                    s.background.data(), options));
    };
    GaussianGradsT<double> grads(s.g.size(), 3);
    render::reference_blend_backward(projected, s.g, s.camera.width, s.camera.height,
                                     s.background.data(), options, s.v_image.data(),
                                     s.v_alpha.data(), s.v_depth.data(), grads);
    expect_gradient("v_means2d", grads.v_means2d, central_differences(projected.means2d, loss));
    expect_gradient("v_conics", grads.v_conics, central_differences(projected.conics, loss));
    expect_gradient("v_depths", grads.v_depths, central_differences(projected.depths, loss));
  }
}

TEST(RenderFiniteDiff, PipelineBackward) {
  for (const unsigned seed : {3u, 4u}) {
    TinyScene s(seed);
    const auto options = smooth_options();
    const auto loss = [&] {
      return s.loss(render::reference_forward(s.g, s.camera, s.background.data(), options));
    };
    const auto grads =
        render::reference_backward(s.g, s.camera, s.background.data(), options, s.v_image.data(),
                                   s.v_alpha.data(), s.v_depth.data());
    expect_gradient("v_means", grads.v_means, central_differences(s.g.means, loss));
    expect_gradient("v_log_scales", grads.v_log_scales, central_differences(s.g.log_scales, loss));
    expect_gradient("v_quats", grads.v_quats, central_differences(s.g.quats, loss));
    expect_gradient("v_opacities", grads.v_opacities, central_differences(s.g.opacities, loss));
    expect_gradient("v_features", grads.v_features, central_differences(s.g.features, loss));
  }
}

// With the default (gsplat) rules the loss is piecewise smooth: away from the cut-offs the
// gradient still matches, including through the alpha clamp (zero gradient when clamped).
TEST(RenderFiniteDiff, ClampedAlphaHasZeroGradient) {
  TinyScene s(7);
  for (double& o : s.g.opacities) o = 1.0;  // the centre of every Gaussian is clamped at 0.99
  const auto options = smooth_options();
  // Some (pixel, Gaussian) pairs must be clamped: exp(-sigma) > 0.99 at a pixel centre.
  const auto p = render::project_forward(s.g, render::PinholeT<double>(s.camera), options);
  int clamped = 0;
  for (std::size_t i = 0; i < s.g.size(); ++i)
    for (int y = 0; y < s.camera.height; ++y)
      for (int x = 0; x < s.camera.width; ++x) {
        const double dx = p.means2d[2 * i] - (x + 0.5), dy = p.means2d[2 * i + 1] - (y + 0.5);
        const double* c = &p.conics[3 * i];
        clamped += std::exp(-(0.5 * (c[0] * dx * dx + c[2] * dy * dy) + c[1] * dx * dy)) > 0.99;
      }
  ASSERT_GT(clamped, 0);
  const auto loss = [&] {
    return s.loss(render::reference_forward(s.g, s.camera, s.background.data(), options));
  };
  const auto grads =
      render::reference_backward(s.g, s.camera, s.background.data(), options, s.v_image.data(),
                                 s.v_alpha.data(), s.v_depth.data());
  expect_gradient("v_means", grads.v_means, central_differences(s.g.means, loss));
  expect_gradient("v_features", grads.v_features, central_differences(s.g.features, loss));
}

}  // namespace
}  // namespace retimegs::test
