// ModelRenderer's depth pass (render/depth.hpp): per pixel gsplat's expected depth
// sum_i z_i w_i / sum_i w_i, kNoDepth where nothing is drawn; the same from render() and
// render_rgba(), for a 4D model and for static splats.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "render/render_test_util.hpp"  // cast_gaussians
#include "retimegs/core/camera.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/render/depth.hpp"
#include "retimegs/render/reference.hpp"
#include "soft_cloud.hpp"

namespace retimegs::playback {
namespace {

constexpr float kWallDepth = 3.0f;

// A camera at the origin looking down +z: a point's camera z is its world z.
Camera front_view() {
  Camera cam;
  cam.name = "front";
  cam.width = 48, cam.height = 36;
  cam.fx = cam.fy = 40, cam.cx = 24, cam.cy = 18;
  return cam;
}

// A 9 x 7 wall of flat, nearly opaque primitives at z = kWallDepth facing the camera: it covers
// the middle of front_view() (x, y within ±1.3 at z = 3: ±17 px) and leaves the border empty.
// Every window covers t = 1.
model::Model wall_model() {
  model::Model model = test::soft_cloud({.count = 63, .seed = 2, .opacity_logit = 3.0f});
  model::Primitives& p = model.primitives;
  for (int i = 0; i < 63; ++i) {
    const float mu[3] = {0.25f * float(i % 9 - 4), 0.25f * float(i / 9 - 3), kWallDepth};
    const float log_scale[3] = {std::log(0.15f), std::log(0.15f), std::log(1e-3f)};
    for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = mu[a], p.log_scale[3 * i + a] = log_scale[a];
  }
  return model;
}

// The static splats of the same wall.
Splats wall_splats() {
  const model::Model m = wall_model();
  Splats s;
  s.means = m.primitives.mu;
  s.log_scales = m.primitives.log_scale;
  s.quats = m.primitives.q0;
  s.opacity_logits = m.primitives.opacity_logit;
  for (std::size_t i = 0; i < m.primitives.size(); ++i)
    for (int k = 0; k < 3; ++k) s.sh.push_back(m.primitives.sh[48 * i + k]);
  return s;
}

// Every Gaussian of the wall sits at camera z = kWallDepth, so each pixel it covers, wholly or in
// part, shows that depth: the pass divides two float sums of the same weights, sum z w and
// 1 - T, which agree to a few float epsilons of the larger of 1 and their own size; relative to
// alpha that is at most ~1e-5 at the faintest drawn pixel (alpha >= 1/255): 1e-4 of the depth.
// The empty border shows kNoDepth. A pass that forgot the division, took the distance to the
// camera instead of z (3.16 at the wall's corner) or filled coverage holes would miss.
void expect_wall_depth(const std::string& what, const ModelRenderer& renderer) {
  const Camera cam = front_view();
  const float black[3] = {0, 0, 0};
  Image depth, rgba_depth;
  renderer.render(cam, 1.0, black, {}, Colors::kModel, &depth);
  const Image rgba = renderer.render_rgba(cam, 1.0, {}, Colors::kModel, &rgba_depth);
  ASSERT_EQ(depth.channels, 1) << what;
  ASSERT_EQ(depth.width, cam.width) << what;
  ASSERT_EQ(depth.height, cam.height) << what;
  EXPECT_EQ(rgba_depth.data, depth.data) << what << ": render_rgba's pass is render's";
  int empty = 0, partial = 0;
  for (std::size_t i = 0; i < depth.pixels(); ++i) {
    const float alpha = rgba.data[4 * i + 3];
    if (alpha == 0) {
      ++empty;
      EXPECT_EQ(depth.data[i], render::kNoDepth) << what << " pixel " << i;
    } else {
      partial += alpha < 0.5f;
      EXPECT_NEAR(depth.data[i], kWallDepth, 1e-4 * kWallDepth)
          << what << " pixel " << i << " alpha " << alpha;
    }
  }
  EXPECT_GT(empty, 200) << what;   // the border
  EXPECT_GT(partial, 20) << what;  // the wall's soft edge
}

TEST(RenderDepth, AWallShowsItsDepthWhereverItIsDrawn) {
  expect_wall_depth("4D model", ModelRenderer(wall_model()));
  expect_wall_depth("static splats", ModelRenderer(wall_splats()));
}

// The pass against the slow reference rasteriser (render/reference.hpp: per pixel, every
// Gaussian in depth order, in double) on the same sliced Gaussians: its composited depth over its
// alpha. The fast float render agrees with it to 1e-5 of the largest depth sum and alpha
// (tests/render); divided by alpha, that error grows by 1 / alpha: compared where alpha >= 0.05,
// the pass is within 1e-5 * (z_max + depth) / alpha, under 1e-3 scene units here. A Gaussian
// drawn at alpha within rounding of the 1/255 cut on one side only may make a pixel empty on one
// side: the empty pixels must agree everywhere else.
TEST(RenderDepth, EqualsTheSlowReferenceOnTheSameGaussians) {
  const model::Model model =
      test::soft_cloud({.count = 40, .seed = 9, .spread = 0.8f, .scale = 0.2f, .drift = 0.3f});
  const ModelRenderer renderer(model);
  Camera cam = front_view();
  cam.world_to_camera = look_at({0.6, -0.3, -4.0}, {0, 0, 0}, {0, -1, 0});
  const double t = 0.7;
  const float black[3] = {0, 0, 0};
  Image depth;
  renderer.render(cam, t, black, {}, Colors::kModel, &depth);

  const model::TimeSlice sliced =
      model::slice(model.primitives, model.config, model.grid, t, cam, {});
  render::RenderOptions options;
  options.render_depth = true;
  const render::ReferenceOutput ref = render::reference_forward(
      test::cast_gaussians<double>(sliced.gaussians), cam, nullptr, options);
  double z_max = 0;
  for (const double z : ref.projected.depths) z_max = std::max(z_max, z);
  int compared = 0, empty = 0, mismatched_empty = 0;
  for (std::size_t i = 0; i < depth.pixels(); ++i) {
    const double alpha = ref.alpha[i];
    if (alpha == 0 || depth.data[i] == render::kNoDepth) {
      empty += alpha == 0;
      mismatched_empty += (alpha == 0) != (depth.data[i] == render::kNoDepth);
      continue;
    }
    if (alpha < 0.05) continue;
    const double expected = ref.depth[i] / alpha;
    EXPECT_NEAR(depth.data[i], expected, 1e-5 * (z_max + expected) / alpha) << "pixel " << i;
    ++compared;
  }
  EXPECT_LE(mismatched_empty, 2);
  EXPECT_GT(empty, 100);  // the view sees empty pixels and many drawn ones
  EXPECT_GT(compared, 300);
}

}  // namespace
}  // namespace retimegs::playback
