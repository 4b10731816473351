// The fast path against gsplat's own numbers (data/gsplat-reference): v0.1.13 projection,
// binning and renders, and v1.3.0 projection gradients.
#include <gtest/gtest.h>

#include <cmath>

#include "render_test_util.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::test {
namespace {

using render::gsplat_v0_1_13;

class RenderGsplat : public ::testing::TestWithParam<const char*> {};

TEST_P(RenderGsplat, ProjectionMatchesV0113) {
  RETIMEGS_REQUIRE_DATA("gsplat-reference");
  const GsplatCase k = load_gsplat_case(GetParam());
  const auto options = gsplat_v0_1_13();
  const render::Projected p =
      render::project_forward(k.gaussians, render::PinholeT<float>(k.camera), options);
  const auto xys = npy_floats(k.dir / "xys.npy");
  const auto depths = npy_floats(k.dir / "depths.npy");
  const auto conics = npy_floats(k.dir / "conics.npy");
  const auto radii = npy_ints(k.dir / "radii.npy");
  const auto visible = npy_ints(k.dir / "visible_mask.npy");
  const std::size_t n = k.gaussians.size();
  int compared = 0, opacity_culled = 0;
  double max_xy = 0, max_depth_rel = 0, max_conic_rel = 0;
  for (std::size_t i = 0; i < n; ++i) {
    // gsplat does not cull by opacity; we drop Gaussians that can never reach alpha >= 1/255.
    const bool can_contribute = k.gaussians.opacities[i] >= options.min_alpha;
    opacity_culled += visible[i] && !can_contribute;
    ASSERT_EQ(p.radii[i] > 0, visible[i] != 0 && can_contribute) << "Gaussian " << i;
    if (p.radii[i] == 0) continue;
    ++compared;
    EXPECT_EQ(p.radii[i], radii[i]) << "Gaussian " << i;
    for (int d = 0; d < 2; ++d)
      max_xy = std::max(max_xy, double(std::abs(p.means2d[2 * i + d] - xys[2 * i + d])));
    max_depth_rel = std::max(max_depth_rel, double(std::abs(p.depths[i] - depths[i]) / depths[i]));
    const double conic_scale = std::max(std::abs(conics[3 * i]), std::abs(conics[3 * i + 2]));
    for (int d = 0; d < 3; ++d)
      max_conic_rel =
          std::max(max_conic_rel, std::abs(p.conics[3 * i + d] - conics[3 * i + d]) / conic_scale);
  }
  EXPECT_GT(compared, int(n) / 4);
  EXPECT_LE(opacity_culled, int(n) / 100);
  // Float round-off: v0.1.13 builds the covariance as (J W) Sigma (J W)^T, we as J (W Sigma W^T)
  // J^T.
  EXPECT_LT(max_xy, 1e-4);
  EXPECT_LT(max_depth_rel, 1e-6);
  EXPECT_LT(max_conic_rel, 3e-5);
  std::printf("%s: %d visible compared, max |xy| %.3g px, depth rel %.3g, conic rel %.3g\n",
              GetParam(), compared, max_xy, max_depth_rel, max_conic_rel);
}

TEST_P(RenderGsplat, BinningMatchesV0113) {
  RETIMEGS_REQUIRE_DATA("gsplat-reference");
  const GsplatCase k = load_gsplat_case(GetParam());
  auto options = gsplat_v0_1_13();
  options.tight_tile_bounds = false;  // gsplat bins by the radius square alone
  const render::Projected p =
      render::project_forward(k.gaussians, render::PinholeT<float>(k.camera), options);
  const render::TileBins bins =
      render::bin_tiles(p, k.gaussians.opacities.data(), k.camera.width, k.camera.height, options);
  const auto ids = npy_ints(k.dir / "gaussian_ids_sorted.npy");
  const auto tile_bins = npy_ints(k.dir / "tile_bins.npy");  // [T, 2]
  ASSERT_EQ(std::size_t(bins.num_tiles()) * 2, tile_bins.size());
  for (int t = 0; t < bins.num_tiles(); ++t) {
    std::vector<std::int32_t> expected;  // gsplat's list, without the opacity-culled Gaussians
    for (int m = tile_bins[2 * t]; m < tile_bins[2 * t + 1]; ++m)
      if (k.gaussians.opacities[ids[m]] >= options.min_alpha) expected.push_back(ids[m]);
    const std::vector<std::int32_t> got(
        bins.gaussian_from_isect.begin() + bins.isect_offsets[t],
        bins.gaussian_from_isect.begin() + bins.isect_offsets[t + 1]);
    ASSERT_EQ(got, expected) << "tile " << t;
  }
}

TEST_P(RenderGsplat, RenderMatchesV0113WithinOneInTenThousand) {
  RETIMEGS_REQUIRE_DATA("gsplat-reference");
  const GsplatCase k = load_gsplat_case(GetParam());
  for (const bool tight : {false, true}) {
    auto options = gsplat_v0_1_13();
    options.tight_tile_bounds = tight;
    const auto out = render::rasterize_forward(k.gaussians, k.camera, k.background.data(), options);
    const auto image = npy_floats(k.dir / "render_pixcenter_plus_half.npy");
    const auto final_t = npy_floats(k.dir / "final_T_pixcenter_plus_half.npy");
    const double image_err = max_abs_diff(out.blend.image.data, image);
    const double t_err = max_abs_diff(out.blend.final_T, final_t);
    EXPECT_LT(image_err, 1e-4) << "tight_tile_bounds " << tight;
    EXPECT_LT(t_err, 1e-4) << "tight_tile_bounds " << tight;
    std::printf("%s (tight %d): max |image - gsplat| %.3g, max |T - gsplat| %.3g\n", GetParam(),
                int(tight), image_err, t_err);
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, RenderGsplat, ::testing::ValuesIn(kGsplatCases));

// gsplat v1.3.0's projection VJP (torch autograd in float64) for case 1.
TEST(RenderGsplatGrad, ProjectionGradientsMatchV130) {
  RETIMEGS_REQUIRE_DATA("gsplat-reference/case1_n500_128x96/grad_v130");
  const GsplatCase k = load_gsplat_case("case1_n500_128x96");
  const auto dir = k.dir / "grad_v130";
  render::RenderOptions options;  // v1.3.0: centre at f x / z, no culling by opacity
  options.min_alpha = 0;
  const render::PinholeT<float> camera(k.camera);
  const render::Projected p = render::project_forward(k.gaussians, camera, options);
  const auto radii_v130 = npy_ints(dir / "radii.npy");
  const std::size_t n = k.gaussians.size();
  int rows = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (radii_v130[i] > 0) {
      ASSERT_GT(p.radii[i], 0) << "Gaussian " << i << " is visible in v1.3.0";
      ++rows;
    }
  EXPECT_EQ(rows, 329);
  GaussianGrads grads(n, 3);
  const auto v_means2d = npy_floats(dir / "v_means2d.npy");
  const auto v_conics = npy_floats(dir / "v_conics.npy");
  grads.v_means2d.assign(v_means2d.begin(), v_means2d.end());
  grads.v_conics.assign(v_conics.begin(), v_conics.end());
  render::project_backward(k.gaussians, camera, p, options, grads);
  // Scales: the reference differentiates the linear scale, we the log-scale (v_log = v_s * s).
  const auto scales = npy_floats(k.dir / "scales.npy");
  auto grad_scales = npy_floats(dir / "grad_scales.npy");
  for (std::size_t i = 0; i < grad_scales.size(); ++i) grad_scales[i] *= scales[i];
  const struct {
    const char* name;
    const UninitVector<float>& got;
    std::vector<float> expected;
  } fields[] = {{"means", grads.v_means, npy_floats(dir / "grad_means.npy")},
                {"log_scales", grads.v_log_scales, grad_scales},
                {"quats", grads.v_quats, npy_floats(dir / "grad_quats.npy")}};
  for (const auto& f : fields) {
    const double rel = max_abs_diff(f.got, f.expected) / max_abs(f.expected);
    EXPECT_LT(rel, 1e-5) << f.name;
    std::printf("v1.3.0 grad_%s: max |diff| / max |grad| = %.3g\n", f.name, rel);
  }
}

}  // namespace
}  // namespace retimegs::test
