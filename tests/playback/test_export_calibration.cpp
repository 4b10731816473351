// export --calibration's files (issue 65): the scene's cameras as the model saw them, as a rig
// file in OpenCV's pixel convention and as a COLMAP text model in the scene's; the round trip
// through import videos is in tests/cli/test_export_calibration_cli.cpp.
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/playback/export_calibration.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

const model::CameraPose kPose{{0.03, -0.05, 0.02}, {0.1, -0.05, 0.08}};

struct Refined {
  test::TwoCameraCloud f;
  model::Model model = f.model;
  Refined() {
    f.scene.cameras[0].cx = 20.25;  // the principal point off the centre: its half-pixel shows
    f.scene.cameras[1].split = Split::kTest;
    model.camera_poses["cam00"] = kPose;
    model.camera_poses["cam09"] = kPose;  // no camera of the scene
  }
  Camera seen(int c) const {
    return c == 0 ? model::corrected(f.scene.cameras[0], kPose) : f.scene.cameras[c];
  }
};

TEST(ExportCalibration, RigFileHoldsTheSeenCamerasInOpenCvsPixelConvention) {
  const Refined r;
  const json rig = json::parse(rig_json({r.seen(0), r.seen(1)}));
  ASSERT_EQ(rig["cameras"].size(), 2u);
  for (int c = 0; c < 2; ++c) {
    const Camera want = r.seen(c);
    const json& cam = rig["cameras"][c];
    EXPECT_EQ(cam["name"], want.name);
    EXPECT_EQ(cam["width"], want.width);
    EXPECT_EQ(cam["height"], want.height);
    EXPECT_EQ(
        cam["K"],
        json({{want.fx, 0.0, want.cx - 0.5}, {0.0, want.fy, want.cy - 0.5}, {0.0, 0.0, 1.0}}));
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        EXPECT_EQ(cam["R"][i][j].get<double>(), want.world_to_camera(i, j));
      EXPECT_EQ(cam["t"][i].get<double>(), want.world_to_camera(i, 3));
    }
  }
  EXPECT_EQ(rig["cameras"][0]["K"][0][2].get<double>(), 19.75);
}

TEST(ExportCalibration, ColmapModelReadsBackAsTheSeenCameras) {
  test::TempDir dir;
  const Refined r;
  const ExportedCalibration written =
      export_calibration(r.model, r.f.scene, CalibrationFormat::kColmap, dir / "sparse", false);
  EXPECT_EQ(written.cameras, 2);
  EXPECT_EQ(written.corrected, 1);
  EXPECT_EQ(written.unmatched, std::vector<std::string>{"cam09"});
  const io::ColmapModel read = io::read_colmap_model(dir / "sparse");
  ASSERT_EQ(read.images.size(), 2u);
  EXPECT_TRUE(read.points.empty());
  for (int c = 0; c < 2; ++c) {
    const Camera want = r.seen(c);
    const io::ColmapImage& image = read.images[c];
    EXPECT_EQ(image.name, want.name + ".png");
    EXPECT_LT((image.world_to_camera() - want.world_to_camera).norm(), 1e-12) << want.name;
    const io::ColmapCamera& cam = read.camera(image.camera_id);
    EXPECT_EQ(cam.model, "PINHOLE");
    EXPECT_EQ(cam.params, (std::vector<double>{want.fx, want.fy, want.cx, want.cy}));
    EXPECT_EQ(cam.width, want.width);
  }
  EXPECT_GT((r.seen(0).world_to_camera - r.f.scene.cameras[0].world_to_camera).norm(), 0.05);
}

TEST(ExportCalibration, OutputsAreRefusedNamingTheProblem) {
  test::TempDir dir;
  const Refined r;
  test::expect_error(
      [&] {
        export_calibration(r.model, r.f.scene, CalibrationFormat::kRig, dir / "rig.yaml", false);
      },
      {"--out", "rig.yaml", ".json"});
  test::write_text(dir / "rig.json", "{}");
  test::expect_error(
      [&] {
        export_calibration(r.model, r.f.scene, CalibrationFormat::kRig, dir / "rig.json", false);
      },
      {"rig.json"});
  EXPECT_EQ(test::read_text(dir / "rig.json"), "{}");
  export_calibration(r.model, r.f.scene, CalibrationFormat::kRig, dir / "rig.json", true);
  EXPECT_EQ(json::parse(test::read_text(dir / "rig.json"))["cameras"].size(), 2u);
  io::Scene spaced = r.f.scene;
  spaced.cameras[1].name = " cam01";
  test::expect_error(
      [&] {
        export_calibration(r.model, spaced, CalibrationFormat::kColmap, dir / "sparse", false);
      },
      {"' cam01'", "starts with a space"});
  EXPECT_FALSE(fs::exists(dir / "sparse"));
  test::expect_error([&] { parse_calibration_format("yaml", "--calibration"); },
                     {"--calibration", "'yaml'", "rig or colmap"});
}

}  // namespace
}  // namespace retimegs::playback
