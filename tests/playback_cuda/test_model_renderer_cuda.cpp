// playback::ModelRenderer on the GPU against the CPU: a 4D model (RGB over a background, straight
// RGBA, a training camera's colour map) and a static one (splats), several cameras and times from
// one renderer, so that the reused device arrays are exercised at two image sizes.
//
// Tolerances. The GPU slices (cuda::slice) and rasterises (cuda::rasterize_forward) with the same
// per-row and per-pixel formulas as the CPU; nvcc contracts a * b + c into FMA where g++ does not,
// and the device's expf is within 2 ulps of glibc's. tests/cuda bounds the stages: slice values
// within 32 to 128 float epsilons of their field's magnitude, pixels within 1e-5. Through both,
// a pixel here moves by a few 1e-5 at most: every value within 1e-4. A Gaussian whose alpha lies
// within rounding of the 1/255 cut (or a pixel at the stop rule) is drawn on one device only; it
// changes a pixel by less than its alpha times its colour, under 1/255: up to 1 in 10^3 values
// may differ by up to 1/255 + 1e-4. Straight RGBA divides by alpha, which scales a colour's error
// by 1 / alpha: the straight colour is compared premultiplied (alpha * colour, the image over
// black), alpha within 1e-4 like the image.
// The depth pass divides the composited depth sum_i z_i w_i by alpha on the host for both
// devices: it is compared as that composited depth (alpha * depth) over the views' farthest
// depth, a value in [0, 1] whose rounding and cut outliers are bounded like a colour's.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cuda/require_gpu.hpp"
#include "premultiplied.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/model/export.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "soft_cloud.hpp"

namespace retimegs::playback {
namespace {

constexpr double kTolerance = 1e-4;            // rounding, through slice and rasteriser
constexpr double kOutlier = 1.0 / 255 + 1e-4;  // a Gaussian at the 1/255 cut, drawn once
constexpr double kOutlierShare = 1e-3;

// Every value of `gpu` within kTolerance of `cpu`, and within kOutlier for at most
// kOutlierShare of them.
void expect_close(const std::string& what, const std::vector<float>& gpu,
                  const std::vector<float>& cpu) {
  ASSERT_EQ(gpu.size(), cpu.size()) << what;
  std::size_t outliers = 0, first = 0;
  double worst = 0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    ASSERT_TRUE(std::isfinite(gpu[i])) << what << "[" << i << "] = " << gpu[i];
    const double err = std::abs(double(gpu[i]) - double(cpu[i]));
    worst = std::max(worst, err);
    if (err > kTolerance && outliers++ == 0) first = i;
  }
  EXPECT_LE(worst, kOutlier) << what;
  EXPECT_LE(outliers, std::size_t(kOutlierShare * double(cpu.size())))
      << what << ": " << outliers << " of " << cpu.size() << " values differ, first [" << first
      << "] gpu " << gpu[first] << " cpu " << cpu[first] << ", worst " << worst;
}

// The depth pass as the composited depth it came from, over kFarDepth: alpha * depth / kFarDepth
// (0 where nothing is drawn), with the alpha of the straight RGBA drawn with it.
constexpr float kFarDepth = 5.0f;  // the views stand 3.7 to 4.1 from the cloud (spread 0.8)
std::vector<float> composited_depth(const Image& depth, const Image& rgba) {
  std::vector<float> out(depth.pixels());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const float a = rgba.data[4 * i + 3];
    out[i] = a > 0 ? a * depth.data[i] / kFarDepth : 0.0f;
  }
  return out;
}

// 60 soft, drifting primitives with view-dependent colour; cam00 has a stored colour correction.
model::Model cloud() {
  model::Model model = test::soft_cloud(
      {.count = 60, .seed = 7, .spread = 0.8f, .drift = 0.3f, .opacity_logit = {}});
  for (std::size_t i = 0; i < model.primitives.size(); ++i)  // degree-1 SH: the view matters
    for (int k = 3; k < 12; ++k) model.primitives.sh[48 * i + k] = 0.05f * float(k % 5 - 2);
  model.camera_colors["cam00"] = {{0.3f, -0.2f, 0.1f}, {0.05f, -0.02f, 0.03f}};
  return model;
}

Camera view(const std::string& name, int width, int height, const Eigen::Vector3d& eye) {
  Camera cam;
  cam.name = name;
  cam.width = width, cam.height = height;
  cam.fx = cam.fy = 0.9 * width, cam.cx = 0.5 * width, cam.cy = 0.5 * height;
  cam.world_to_camera = look_at(eye, {0, 0, 0}, {0, -1, 0});
  return cam;
}

struct View {
  Camera camera;
  double t;
};

// A larger image first, then smaller ones: the device arrays are reused, not reallocated.
const View kViews[] = {
    {view("cam00", 97, 71, {0.4, -0.2, -4.0}), 1.0},   // a colour map
    {view("cam01", 40, 30, {-1.0, 0.3, -3.5}), 0.35},  // none; between training times
    {view("cam00", 64, 48, {0.4, -0.2, -4.0}), 2.0},   // a colour map, at the clip's end
};

