// Near a merged model's seam an image is the cross-fade of the two windows' images, each window
// drawn whole (model::seam_handover, ModelRenderer::draw): the static world keeps its coverage
// across the seam, where a cross-fade of the two sets of primitives would let it thin out.
#include <algorithm>
#include <optional>

#include <gtest/gtest.h>

#include "premultiplied.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "soft_cloud.hpp"

namespace retimegs::playback {
namespace {

Camera view() {
  Camera cam;
  cam.name = "cam";
  cam.width = 40, cam.height = 30;
  cam.fx = cam.fy = 40, cam.cx = 20, cam.cy = 15;
  cam.world_to_camera = look_at({0.3, 0, -4.0}, {0, 0, 0}, {0, -1, 0});
  return cam;
}

// Dense, nearly opaque clouds of different colours: each covers the middle of the view.
constexpr test::SoftCloud kBefore{
    .count = 40, .seed = 3, .spread = 0.3f, .scale = 0.25f, .opacity_logit = 6.0f};
constexpr test::SoftCloud kAfter{
    .count = 40, .seed = 4, .spread = 0.3f, .scale = 0.25f, .opacity_logit = 6.0f};
constexpr double kFade = 0.4;

// a * x + (1 - a) * y
std::vector<float> mix(double a, const std::vector<float>& x, const std::vector<float>& y) {
  std::vector<float> out(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) out[i] = float(a * x[i] + (1 - a) * y[i]);
  return out;
}

// The depth pass as the composited depth sum_i z_i w_i it divides by alpha.
std::vector<float> composited(const Image& depth, const Image& rgba) {
  std::vector<float> out(depth.pixels());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = rgba.data[4 * i + 3] * depth.data[i];
  return out;
}

void expect_near(const std::vector<float>& got, const std::vector<float>& expected, double tol,
                 const std::string& what) {
  ASSERT_EQ(got.size(), expected.size()) << what;
  double worst = 0;
  for (std::size_t i = 0; i < got.size(); ++i)
    worst = std::max(worst, double(std::abs(got[i] - expected[i])));
  EXPECT_LE(worst, tol) << what;
}

TEST(SeamHandover, ImageIsTheCrossFadeOfTheTwoWindowsDrawnWhole) {
  const model::Model merged = test::seamed_clouds(kBefore, kAfter, kFade);
  const ModelRenderer renderer(merged);
  const ModelRenderer before(test::seamed_clouds(kBefore, kAfter, kFade, model::SeamSide::kBefore));
  const ModelRenderer after(test::seamed_clouds(kBefore, kAfter, kFade, model::SeamSide::kAfter));
  const Camera cam = view();
  const float background[3] = {0.9f, 0.4f, 0.1f};
  // Both windows cover the middle of the view (nearly) opaquely.
  const Image whole_before = before.render_rgba(cam, 0), whole_after = after.render_rgba(cam, 4);
  std::vector<std::size_t> covered;
  for (std::size_t i = 0; i < whole_before.pixels(); ++i)
    if (whole_before.data[4 * i + 3] > 0.999f && whole_after.data[4 * i + 3] > 0.999f)
      covered.push_back(i);
  ASSERT_GT(covered.size(), 50u);
  for (const double t : {0.0, 1.0, 1.5, 1.8, 2.0, 2.2, 2.5, 3.0, 4.0}) {
    const std::string what = "t = " + std::to_string(t);
    const std::optional<model::SeamHandover> h =
        model::seam_handover(merged.config, merged.grid, t);
    ASSERT_TRUE(h);
    // The side drawn alone beyond the tail: its weight rounded to 0 or 1.
    const double w = !h->draws(model::SeamSide::kAfter)    ? 1.0
                     : !h->draws(model::SeamSide::kBefore) ? 0.0
                                                           : h->before;
    expect_near(
        renderer.render(cam, t, background).data,
        mix(w, before.render(cam, t, background).data, after.render(cam, t, background).data), 1e-5,
        what + " image");
    Image depth, depth_before, depth_after;
    const Image rgba = renderer.render_rgba(cam, t, {}, Colors::kModel, &depth);
    const Image rgba_before = before.render_rgba(cam, t, {}, Colors::kModel, &depth_before);
    const Image rgba_after = after.render_rgba(cam, t, {}, Colors::kModel, &depth_after);
    expect_near(test::premultiplied(rgba),
                mix(w, test::premultiplied(rgba_before), test::premultiplied(rgba_after)), 1e-5,
                what + " rgba");
    expect_near(composited(depth, rgba),
                mix(w, composited(depth_before, rgba_before), composited(depth_after, rgba_after)),
                1e-4, what + " depth");
    // What both windows cover stays covered: two sets of primitives at σ_τ 0.5 each would
    // leave a quarter of it uncovered at the seam.
    float least = 1;
    for (const std::size_t i : covered) least = std::min(least, rgba.data[4 * i + 3]);
    EXPECT_GT(least, 0.999f) << what;
  }
  // At the seam the two windows weigh half each.
  EXPECT_EQ(model::seam_handover(merged.config, merged.grid, 2.0)->before, 0.5);
}

}  // namespace
}  // namespace retimegs::playback
