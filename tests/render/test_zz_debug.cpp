#include <gtest/gtest.h>
#include "render_test_util.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/render/reference.hpp"
namespace retimegs::test {
TEST(RenderDebug, Case3) {
  for (const char* name : kGsplatCases) {
  const GsplatCase k = load_gsplat_case(name);
  auto options = render::gsplat_v0_1_13();
  const auto out = render::rasterize_forward(k.gaussians, k.camera, k.background.data(), options);
  const auto image = npy_floats(k.dir / "render_pixcenter_plus_half.npy");
  const auto final_t = npy_floats(k.dir / "final_T_pixcenter_plus_half.npy");
  const auto n_contrib = npy_ints(k.dir / "n_contrib.npy");
  long s1 = 0, s2 = 0;
  for (size_t i = 0; i < n_contrib.size(); ++i) { s1 += n_contrib[i]; s2 += out.blend.n_contrib[i]; }
  printf("%s sum n_contrib ref %ld mine %ld\n", name, s1, s2);
  int W = k.camera.width;
  int shown = 0;
  for (size_t i = 0; i < final_t.size() && shown < 5; ++i) {
    if (std::abs(final_t[i] - out.blend.final_T[i]) > 1e-4) {
      printf("pixel x=%zu y=%zu T ref %.8g mine %.8g ncontrib ref %d mine %d\n", i % W, i / W, final_t[i], out.blend.final_T[i], n_contrib[i], out.blend.n_contrib[i]);
      ++shown;
    }
  }
  // reference double
  auto gd = cast_gaussians<double>(k.gaussians);
  std::vector<double> bg(k.background.begin(), k.background.end());
  auto ref = render::reference_forward(gd, k.camera, bg.data(), options);
  printf("ref double vs gsplat: %.3g  fast vs ref double %.3g\n", max_abs_diff(ref.final_T, final_t), max_abs_diff(ref.final_T, out.blend.final_T));
  }
}
}
namespace retimegs::test {
TEST(RenderDebug, Xy) {
  const GsplatCase k = load_gsplat_case("case1_n500_128x96");
  auto options = render::gsplat_v0_1_13();
  for (float off : {0.0f, 1e-6f}) {
  options.centre_depth_offset = off;
  const auto p = render::project_forward(k.gaussians, render::PinholeT<float>(k.camera), options);
  auto gd = cast_gaussians<double>(k.gaussians);
  const auto pd = render::project_forward(gd, render::PinholeT<double>(k.camera), options);
  const auto xys = npy_floats(k.dir / "xys.npy");
  const auto m2d = npy_floats(k.dir / "grad_v130/means2d.npy");
  double worst = 0; int wi = -1;
  for (size_t i = 0; i < k.gaussians.size(); ++i) if (p.radii[i] > 0) {
    double d = std::abs(p.means2d[2*i] - xys[2*i]) + std::abs(p.means2d[2*i+1] - xys[2*i+1]);
    if (d > worst) { worst = d; wi = i; }
  }
  int i = wi;
  printf("off %g worst %d: z %.8g mine %.8f %.8f  double %.8f %.8f ref %.8f %.8f v130 %.8f %.8f\n", off, i, p.depths[i], p.means2d[2*i], p.means2d[2*i+1], pd.means2d[2*i], pd.means2d[2*i+1], xys[2*i], xys[2*i+1], m2d[2*i], m2d[2*i+1]);
  }
}
}
