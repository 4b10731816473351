// The CUDA rasteriser against the CPU renderer, stage by stage, forward and backward.
//
// Tolerances. Forward: the same formulas in the same order (render/formulas.hpp), so values agree
// to float rounding: 1e-5 absolute (+ 1e-5 relative for conics and depths, which are not in
// [0, 1]); integers exactly. The two compilers may contract a * b + c into FMA differently,
// which can flip a decision at a threshold (alpha >= min_alpha, the stop rule, a tile or radius
// boundary): up to 1 in 10^4 pixel values and 1 in 10^3 per-Gaussian values may differ more.
// Backward: the GPU sums each Gaussian's pixels over warps and then by atomicAdd in whatever order
// the warps finish, the CPU per thread in tile order: 1e-4 relative, plus 1e-5 of the field's
// largest magnitude (sums that cancel), with the same share of threshold outliers. A rotated
// camera's depths may differ by an ulp between the compilers, which can swap two Gaussians of
// (nearly) equal depth in a tile: its cases allow 1 % outliers (its projections stay strict).
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/require_gpu.hpp"
#include "render/render_test_util.hpp"
#include "retimegs/cuda/rasterize.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::cuda {
namespace {

struct Case {
  int n, width, height, channels;
  unsigned seed;
  bool gsplat_v0 = false, depth = false;
  bool rotated = false;  // a camera turned away from the axes (else at the origin, along +z)

  std::string name() const {
    return "n=" + std::to_string(n) + " " + std::to_string(width) + "x" + std::to_string(height) +
           " C=" + std::to_string(channels) + " seed=" + std::to_string(seed) +
           (gsplat_v0 ? " gsplat_v0_1_13" : "") + (depth ? " depth" : "") +
           (rotated ? " rotated" : "");
  }
  render::RenderOptions options() const {
    render::RenderOptions o = gsplat_v0 ? render::gsplat_v0_1_13() : render::RenderOptions{};
    o.render_depth = depth;
    return o;
  }
  // Shares of values allowed past the tolerance (see the top of the file).
  double pixel_outliers() const { return rotated ? 1e-2 : 1e-4; }
  double gaussian_outliers() const { return rotated ? 1e-2 : 1e-3; }

  Camera camera() const {
    Camera c = test::test_camera(width, height);
    if (rotated)
      c.world_to_camera = look_at({0.7, -0.4, -0.3}, {0.1, 0.05, 3.0}, {0.1, -1.0, 0.05});
    return c;
  }
};

// Image sizes that are not multiples of 16 (partial tiles), 1 to 5000 Gaussians, C = 3, 7 (RGB +
// 4 flow channels) and others, both option sets, depth on and off.
const Case kCases[] = {
    {1, 37, 29, 3, 1},
    {37, 50, 40, 3, 2, false, true},
    {1000, 160, 120, 3, 3, true, false},
    {1000, 161, 93, 7, 4, false, true},
    {5000, 333, 257, 7, 5},
    {5000, 200, 150, 3, 6, true, true},
    {2000, 129, 97, 5, 7, false, true},
    {2000, 100, 75, 1, 8, true},
    {3000, 240, 135, 11, 9, false, true, true},
    {3000, 96, 64, 3, 10, false, false, true},
};

double magnitude(const auto& v) {
  double m = 0;
  for (const auto x : v) m = std::max(m, std::abs(double(x)));
  return m;
}

// Every value of `gpu` within abs + rel |cpu| of `cpu`, but for at most `outlier_share` of them.
void expect_close(const std::string& what, const auto& gpu, const auto& cpu, double abs, double rel,
                  double outlier_share) {
  ASSERT_EQ(gpu.size(), cpu.size()) << what;
  std::size_t outliers = 0, first = 0;
  double worst = 0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const double g = double(gpu[i]), c = double(cpu[i]);
    ASSERT_TRUE(std::isfinite(g)) << what << "[" << i << "] = " << g << " (not written?)";
    const double err = std::abs(g - c);
    if (err > abs + rel * std::abs(c)) {
      if (outliers++ == 0) first = i;
      worst = std::max(worst, err);
    }
  }
  EXPECT_LE(outliers, std::size_t(outlier_share * double(cpu.size())))
      << what << ": " << outliers << " of " << cpu.size() << " values differ, first [" << first
      << "] gpu " << double(gpu[first]) << " cpu " << double(cpu[first]) << ", worst " << worst;
}

void expect_equal(const std::string& what, const auto& gpu, const auto& cpu, double outlier_share) {
  expect_close(what, gpu, cpu, 0.0, 0.0, outlier_share);
}

