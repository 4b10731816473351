// Degenerate inputs: empty and culled scenes, borders, thin and transparent Gaussians, odd image
// sizes, and invalid values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "render_test_util.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/memory.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/render/reference.hpp"

namespace retimegs::test {
namespace {

const std::vector<float> kBackground = {0.25f, 0.5f, 0.75f};

// Forward and backward through both paths; expects them to agree and returns the fast output.
render::RenderOutput render_both(const Gaussians& g, const Camera& camera,
                                 GaussianGrads* grads_out = nullptr) {
  const render::RenderOptions options;
  const auto fast = render::rasterize_forward(g, camera, kBackground.data(), options);
  const std::vector<double> bg(kBackground.begin(), kBackground.end());
  const auto gd = cast_gaussians<double>(g);
  const auto ref = render::reference_forward(gd, camera, bg.data(), options);
  EXPECT_LT(max_abs_diff(fast.blend.image.data, ref.image), 1e-5);
  const std::size_t pixels = std::size_t(camera.width) * camera.height;
  const auto v_image = random_values(pixels * g.channels, 3);
  const std::vector<float> v_image_f(v_image.begin(), v_image.end());
  const auto grads =
      render::rasterize_backward(g, camera, kBackground.data(), options, fast, v_image_f.data());
  const auto ref_grads =
      render::reference_backward(gd, camera, bg.data(), options, v_image.data(), nullptr, nullptr);
  for (const auto& [got, expected] : {std::pair{&grads.v_means, &ref_grads.v_means},
                                      {&grads.v_log_scales, &ref_grads.v_log_scales},
                                      {&grads.v_quats, &ref_grads.v_quats},
                                      {&grads.v_opacities, &ref_grads.v_opacities},
                                      {&grads.v_features, &ref_grads.v_features}}) {
    for (const float v : *got) EXPECT_TRUE(std::isfinite(v));
    EXPECT_LE(max_abs_diff(*got, *expected), 2e-5 * std::max(1.0, max_abs(*expected)));
  }
  if (grads_out) *grads_out = grads;
  return fast;
}

void expect_background_only(const render::RenderOutput& out) {
  const Image& image = out.blend.image;
  for (std::size_t p = 0; p < image.pixels(); ++p) {
    for (int c = 0; c < 3; ++c) ASSERT_EQ(image.data[p * 3 + c], kBackground[c]);
    ASSERT_EQ(out.blend.alpha[p], 0.0f);
  }
}

TEST(RenderEdgeCases, EmptySceneIsBackground) {
  const Camera camera = test_camera(20, 10);
  GaussianGrads grads;
  const auto out = render_both(Gaussians(0, 3), camera, &grads);
  expect_background_only(out);
  EXPECT_EQ(out.bins.num_intersections(), 0u);
  EXPECT_TRUE(grads.v_means.empty());
}

TEST(RenderEdgeCases, GaussiansBehindTheCameraAreCulled) {
  const Camera camera = test_camera(32, 24);
  Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 50, 3, 1));
  for (std::size_t i = 0; i < g.size(); ++i) g.means[3 * i + 2] *= -1.0f;  // z in [-5, -2]
  g.means[2] = 0.005f;  // in front, but nearer than the near plane (0.01)
  GaussianGrads grads;
  const auto out = render_both(g, camera, &grads);
  expect_background_only(out);
  for (const std::int32_t r : out.projected.radii) EXPECT_EQ(r, 0);
  EXPECT_EQ(max_abs(grads.v_means), 0.0);
}

TEST(RenderEdgeCases, GaussianStraddlingTheBorderIsDrawnOnBothTiles) {
  const Camera camera = test_camera(40, 36);
  Gaussians g(3, 3);
  // Centres left of the image, on the tile boundary x = 16 and below the image.
  const double centres[3][2] = {{-2.0, 18.0}, {16.0, 10.0}, {30.0, 37.5}};
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d x = camera.unproject({centres[i][0], centres[i][1]}, 3.0);
    for (int k = 0; k < 3; ++k) g.means[3 * i + k] = float(x[k]);
    for (int k = 0; k < 3; ++k) g.log_scales[3 * i + k] = std::log(3.0f * 3.0f / float(camera.fx));
    g.quats[4 * i] = 1.0f;
    g.opacities[i] = 0.8f;
    g.features[3 * i + i] = 1.0f;
  }
  const auto out = render_both(g, camera);
  EXPECT_GT(out.blend.alpha[18 * 40 + 0], 0.3f);   // column 0, from the Gaussian at x = -2
  EXPECT_GT(out.blend.alpha[10 * 40 + 15], 0.7f);  // both sides of the tile boundary
  EXPECT_GT(out.blend.alpha[10 * 40 + 16], 0.7f);
  EXPECT_GT(out.blend.alpha[35 * 40 + 30], 0.5f);  // last row, from the Gaussian below it
}

