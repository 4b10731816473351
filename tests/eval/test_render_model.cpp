// Which colours a render shows: a scene camera with a stored colour correction (a training
// camera) through it, any other camera and every camera path with the model's own.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "retimegs/core/camera.hpp"
#include "retimegs/eval/render_model.hpp"
#include "retimegs/io/frame_writer.hpp"
#include "retimegs/io/image_io.hpp"
#include "test_util.hpp"

namespace retimegs::eval {
namespace {
namespace fs = std::filesystem;

// Two cameras looking at a cloud of drifting primitives; cam00 has a stored correction.
struct Fixture {
  io::Scene scene;
  model::Model model;
  Fixture() {
    for (int c = 0; c < 2; ++c) {
      Camera cam;
      cam.name = "cam0" + std::to_string(c);
      cam.width = 40, cam.height = 30;
      cam.fx = cam.fy = 40, cam.cx = 20, cam.cy = 15;
      cam.world_to_camera = look_at({1.0 * c - 0.5, 0, -4.0}, {0, 0, 0}, {0, -1, 0});
      scene.cameras.push_back(cam);
    }
    scene.num_frames = 3;
    model.grid = {0.0, 2.0, 2};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1, 1);
    model::Primitives& p = model.primitives;
    const int n = 60;
    p.resize(n);
    for (int i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) p.mu[3 * i + a] = u(rng);
      for (int a = 0; a < 3; ++a) p.log_scale[3 * i + a] = std::log(0.15f);
      p.q0[4 * i] = 1;
      p.velocity[9 * i] = 0.3f;
      for (int k = 0; k < 3; ++k) p.sh[48 * i + k] = 0.8f * u(rng);
      p.opacity_logit[i] = 1.0f;
      p.mu_tau[i] = 1.0f;
      p.tau_l[i] = p.tau_r[i] = 2.0f;
    }
    model.camera_colors["cam00"] = {{0.3f, -0.2f, 0.1f}, {0.05f, -0.02f, 0.0f}};
  }
};

double max_abs_diff(const Image& a, const Image& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i)
    d = std::max(d, double(std::abs(a.data[i] - b.data[i])));
  return d;
}

// The largest difference of a written frame from `image` as a PNG holds it: clamped to [0, 1],
// 8 bits (half a level).
void expect_written(const fs::path& png, Image image) {
  for (float& v : image.data) v = std::clamp(v, 0.0f, 1.0f);
  EXPECT_LT(max_abs_diff(io::read_image(png), image), 0.5 / 255 + 1e-6) << png;
}

TEST(RenderModel, ATrainingCameraRendersThroughItsCorrection) {
  const Fixture f;
  const float black[3] = {0, 0, 0};
  const Camera& cam0 = f.scene.cameras[0];
  const Camera& cam1 = f.scene.cameras[1];
  const Image own = render_model(f.model, cam0, 1.0, black);
  Image corrected;
  model::apply_camera_color(own, f.model.camera_colors.at("cam00"), corrected);
  EXPECT_GT(max_abs_diff(own, corrected), 0.05) << "the correction changes the render";
  EXPECT_EQ(render_model(f.model, cam0, 1.0, black, {}, Colors::kCamera).data, corrected.data);
  // A camera without a correction renders the model's colours either way.
  EXPECT_EQ(render_model(f.model, cam1, 1.0, black, {}, Colors::kCamera).data,
            render_model(f.model, cam1, 1.0, black).data);
  // eval's renderer shows each scene camera as it recorded.
  const FrameRenderer renderer = model_renderer(f.scene, f.model);
  EXPECT_EQ(renderer(0, 1.0).data, corrected.data);
  EXPECT_EQ(renderer(1, 1.0).data, render_model(f.model, cam1, 1.0, black).data);
  // Between frames too: stability renders at fractional times.
  const Image between = render_model(f.model, cam1, 0.5, black);
  EXPECT_GT(max_abs_diff(between, renderer(1, 1.0)), 0.01) << "the model changes in time";
  EXPECT_EQ(renderer(1, 0.5).data, between.data);
}

TEST(RenderModel, OneCameraUsesItsColoursAPathTheModels) {
  test::TempDir dir;
  const Fixture f;
  const float black[3] = {0, 0, 0};
  const Camera& cam0 = f.scene.cameras[0];
  {
    io::FrameWriter writer(dir / "one", 2, 24);
    render_frames(f.model, {cam0}, {0.5, 1.0}, black, writer);
  }
  {
    io::FrameWriter writer(dir / "path", 2, 24);
    render_frames(f.model, {cam0, f.scene.cameras[1]}, {1.0, 1.0}, black, writer);
  }
  expect_written(dir / "one" / "00001.png",
                 render_model(f.model, cam0, 1.0, black, {}, Colors::kCamera));
  // The path starts at cam00's pose, with the model's colours (no jump where it passes a camera).
  expect_written(dir / "path" / "00000.png", render_model(f.model, cam0, 1.0, black));
}

}  // namespace
}  // namespace retimegs::eval