// The tile lists as sets of lists: tiles whose list differs.
void expect_same_bins(const std::string& what, const render::TileBins& gpu,
                      const render::TileBins& cpu, double outlier_share) {
  ASSERT_EQ(gpu.tiles_x, cpu.tiles_x);
  ASSERT_EQ(gpu.tiles_y, cpu.tiles_y);
  ASSERT_EQ(gpu.isect_offsets.size(), cpu.isect_offsets.size());
  EXPECT_EQ(gpu.isect_offsets.front(), 0) << what;
  EXPECT_EQ(std::size_t(gpu.isect_offsets.back()), gpu.gaussian_from_isect.size()) << what;
  int differing = 0;
  for (int t = 0; t < cpu.num_tiles(); ++t) {
    const auto list = [](const render::TileBins& b, int tile) {
      return std::vector<std::int32_t>(b.gaussian_from_isect.begin() + b.isect_offsets[tile],
                                       b.gaussian_from_isect.begin() + b.isect_offsets[tile + 1]);
    };
    ASSERT_LE(gpu.isect_offsets[t], gpu.isect_offsets[t + 1]) << what << " tile " << t;
    differing += list(gpu, t) != list(cpu, t);
  }
  EXPECT_LE(differing, int(outlier_share * cpu.num_tiles()))
      << what << ": " << differing << " of " << cpu.num_tiles() << " tile lists differ";
}

void poison(DeviceRenderOutput& out) {
  for (auto* b : {&out.projected.means2d, &out.projected.conics, &out.projected.depths,
                  &out.blend.image, &out.blend.alpha, &out.blend.depth, &out.blend.final_T})
    b->fill_bytes(0xff);  // NaN
  for (auto* b : {&out.projected.radii, &out.bins.isect_offsets, &out.bins.gaussian_from_isect,
                  &out.blend.last_contributor, &out.blend.n_contrib})
    b->fill_bytes(0xff);  // -1
}

void poison(DeviceGaussianGrads& grads) {
  for (auto* b : {&grads.v_means, &grads.v_log_scales, &grads.v_quats, &grads.v_opacities,
                  &grads.v_features, &grads.v_means2d, &grads.v_conics, &grads.v_depths})
    b->fill_bytes(0xff);
}

struct Rendered {
  render::RenderOutput cpu, gpu;
};

// The forward on both devices; the GPU's twice, its outputs poisoned in between (the second run
// must write every value) and the two runs compared bit for bit.
Rendered render_both(const Case& k, const Gaussians& g, const std::vector<float>& background,
                     DeviceGaussians& dg, DeviceRenderOutput& out) {
  const Camera camera = k.camera();
  Rendered r;
  r.cpu = render::rasterize_forward(g, camera, background.data(), k.options());
  dg.upload(g);
  rasterize_forward(dg, camera, background.data(), k.options(), out);
  render::RenderOutput first;
  download(out, first);
  poison(out);
  rasterize_forward(dg, camera, background.data(), k.options(), out);
  download(out, r.gpu);
  const auto bits_equal = [](const auto& a, const auto& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
  };
  EXPECT_TRUE(bits_equal(first.blend.image.data, r.gpu.blend.image.data)) << "not repeatable";
  EXPECT_TRUE(bits_equal(first.blend.alpha, r.gpu.blend.alpha)) << "not repeatable";
  EXPECT_TRUE(bits_equal(first.blend.depth, r.gpu.blend.depth)) << "not repeatable";
  EXPECT_TRUE(bits_equal(first.bins.gaussian_from_isect, r.gpu.bins.gaussian_from_isect));
  return r;
}

std::vector<float> random_background(int channels, unsigned seed) {
  std::vector<float> bg(channels);
  for (int c = 0; c < channels; ++c) bg[c] = 0.1f + 0.8f * float((seed * 7 + c * 13) % 10) / 10;
  return bg;
}

TEST(CudaRasterize, ForwardMatchesTheCpuRendererStageByStage) {
  RETIMEGS_REQUIRE_GPU();
  DeviceGaussians dg;
  DeviceRenderOutput out;  // reused across cases, as a training loop does
  for (const Case& k : kCases) {
    SCOPED_TRACE(k.name());
    const Gaussians g = test::random_gaussians<float>(k.camera(), k.n, k.channels, k.seed);
    const std::vector<float> background = random_background(k.channels, k.seed);
    const Rendered r = render_both(k, g, background, dg, out);
    const render::Projected &pc = r.cpu.projected, &pg = r.gpu.projected;
    constexpr double kProjectionOutliers = 1e-3;
    expect_equal("radii", pg.radii, pc.radii, kProjectionOutliers);
    expect_close("means2d", pg.means2d, pc.means2d, 1e-5, 1e-6, kProjectionOutliers);
    expect_close("conics", pg.conics, pc.conics, 1e-5, 1e-5, kProjectionOutliers);
    expect_close("depths", pg.depths, pc.depths, 1e-5, 1e-6, kProjectionOutliers);
    expect_same_bins("bins", r.gpu.bins, r.cpu.bins, 10 * k.gaussian_outliers());
    const render::BlendOutput &bc = r.cpu.blend, &bg = r.gpu.blend;
    ASSERT_EQ(bg.image.channels, k.channels);
    expect_close("image", bg.image.data, bc.image.data, 1e-5, 0, k.pixel_outliers());
    expect_close("alpha", bg.alpha, bc.alpha, 1e-5, 0, k.pixel_outliers());
    expect_close("final_T", bg.final_T, bc.final_T, 1e-5, 0, k.pixel_outliers());
    expect_close("depth", bg.depth, bc.depth, 1e-5, 1e-6, k.pixel_outliers());
    expect_equal("n_contrib", bg.n_contrib, bc.n_contrib, k.pixel_outliers());
    expect_equal("last_contributor", bg.last_contributor, bc.last_contributor, k.pixel_outliers());
    // Not an empty picture: some Gaussian reached a pixel (the one-Gaussian case may be faint).
    EXPECT_GE(magnitude(bc.alpha), 1.0 / 255);
  }
}