TEST(RenderEdgeCases, DegenerateThinScalesStayFinite) {
  const Camera camera = test_camera(24, 24);
  Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 40, 3, 2));
  for (std::size_t i = 0; i < g.size(); i += 2) {  // needles and discs: two or one axes ~0
    g.log_scales[3 * i] = -30.0f;
    if (i % 4 == 0) g.log_scales[3 * i + 1] = -30.0f;
  }
  const auto out = render_both(g, camera);
  for (const float v : out.blend.image.data) ASSERT_TRUE(std::isfinite(v));
  int visible = 0;
  for (const std::int32_t r : out.projected.radii) visible += r > 0;
  EXPECT_GT(visible, 20);  // the 0.3 px^2 low-pass keeps them drawable
}

TEST(RenderEdgeCases, ZeroOpacityChangesNothing) {
  const Camera camera = test_camera(30, 20);
  Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 60, 3, 3));
  const auto before = render::rasterize_forward(g, camera, kBackground.data());
  Gaussians with_ghosts = g;
  const Gaussians ghosts = cast_gaussians<float>(random_gaussians<double>(camera, 20, 3, 4));
  for (std::size_t i = 0; i < ghosts.size(); ++i) {
    with_ghosts.means.insert(with_ghosts.means.end(), &ghosts.means[3 * i],
                             &ghosts.means[3 * i + 3]);
    with_ghosts.log_scales.insert(with_ghosts.log_scales.end(), &ghosts.log_scales[3 * i],
                                  &ghosts.log_scales[3 * i + 3]);
    with_ghosts.quats.insert(with_ghosts.quats.end(), &ghosts.quats[4 * i],
                             &ghosts.quats[4 * i + 4]);
    with_ghosts.opacities.push_back(0.0f);
    with_ghosts.features.insert(with_ghosts.features.end(), &ghosts.features[3 * i],
                                &ghosts.features[3 * i + 3]);
  }
  GaussianGrads grads;
  const auto after = render_both(with_ghosts, camera, &grads);
  EXPECT_EQ(before.blend.image.data, after.blend.image.data);
  for (std::size_t i = g.size(); i < with_ghosts.size(); ++i) {
    EXPECT_EQ(after.projected.radii[i], 0);
    EXPECT_EQ(grads.v_opacities[i], 0.0f);
  }
}

TEST(RenderEdgeCases, OddImageSizes) {
  for (const auto& [w, h] : {std::pair{1, 1}, {1, 17}, {17, 1}, {33, 47}, {16, 16}}) {
    const Camera camera = test_camera(w, h);
    // Footprints of up to 8 px so that even a 1x1 image is covered.
    const Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 80, 3, 5, 8.0));
    const auto out = render_both(g, camera);
    EXPECT_EQ(out.blend.image.width, w);
    EXPECT_EQ(out.blend.image.height, h);
    EXPECT_EQ(out.bins.num_tiles(), ((w + 15) / 16) * ((h + 15) / 16));
  }
}

