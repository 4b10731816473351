// The tiled, SIMD, multi-threaded float path against the per-pixel double reference.
#include <gtest/gtest.h>

#include "render_test_util.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/render/rasterize.hpp"
#include "retimegs/render/reference.hpp"

namespace retimegs::test {
namespace {

struct Scenario {
  const char* name;
  int width, height, gaussians, channels;
  bool depth;
  unsigned seed;
};

// Non-multiples of 16, C = 3 and C = 7 (RGB + two flows), depth on and off.
const Scenario kScenarios[] = {
    {"rgb_61x47", 61, 47, 400, 3, false, 1},
    {"rgb_depth_64x48", 64, 48, 600, 3, true, 2},
    {"flow7_depth_45x38", 45, 38, 300, 7, true, 3},
    {"c12_33x20", 33, 20, 150, 12, false, 4},    // more channels than the compiled kernels
    {"dense_40x30", 40, 30, 3000, 3, false, 5},  // most pixels end by the transmittance rule
};

void PrintTo(const Scenario& scenario, std::ostream* os) {
  *os << scenario.name;
}

class RenderFastVsReference : public ::testing::TestWithParam<Scenario> {};

struct Rendered {
  render::RenderOptions options;
  Camera camera;
  GaussiansT<double> gd;
  Gaussians gf;
  std::vector<double> background;
  std::vector<float> background_f;
};

Rendered make(const Scenario& sc) {
  Rendered r;
  r.options.render_depth = sc.depth;
  r.camera = test_camera(sc.width, sc.height);
  r.gd = random_gaussians<double>(r.camera, sc.gaussians, sc.channels, sc.seed);
  r.gf = cast_gaussians<float>(r.gd);
  // Round-trip through float so that both paths see the same inputs.
  r.gd = cast_gaussians<double>(r.gf);
  for (int c = 0; c < sc.channels; ++c) r.background.push_back(0.2 + 0.1 * c);
  r.background_f.assign(r.background.begin(), r.background.end());
  return r;
}

TEST_P(RenderFastVsReference, ForwardMatches) {
  const Scenario& sc = GetParam();
  const Rendered r = make(sc);
  const auto ref = render::reference_forward(r.gd, r.camera, r.background.data(), r.options);
  const auto fast = render::rasterize_forward(r.gf, r.camera, r.background_f.data(), r.options);
  const double image_err = max_abs_diff(fast.blend.image.data, ref.image);
  const double alpha_err = max_abs_diff(fast.blend.alpha, ref.alpha);
  EXPECT_LT(image_err, 1e-5);
  EXPECT_LT(alpha_err, 1e-5);
  // The scene must be non-trivial: many composited pairs, opaque and transparent pixels.
  long pairs = 0;
  for (std::size_t i = 0; i < ref.n_contrib.size(); ++i) {
    EXPECT_EQ(fast.blend.n_contrib[i], ref.n_contrib[i]) << "pixel " << i;
    pairs += ref.n_contrib[i];
  }
  EXPECT_GT(pairs, 5 * sc.width * sc.height);
  double depth_err = 0;
  if (sc.depth) {
    depth_err = max_abs_diff(fast.blend.depth, ref.depth) / max_abs(ref.depth);
    EXPECT_LT(depth_err, 1e-5);
  }
  int stopped = 0;  // pixels that ended by the transmittance rule
  for (const double t : ref.final_T) stopped += t < 1e-3;
  std::printf("%s: %ld pairs, %d stopped, max |image err| %.3g, |alpha err| %.3g, depth rel %.3g\n",
              sc.name, pairs, stopped, image_err, alpha_err, depth_err);
}

TEST_P(RenderFastVsReference, BackwardMatches) {
  const Scenario& sc = GetParam();
  const Rendered r = make(sc);
  const std::size_t pixels = std::size_t(sc.width) * sc.height;
  const auto v_image = random_values(pixels * sc.channels, 11);
  const auto v_alpha = random_values(pixels, 12);
  const auto v_depth = random_values(pixels, 13);
  const std::vector<float> v_image_f(v_image.begin(), v_image.end());
  const std::vector<float> v_alpha_f(v_alpha.begin(), v_alpha.end());
  const std::vector<float> v_depth_f(v_depth.begin(), v_depth.end());
  const double* v_depth_ptr = sc.depth ? v_depth.data() : nullptr;
  const auto ref = render::reference_backward(r.gd, r.camera, r.background.data(), r.options,
                                              v_image.data(), v_alpha.data(), v_depth_ptr);
  const auto out = render::rasterize_forward(r.gf, r.camera, r.background_f.data(), r.options);
  const auto fast = render::rasterize_backward(r.gf, r.camera, r.background_f.data(), r.options,
                                               out, v_image_f.data(), v_alpha_f.data(),
                                               sc.depth ? v_depth_f.data() : nullptr);
  const struct {
    const char* name;
    const UninitVector<float>& got;
    const UninitVector<double>& expected;
  } fields[] = {{"v_means", fast.v_means, ref.v_means},
                {"v_log_scales", fast.v_log_scales, ref.v_log_scales},
                {"v_quats", fast.v_quats, ref.v_quats},
                {"v_opacities", fast.v_opacities, ref.v_opacities},
                {"v_features", fast.v_features, ref.v_features},
                {"v_means2d", fast.v_means2d, ref.v_means2d},
                {"v_conics", fast.v_conics, ref.v_conics},
                {"v_depths", fast.v_depths, ref.v_depths}};
  for (const auto& f : fields) {
    if (!sc.depth && std::string(f.name) == "v_depths") continue;
    ASSERT_GT(max_abs(f.expected), 0.0) << f.name;
    // Float vs double through up to ~100 layers: relative to the field's largest magnitude.
    const double rel = max_abs_diff(f.got, f.expected) / max_abs(f.expected);
    EXPECT_LT(rel, 2e-5) << f.name;
    std::printf("%s %s: max |fast - ref| / max |ref| = %.3g\n", sc.name, f.name, rel);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, RenderFastVsReference, ::testing::ValuesIn(kScenarios),
                         [](const auto& scenario) { return std::string(scenario.param.name); });

// Same inputs and thread count: bit-identical outputs and gradients. Different thread counts:
// the same image (tiles do not interact), gradients equal up to summation order.
TEST(RenderDeterminism, SameThreadCountIsBitIdentical) {
  const Camera camera = test_camera(70, 50);
  const Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 800, 3, 21));
  const std::vector<float> background = {0.1f, 0.2f, 0.3f};
  const auto v_image_d = random_values(std::size_t(70) * 50 * 3, 22);
  const std::vector<float> v_image(v_image_d.begin(), v_image_d.end());
  const int threads_before = max_threads();
  std::vector<UninitVector<float>> v_means;
  std::vector<std::vector<float>> images;
  for (const int threads : {2, 2, 1}) {
    set_threads(threads);
    const auto out = render::rasterize_forward(g, camera, background.data());
    const auto grads =
        render::rasterize_backward(g, camera, background.data(), {}, out, v_image.data());
    images.push_back(out.blend.image.data);
    v_means.push_back(grads.v_means);
  }
  set_threads(threads_before);
  EXPECT_EQ(images[0], images[1]);
  EXPECT_EQ(images[0], images[2]);
  EXPECT_EQ(v_means[0], v_means[1]);
  EXPECT_LT(max_abs_diff(v_means[0], v_means[2]), 1e-5 * max_abs(v_means[0]));
}

// The reusing overloads give the allocating ones' results, byte for byte, into a RenderOutput and
// GaussianGrads that held a render of more Gaussians and channels before (and of fewer after).
TEST(RenderReuse, ReusedOutputsMatchFreshOnes) {
  const Camera camera = test_camera(70, 50);
  const std::vector<float> background(7, 0.25f);
  const auto v_image_d = random_values(std::size_t(70) * 50 * 7, 23);
  const std::vector<float> v_image(v_image_d.begin(), v_image_d.end());
  render::RenderOutput out;
  GaussianGrads grads;
  for (const auto& [n, channels] : {std::pair{1500, 7}, std::pair{600, 3}, std::pair{900, 7}}) {
    const Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, n, channels, 24));
    const auto fresh = render::rasterize_forward(g, camera, background.data());
    const auto fresh_grads =
        render::rasterize_backward(g, camera, background.data(), {}, fresh, v_image.data());
    render::rasterize_forward(g, camera, background.data(), {}, out);
    render::rasterize_backward(g, camera, background.data(), {}, out, v_image.data(), grads);
    EXPECT_EQ(out.blend.image.data, fresh.blend.image.data) << n;
    EXPECT_EQ(out.blend.alpha, fresh.blend.alpha) << n;
    EXPECT_EQ(out.bins.gaussian_from_isect, fresh.bins.gaussian_from_isect) << n;
    EXPECT_EQ(out.projected.radii, fresh.projected.radii) << n;
    EXPECT_EQ(grads.channels, fresh_grads.channels) << n;
    for (const auto field :
         {&GaussianGrads::v_means, &GaussianGrads::v_log_scales, &GaussianGrads::v_quats,
          &GaussianGrads::v_opacities, &GaussianGrads::v_features, &GaussianGrads::v_means2d,
          &GaussianGrads::v_conics})
      EXPECT_EQ(grads.*field, fresh_grads.*field) << n;
  }
}

// min_alpha = 0 turns the footprint test off (every block of every binned tile is visited).
TEST(RenderFastVsReferenceOptions, ZeroMinAlphaMatches) {
  render::RenderOptions options;
  options.min_alpha = 0.0f;
  const Camera camera = test_camera(50, 37);
  const Gaussians g = cast_gaussians<float>(random_gaussians<double>(camera, 300, 3, 41));
  const GaussiansT<double> gd = cast_gaussians<double>(g);
  const std::vector<double> background = {0.3, 0.2, 0.1};
  const std::vector<float> background_f(background.begin(), background.end());
  const auto ref = render::reference_forward(gd, camera, background.data(), options);
  const auto fast = render::rasterize_forward(g, camera, background_f.data(), options);
  EXPECT_LT(max_abs_diff(fast.blend.image.data, ref.image), 1e-5);
  EXPECT_EQ(std::vector<std::int32_t>(fast.blend.n_contrib.begin(), fast.blend.n_contrib.end()),
            ref.n_contrib);
}

}  // namespace
}  // namespace retimegs::test
