// The near plane of `retimegs render` / `retimegs eval` (--near): an opaque Gaussian 0.1 in front
// of the camera, as a rig camera's own body is in a dome capture, covers the image with a near
// plane of 0.01 and is gone with 0.2, through the library and the command line alike; by default
// the near plane is the scene's (io::scene_near_plane), which clears the body on a rig of a dome's
// size.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/eval/protocol.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/model/sh.hpp"
#include "retimegs/playback/render_model.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// A 3-frame scene whose images are mid-grey, and a model of one white, opaque Gaussian (0.1
// across) 0.1 in front of camera cam00, seen at every frame. With `rig_radius` the scene has a
// second training camera opposite cam00 at that distance from the origin (a dome's rig), else
// cam00 alone.
struct Fixture {
  io::Scene scene;
  model::Model model;
  explicit Fixture(const fs::path& root, double rig_radius = 0) {
    scene.root = root / "scene";
    scene.num_frames = 3;
    scene.fps = 24;
    const Camera cam = test::small_camera("cam00", {0, 0, -4.0});
    scene.cameras.push_back(cam);
    if (rig_radius > 0) scene.cameras.push_back(test::small_camera("cam01", {0, 0, rig_radius}));
    for (int c = 0; c < int(scene.cameras.size()); ++c)
      for (int k = 0; k < scene.num_frames; ++k)
        media::write_png(scene.image_path(c, k), Image(64, 48, 3, 0.5f));
    io::write_scene_json(scene);

    model.grid = {0.0, 2.0, 2};
    model::Primitives& p = model.primitives;
    p.resize(1);
    const Eigen::Vector3d mean = cam.cam_to_world({0, 0, 0.1});
    for (int a = 0; a < 3; ++a) p.mu[a] = float(mean[a]);
    for (int a = 0; a < 3; ++a) p.log_scale[a] = std::log(0.1f);
    p.q0[0] = 1;
    for (int k = 0; k < 3; ++k) p.sh[k] = float(0.5 / model::kShC0);  // colour 1
    p.opacity_logit[0] = 10.0f;
    p.mu_tau[0] = 1.0f;
    p.tau_l[0] = p.tau_r[0] = 2.0f;
    model::write_model(root / "model.rgs", model);
  }
};

std::pair<float, float> min_max(const Image& image) {
  const auto [lo, hi] = std::minmax_element(image.data.begin(), image.data.end());
  return {*lo, *hi};
}

render::RenderOptions with_near(float near) {
  render::RenderOptions options;
  options.near_plane = near;
  return options;
}

TEST(NearCli, AGaussianInFrontOfTheCameraCoversTheImageUnlessBeyondTheNearPlane) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const Camera& cam = f.scene.cameras[0];
  const float black[3] = {0, 0, 0};
  EXPECT_GT(min_max(playback::render_model(f.model, cam, 1.0, black, with_near(0.01f))).first,
            0.5f);
  EXPECT_EQ(min_max(playback::render_model(f.model, cam, 1.0, black, with_near(0.2f))).second,
            0.0f);
  // eval's renderer passes its options to every render.
  EXPECT_GT(min_max(eval::model_renderer(f.scene, f.model, with_near(0.01f))(0, 1.0)).first, 0.5f);
  EXPECT_EQ(min_max(eval::model_renderer(f.scene, f.model, with_near(0.2f))(0, 1.0)).second, 0.0f);

  const std::string base = "render --model " + (dir / "model.rgs").string() + " --scene " +
                           f.scene.root.string() + " --camera cam00 --time 1 --out ";
  for (const auto& [near, out] : {std::pair{"", "default.png"}, {" --near 0.2", "near.png"}}) {
    const auto r = test::run_cli(base + (dir / out).string() + near);
    ASSERT_EQ(r.status, 0) << r.err;
  }
  EXPECT_GT(min_max(media::read_image(dir / "default.png")).first, 0.5f);
  EXPECT_EQ(min_max(media::read_image(dir / "near.png")).second, 0.0f);
}