// The stages size their outputs without zeroing them (UninitVector) and then write every element.
// Rendering into memory filled with 0xff bytes (NaN, -1) must give the same bits as into zeroed
// memory, on a scene with culled Gaussians (behind the camera, off image, transparent), a
// partial last batch of 16, depth, C = 7 and an image of partial tiles.
TEST(RenderEdgeCases, EveryOutputElementIsWritten) {
  const Camera camera = test_camera(37, 23);
  Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 61, 7, 8, 6.0));
  g.means[3 * 1 + 2] *= -1.0f;                          // behind the camera
  g.means[3 * 2 + 0] += 100.0f;                         // off image
  for (int i = 16; i < 32; ++i) g.opacities[i] = 0.0f;  // a whole batch of 16 culled
  const std::vector<float> background = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f};
  render::RenderOptions options;
  options.render_depth = true;
  const std::size_t pixels = std::size_t(camera.width) * camera.height;
  const auto to_float = [](const std::vector<double>& v) {
    return std::vector<float>(v.begin(), v.end());
  };
  const auto v_image = to_float(random_values(pixels * 7, 9));
  const auto v_alpha = to_float(random_values(pixels, 10));
  const auto v_depth = to_float(random_values(pixels, 11));
  std::vector<render::RenderOutput> outs;
  std::vector<GaussianGrads> grads;
  for (const int poison : {0x00, 0xff}) {
    set_uninit_poison(poison);
    outs.push_back(render::rasterize_forward(g, camera, background.data(), options));
    grads.push_back(render::rasterize_backward(g, camera, background.data(), options, outs.back(),
                                               v_image.data(), v_alpha.data(), v_depth.data()));
  }
  set_uninit_poison(-1);
  const auto same_bits = [](const auto& a, const auto& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
  };
  const render::RenderOutput &zeroed = outs[0], &poisoned = outs[1];
  EXPECT_TRUE(same_bits(zeroed.projected.means2d, poisoned.projected.means2d));
  EXPECT_TRUE(same_bits(zeroed.projected.conics, poisoned.projected.conics));
  EXPECT_TRUE(same_bits(zeroed.projected.depths, poisoned.projected.depths));
  EXPECT_TRUE(same_bits(zeroed.projected.radii, poisoned.projected.radii));
  EXPECT_EQ(zeroed.projected.radii[1], 0);
  EXPECT_EQ(zeroed.projected.radii[2], 0);
  EXPECT_EQ(zeroed.projected.radii[16], 0);
  EXPECT_TRUE(same_bits(zeroed.blend.image.data, poisoned.blend.image.data));
  EXPECT_TRUE(same_bits(zeroed.blend.alpha, poisoned.blend.alpha));
  EXPECT_TRUE(same_bits(zeroed.blend.depth, poisoned.blend.depth));
  EXPECT_TRUE(same_bits(zeroed.blend.final_T, poisoned.blend.final_T));
  EXPECT_TRUE(same_bits(zeroed.blend.last_contributor, poisoned.blend.last_contributor));
  EXPECT_TRUE(same_bits(zeroed.blend.n_contrib, poisoned.blend.n_contrib));
  for (const auto field :
       {&GaussianGrads::v_means, &GaussianGrads::v_log_scales, &GaussianGrads::v_quats,
        &GaussianGrads::v_opacities, &GaussianGrads::v_features, &GaussianGrads::v_means2d,
        &GaussianGrads::v_conics, &GaussianGrads::v_depths}) {
    EXPECT_TRUE(same_bits(grads[0].*field, grads[1].*field));
  }
}

void expect_rejected(const Gaussians& g, const std::string& needle) {
  try {
    render::rasterize_forward(g, test_camera(16, 16), kBackground.data());
    ADD_FAILURE() << "accepted input with " << needle;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(RenderEdgeCases, NonFiniteAndInvalidInputsAreRejected) {
  const Gaussians good =
      cast_gaussians<float>(random_gaussians<double>(test_camera(16, 16), 10, 3, 6));
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  Gaussians g = good;
  g.means[3 * 4 + 1] = kNan;
  expect_rejected(g, "gaussians.means[4][1] is nan");
  g = good;
  g.log_scales[3 * 7 + 2] = kInf;
  expect_rejected(g, "gaussians.log_scales[7][2] is inf");
  g = good;
  g.quats[4 * 2 + 0] = -kInf;
  expect_rejected(g, "gaussians.quats[2][0]");
  g = good;
  g.features[3 * 9 + 1] = kNan;
  expect_rejected(g, "gaussians.features[9][1]");
  g = good;
  g.opacities[5] = kNan;
  expect_rejected(g, "gaussians.opacities[5]");
  g = good;
  g.opacities[3] = 1.5f;
  expect_rejected(g, "gaussians.opacities[3] is 1.5");
  g = good;
  for (int k = 0; k < 4; ++k) g.quats[4 * 6 + k] = 0.0f;
  expect_rejected(g, "gaussians.quats[6] is zero");
  g = good;
  g.features.pop_back();
  expect_rejected(g, "gaussians.features: has 29 values, expected 30");
  // Past the first batch of 16, and a value that the projection would turn finite (exp(-inf)).
  Gaussians many = cast_gaussians<float>(random_gaussians<double>(test_camera(16, 16), 40, 3, 7));
  many.log_scales[3 * 33] = -kInf;
  expect_rejected(many, "gaussians.log_scales[33][0] is -inf");
  EXPECT_THROW(render::project_forward(many, render::PinholeT<float>(test_camera(16, 16)), {}),
               Error);
  // The reference path validates the same way.
  GaussiansT<double> gd = cast_gaussians<double>(good);
  gd.means[0] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(render::reference_forward(gd, test_camera(16, 16), nullptr, {}), Error);
  // And the background and camera.
  const std::vector<float> bad_background = {0.0f, kNan, 0.0f};
  EXPECT_THROW(render::rasterize_forward(good, test_camera(16, 16), bad_background.data()), Error);
  Camera camera = test_camera(16, 16);
  camera.fx = 0;
  EXPECT_THROW(render::rasterize_forward(good, camera, nullptr), Error);
}

}  // namespace
}  // namespace retimegs::test