TEST(CudaRasterize, BackwardMatchesTheCpuRendererFieldByField) {
  RETIMEGS_REQUIRE_GPU();
  DeviceGaussians dg;
  DeviceRenderOutput out;
  DeviceGaussianGrads grads;
  DeviceBuffer<float> v_image, v_alpha, v_depth;
  for (const Case& k : kCases) {
    SCOPED_TRACE(k.name());
    const Camera camera = k.camera();
    const Gaussians g = test::random_gaussians<float>(camera, k.n, k.channels, k.seed);
    const std::vector<float> background = random_background(k.channels, k.seed);
    Rendered r = render_both(k, g, background, dg, out);
    const std::size_t pixels = std::size_t(k.width) * k.height;
    const auto upstream = [](std::size_t n, unsigned seed) {
      const std::vector<double> d = test::random_values(n, seed);
      return std::vector<float>(d.begin(), d.end());
    };
    const std::vector<float> vi = upstream(pixels * k.channels, k.seed + 100);
    const std::vector<float> va = upstream(pixels, k.seed + 200);
    const std::vector<float> vd = upstream(pixels, k.seed + 300);
    const float* vd_cpu = k.depth ? vd.data() : nullptr;
    const GaussianGrads cpu = render::rasterize_backward(g, camera, background.data(), k.options(),
                                                         r.cpu, vi.data(), va.data(), vd_cpu);
    v_image.upload(vi);
    v_alpha.upload(va);
    v_depth.upload(vd);
    const float* vd_gpu = k.depth ? v_depth.data() : nullptr;
    rasterize_backward(dg, camera, background.data(), k.options(), out, v_image.data(),
                       v_alpha.data(), vd_gpu, grads);
    poison(grads);
    rasterize_backward(dg, camera, background.data(), k.options(), out, v_image.data(),
                       v_alpha.data(), vd_gpu, grads);
    const GaussianGrads gpu = grads.download();
    ASSERT_EQ(gpu.channels, k.channels);
    const auto check = [&](const char* what, const auto& gv, const auto& cv) {
      expect_close(what, gv, cv, 1e-5 * magnitude(cv), 1e-4, k.gaussian_outliers());
    };
    check("v_means2d", gpu.v_means2d, cpu.v_means2d);
    check("v_conics", gpu.v_conics, cpu.v_conics);
    check("v_opacities", gpu.v_opacities, cpu.v_opacities);
    check("v_features", gpu.v_features, cpu.v_features);
    check("v_depths", gpu.v_depths, cpu.v_depths);
    check("v_means", gpu.v_means, cpu.v_means);
    check("v_log_scales", gpu.v_log_scales, cpu.v_log_scales);
    check("v_quats", gpu.v_quats, cpu.v_quats);
    // Gradients that a wrong kernel could miss by being zero are not zero.
    EXPECT_GT(magnitude(cpu.v_means), 0);
    EXPECT_GT(magnitude(cpu.v_opacities), 0);
    if (k.depth) {
      EXPECT_GT(magnitude(cpu.v_depths), 0);
    }
  }
}

TEST(CudaRasterize, BadInputsThrowTheCpuRenderersErrors) {
  RETIMEGS_REQUIRE_GPU();
  const Case k{100, 64, 48, 3, 11};
  const Camera camera = k.camera();
  Gaussians g = test::random_gaussians<float>(camera, k.n, k.channels, k.seed);
  DeviceGaussians dg;
  dg.upload(g);
  // A NaN that only the device sees (written behind upload's check): the forward names it.
  const float nan = std::nanf("");
  check(cudaMemcpy(dg.means.data() + 3 * 42 + 1, &nan, sizeof(float), cudaMemcpyHostToDevice),
        "poke");
  DeviceRenderOutput out;
  test::expect_error([&] { rasterize_forward(dg, camera, nullptr, k.options(), out); },
                     {"gaussians.means[42][1]", "finite"});
  g.channels = kMaxBlendChannels + 1;
  g.features.resize(g.size() * g.channels, 0.5f);
  dg.upload(g);
  test::expect_error([&] { rasterize_forward(dg, camera, nullptr, k.options(), out); },
                     {"channels", "maximum"});
}

}  // namespace
}  // namespace retimegs::cuda
