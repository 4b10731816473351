// `retimegs export --calibration rig|colmap` (issue 65): the scene's cameras as the model refined
// them, read back by `import videos --calib` as the corrected cameras, test cameras as they were.
#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "moving_model_scene.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// The CLI fixture with cam01 a test camera and a model that refined cam00 (and a camera the scene
// lacks), and footage for `import videos`: two frames of each camera as image folders in src/.
struct RefinedRig : test::MovingModelScene {
  model::CameraPose pose{{0.02, -0.015, 0.01}, {0.05, -0.03, 0.02}};
  explicit RefinedRig(const fs::path& root) : MovingModelScene(root) {
    scene.cameras[1].split = Split::kTest;
    io::write_scene_json(scene);
    model.camera_poses["cam00"] = pose;
    model.camera_poses["elsewhere"] = {{0.01, 0, 0}, {0, 0, 0}};
    model::write_model(model_path, model);
    for (const Camera& cam : scene.cameras)
      for (int k = 0; k < 2; ++k) {
        Image image(cam.width, cam.height, 3);
        for (std::size_t i = 0; i < image.data.size(); ++i)
          image.data[i] = float((i * 7 + 40 * k) % 256) / 255;
        media::write_png(root / "src" / cam.name / fmt::format("{:05d}.png", k), image);
      }
  }
  // The cameras the export must give back: cam00 through its correction, cam01 as it is.
  Camera expected(int c) const {
    return c == 0 ? model::corrected(scene.cameras[0], pose) : scene.cameras[c];
  }
};

void expect_same_camera(const Camera& read, const Camera& want) {
  SCOPED_TRACE(want.name);
  EXPECT_EQ(read.name, want.name);
  EXPECT_EQ(read.width, want.width);
  EXPECT_EQ(read.height, want.height);
  EXPECT_NEAR(read.fx, want.fx, 1e-9);
  EXPECT_NEAR(read.fy, want.fy, 1e-9);
  EXPECT_NEAR(read.cx, want.cx, 1e-9);
  EXPECT_NEAR(read.cy, want.cy, 1e-9);
  EXPECT_LT((read.world_to_camera - want.world_to_camera).norm(), 1e-9)
      << read.world_to_camera << "\n"
      << want.world_to_camera;
}

// Imports the fixture's footage with the calibration `calib`; returns the scene.
io::Scene import_with(const fs::path& dir, const fs::path& calib, const std::string& out) {
  const auto r = test::run_cli("import videos --in " + (dir / "src").string() + " --calib " +
                               calib.string() + " --out " + (dir / out).string());
  EXPECT_EQ(r.status, 0) << r.err;
  return media::read_scene(dir / out, media::SceneCheck::kJson);
}

TEST(ExportCalibrationCli, RigAndColmapImportAsTheCorrectedCameras) {
  test::TempDir dir;
  const RefinedRig f(dir.path());
  ASSERT_GT((f.expected(0).world_to_camera - f.scene.cameras[0].world_to_camera).norm(), 0.03);
  const std::string common =
      "export --model " + f.model_path.string() + " --scene " + f.scene.root.string();
  const auto rig =
      test::run_cli(common + " --calibration rig --out " + (dir / "rig.json").string());
  ASSERT_EQ(rig.status, 0) << rig.err;
  const std::string log = rig.out + rig.err;
  EXPECT_NE(log.find("wrote 2 cameras"), std::string::npos) << log;
  EXPECT_NE(log.find("1 through the model's pose corrections"), std::string::npos) << log;
  EXPECT_NE(log.find("left out: elsewhere"), std::string::npos) << log;
  const auto colmap =
      test::run_cli(common + " --calibration colmap --out " + (dir / "sparse").string());
  ASSERT_EQ(colmap.status, 0) << colmap.err;
  for (const char* file : {"cameras.txt", "images.txt", "points3D.txt"})
    EXPECT_TRUE(fs::is_regular_file(dir / "sparse" / file)) << file;
  EXPECT_TRUE(io::read_colmap_model(dir / "sparse").points.empty());

  for (const auto& [calib, out] :
       {std::pair{dir / "rig.json", "from_rig"}, std::pair{dir / "sparse", "from_colmap"}}) {
    SCOPED_TRACE(out);
    const io::Scene imported = import_with(dir.path(), calib, out);
    ASSERT_EQ(imported.cameras.size(), 2u);
    for (int c = 0; c < 2; ++c) expect_same_camera(imported.cameras[c], f.expected(c));
  }
}

TEST(ExportCalibrationCli, BadRequestsAreRefusedInOneLine) {
  test::TempDir dir;
  const RefinedRig f(dir.path());
  const std::string common =
      "export --model " + f.model_path.string() + " --scene " + f.scene.root.string();
  test::write_text(dir / "taken.json", "{}");
  struct Case {
    std::string args, fragment;
  };
  const std::vector<Case> cases = {
      {common + " --calibration opencv --out " + (dir / "x.json").string(), "'opencv'"},
      {common + " --calibration rig --out " + (dir / "rig.yaml").string(), ".json"},
      {common + " --calibration rig --out " + (dir / "taken.json").string(), "taken.json"},
      {common + " --calibration rig", "--out"},
      {"export --model " + f.model_path.string() + " --calibration colmap --out " +
           (dir / "s").string(),
       "--scene"},
      {common + " --calibration colmap --time 1 --out " + (dir / "s").string(), "--time"},
      // Never onto an input, even with --force.
      {common + " --calibration colmap --force --out " + f.scene.root.string(), "--out"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const auto r = test::run_cli(c.args);
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << r.err;
  }
  EXPECT_EQ(test::read_text(dir / "taken.json"), "{}");
  EXPECT_FALSE(fs::exists(dir / "s"));
  EXPECT_TRUE(fs::is_regular_file(f.scene.root / "scene.json"));
  // --force replaces an existing output.
  const auto forced =
      test::run_cli(common + " --calibration rig --force --out " + (dir / "taken.json").string());
  EXPECT_EQ(forced.status, 0) << forced.err;
  EXPECT_NE(test::read_text(dir / "taken.json"), "{}");
}

}  // namespace
}  // namespace retimegs