// By default the near plane is kNearPlaneFraction of the extent of the training cameras: 9 % of
// 1.1 x 4 = 0.396 for cameras 8 apart, beyond the Gaussian 0.1 in front of cam00, so render draws
// nothing; with cam00 alone (extent 1) it is 0.09 and the Gaussian covers the image.
TEST(NearCli, TheDefaultNearPlaneIsTheScenes) {
  test::TempDir dir;
  const Fixture lone(dir / "lone"), rig(dir / "rig", 4.0);
  EXPECT_DOUBLE_EQ(io::scene_near_plane(lone.scene), io::kNearPlaneFraction);
  EXPECT_DOUBLE_EQ(io::scene_near_plane(rig.scene), io::kNearPlaneFraction * 1.1 * 4.0);
  // Test cameras do not size the scene.
  io::Scene with_test = rig.scene;
  with_test.cameras[1].split = Split::kTest;
  EXPECT_DOUBLE_EQ(io::scene_near_plane(with_test), io::kNearPlaneFraction);

  for (const Fixture* f : {&lone, &rig}) {
    const fs::path out = f->scene.root.parent_path() / "default.png";
    const auto r = test::run_cli(
        "render --model " + (f->scene.root.parent_path() / "model.rgs").string() + " --scene " +
        f->scene.root.string() + " --camera cam00 --time 1 --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    if (f == &lone)
      EXPECT_GT(min_max(media::read_image(out)).first, 0.5f);
    else
      EXPECT_EQ(min_max(media::read_image(out)).second, 0.0f);
  }
}

// eval scores the render with its near plane and records it: a black render of the mid-grey
// images (128 in 8 bits) scores 20 log10(255 / 128) = 5.99 dB.
TEST(NearCli, EvalRendersWithItsNearPlaneAndRecordsIt) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string base = "eval --model " + (dir / "model.rgs").string() + " --scene " +
                           f.scene.root.string() + " --frames 1 --out ";
  for (const auto& [near, out] : {std::pair{"", "default.json"}, {" --near 0.2", "near.json"}}) {
    const auto r = test::run_cli(base + (dir / out).string() + near);
    ASSERT_EQ(r.status, 0) << r.err;
  }
  const auto near = nlohmann::json::parse(test::read_text(dir / "near.json"));
  EXPECT_EQ(near["near"], 0.2);
  const double black_psnr = 20 * std::log10(255.0 / 128);
  EXPECT_NEAR(near["whole"]["psnr"].get<double>(), black_psnr, 1e-3);
  const auto by_default = nlohmann::json::parse(test::read_text(dir / "default.json"));
  EXPECT_DOUBLE_EQ(by_default["near"].get<double>(), io::kNearPlaneFraction);
  EXPECT_GT(std::abs(by_default["whole"]["psnr"].get<double>() - black_psnr), 1.0);
}

TEST(NearCli, RejectsANearPlaneThatIsNotFiniteAndPositive) {
  test::TempDir dir;
  const Fixture f(dir.path());
  const std::string scene = " --scene " + f.scene.root.string();
  const std::string model = " --model " + (dir / "model.rgs").string();
  for (const std::string value : {"0", "-1", "nan"}) {
    for (const std::string& command :
         {"render" + model + scene + " --camera cam00 --time 1 --out " + (dir / "o.png").string(),
          "eval" + model + scene + " --out " + (dir / "o.json").string()}) {
      const auto r = test::run_cli(command + " --near " + value);
      EXPECT_EQ(r.status, 2) << command;
      EXPECT_NE(r.err.find("--near: must be a finite number > 0, got " + value), std::string::npos)
          << r.err;
      EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
    }
  }
  // A baseline renders no Gaussians: a near plane for it is a mistake, said so.
  const auto r = test::run_cli("eval --baseline crossfade" + scene + " --near 0.3 --out " +
                               (dir / "o.json").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--near 0.3: a baseline renders no Gaussians"), std::string::npos) << r.err;
  for (const char* name : {"o.png", "o.json"}) EXPECT_FALSE(fs::exists(dir / name)) << name;
}

}  // namespace
}  // namespace retimegs