TEST(ModelRendererCuda, FourDModelMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const model::Model model = cloud();
  const ModelRenderer cpu(model, cuda::Device::kCpu);
  const ModelRenderer gpu(model, cuda::Device::kCuda);
  const float background[3] = {0.9f, 0.4f, 0.1f};
  for (const Colors colors : {Colors::kCamera, Colors::kModel})
    for (const View& v : kViews) {
      const std::string what = v.camera.name + " " + std::to_string(v.camera.width) + "x" +
                               std::to_string(v.camera.height) + " t=" + std::to_string(v.t) +
                               (colors == Colors::kCamera ? " camera colours" : " model colours");
      const Image rgb_gpu = gpu.render(v.camera, v.t, background, {}, colors);
      const Image rgb_cpu = cpu.render(v.camera, v.t, background, {}, colors);
      ASSERT_EQ(rgb_gpu.width, v.camera.width);
      ASSERT_EQ(rgb_gpu.channels, 3);
      expect_close(what + " rgb", rgb_gpu.data, rgb_cpu.data);
      const Image rgba_gpu = gpu.render_rgba(v.camera, v.t, {}, colors);
      const Image rgba_cpu = cpu.render_rgba(v.camera, v.t, {}, colors);
      ASSERT_EQ(rgba_gpu.channels, 4);
      expect_close(what + " rgba", test::premultiplied(rgba_gpu), test::premultiplied(rgba_cpu));
      // The view sees the cloud.
      EXPECT_GT(*std::max_element(rgba_cpu.data.begin(), rgba_cpu.data.end()), 0.5f) << what;
    }
}

// A merged model near its seam: one side alone, and the cross-fade of both sides' images.
TEST(ModelRendererCuda, SeamHandoverMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const model::Model model = test::seamed_clouds(
      {.count = 60, .seed = 7, .spread = 0.8f, .drift = 0.3f, .opacity_logit = {}},
      {.count = 60, .seed = 8, .spread = 0.8f, .drift = -0.2f, .opacity_logit = {}}, 0.4);
  const ModelRenderer cpu(model, cuda::Device::kCpu), gpu(model, cuda::Device::kCuda);
  const float background[3] = {0.9f, 0.4f, 0.1f};
  const View& v = kViews[1];
  for (const double t : {0.5, 1.7, 2.0, 2.4, 3.5}) {
    const std::string what = "t=" + std::to_string(t);
    expect_close(what + " rgb", gpu.render(v.camera, t, background).data,
                 cpu.render(v.camera, t, background).data);
    Image depth_cpu, depth_gpu;
    const Image rgba_cpu = cpu.render_rgba(v.camera, t, {}, Colors::kModel, &depth_cpu);
    const Image rgba_gpu = gpu.render_rgba(v.camera, t, {}, Colors::kModel, &depth_gpu);
    expect_close(what + " rgba", test::premultiplied(rgba_gpu), test::premultiplied(rgba_cpu));
    expect_close(what + " depth", composited_depth(depth_gpu, rgba_gpu),
                 composited_depth(depth_cpu, rgba_cpu));
  }
}

TEST(ModelRendererCuda, NearPlaneAppliesOnTheGpu) {
  RETIMEGS_REQUIRE_GPU();
  const model::Model model = cloud();
  const ModelRenderer cpu(model, cuda::Device::kCpu), gpu(model, cuda::Device::kCuda);
  render::RenderOptions options;
  options.near_plane = 3.8f;  // cuts through the cloud
  const float black[3] = {0, 0, 0};
  const View& v = kViews[0];
  expect_close("near 3.8", gpu.render(v.camera, v.t, black, options).data,
               cpu.render(v.camera, v.t, black, options).data);
}

TEST(ModelRendererCuda, StaticSplatsMatchTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const Splats splats = model::export_splats(cloud(), 1.0);
  ASSERT_GT(splats.size(), 10u);
  const ModelRenderer cpu(splats, cuda::Device::kCpu), gpu(splats, cuda::Device::kCuda);
  const float background[3] = {0.2f, 0.3f, 0.4f};
  for (const View& v : kViews) {
    const std::string what = v.camera.name + " " + std::to_string(v.camera.width);
    expect_close(what + " rgb", gpu.render(v.camera, 0, background).data,
                 cpu.render(v.camera, 0, background).data);
    expect_close(what + " rgba", test::premultiplied(gpu.render_rgba(v.camera, 0)),
                 test::premultiplied(cpu.render_rgba(v.camera, 0)));
  }
}

TEST(ModelRendererCuda, DepthPassMatchesTheCpu) {
  RETIMEGS_REQUIRE_GPU();
  const model::Model model = cloud();
  const Splats splats = model::export_splats(model, 1.0);
  const float black[3] = {0, 0, 0};
  for (const bool is_static : {false, true}) {
    const LoadedModel loaded = is_static ? LoadedModel(splats) : LoadedModel(model);
    const ModelRenderer cpu(loaded, cuda::Device::kCpu), gpu(loaded, cuda::Device::kCuda);
    for (const View& v : kViews) {
      const std::string what = std::string(is_static ? "splats " : "4D ") + v.camera.name + " " +
                               std::to_string(v.camera.width) + " depth";
      Image depth_cpu, depth_gpu, depth_rgb;
      const Image rgba_cpu = cpu.render_rgba(v.camera, v.t, {}, Colors::kModel, &depth_cpu);
      const Image rgba_gpu = gpu.render_rgba(v.camera, v.t, {}, Colors::kModel, &depth_gpu);
      ASSERT_EQ(depth_gpu.channels, 1) << what;
      expect_close(what, composited_depth(depth_gpu, rgba_gpu),
                   composited_depth(depth_cpu, rgba_cpu));
      gpu.render(v.camera, v.t, black, {}, Colors::kModel, &depth_rgb);
      EXPECT_EQ(depth_rgb.data, depth_gpu.data) << what << ": render's pass is render_rgba's";
      int drawn = 0;  // the view sees the cloud at its depth
      for (const float z : depth_gpu.data) drawn += z > 3.0f && z < kFarDepth;
      EXPECT_GT(drawn, 100) << what;
    }
  }
}

}  // namespace
}  // namespace retimegs::playback
