#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/ingest/import.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr int kW = 40, kH = 30;

// OpenGL camera-to-world (x right, y up, z backward) of a camera at `eye` whose view (-z) runs
// along -z world (a = 0), or along -x world (a = 1).
json transform(const Eigen::Vector3d& eye, int axes) {
  if (axes == 0)
    return json::array({json::array({1, 0, 0, eye.x()}), json::array({0, 1, 0, eye.y()}),
                        json::array({0, 0, 1, eye.z()}), json::array({0, 0, 0, 1})});
  // right = (0, 0, -1), up = (0, 1, 0), back = (1, 0, 0)
  return json::array({json::array({0, 0, 1, eye.x()}), json::array({0, 1, 0, eye.y()}),
                      json::array({-1, 0, 0, eye.z()}), json::array({0, 0, 0, 1})});
}

void write_gray(const fs::path& path, float value, int w = kW, int h = kH) {
  media::write_png(path, Image(w, h, 3, value));
}

// Static capture: two frames without time, global intrinsics.
TEST(NerfstudioImport, StaticCaptureProjectsAKnownPoint) {
  test::TempDir dir;
  json j = {{"fl_x", 30.0}, {"fl_y", 31.0}, {"cx", 20.0}, {"cy", 15.0}, {"w", kW}, {"h", kH}};
  j["frames"] = json::array();
  j["frames"].push_back(
      {{"file_path", "images/frame_00001.png"}, {"transform_matrix", transform({0, 0, 5}, 0)}});
  j["frames"].push_back({{"file_path", "images/frame_00002"},  // no extension, as Blender
                         {"transform_matrix", transform({5, 0, 0}, 1)}});
  write_gray(dir / "src" / "images" / "frame_00001.png", 0.2f);
  write_gray(dir / "src" / "images" / "frame_00002.png", 0.6f);
  test::write_text(dir / "src" / "transforms.json", j.dump(2));
  ImportOptions options;
  options.progress = false;
  import_nerfstudio(dir / "src", dir / "scene", options);
  const io::Scene scene = media::read_scene(dir / "scene");
  EXPECT_EQ(scene.num_frames, 1);
  EXPECT_EQ(scene.calibration, io::CalibrationSource::kUser);  // a user's reconstruction
  ASSERT_EQ(scene.cameras.size(), 2u);
  EXPECT_EQ(scene.cameras[0].name, "frame_00001");
  EXPECT_EQ(scene.cameras[1].name, "frame_00002");
  // X = (1, 0.5, 0). Camera 0 at (0,0,5) looking along -z, y up: right 1, down -0.5, depth 5.
  // Camera 1 at (5,0,0) looking along -x, right = -z: right 0, down -0.5, depth 4.
  const Eigen::Vector3d x(1, 0.5, 0);
  EXPECT_LT(
      (scene.cameras[0].project(x) - Eigen::Vector2d(20 + 30.0 / 5, 15 - 31 * 0.5 / 5)).norm(),
      1e-9);
  EXPECT_NEAR(scene.cameras[1].world_to_cam(x).z(), 4, 1e-9);
  EXPECT_LT((scene.cameras[1].project(x) - Eigen::Vector2d(20, 15 - 31 * 0.5 / 4)).norm(), 1e-9);
  EXPECT_NEAR(media::load_image(scene, 1, 0).at(3, 3, 0), 0.6f, 1e-3);
  EXPECT_GT(scene.up.y(), 0.99);  // both cameras have world +y up
}

// The same OPENCV camera through transforms.json and through a COLMAP model: same pinhole camera,
// same undistorted pixels (the undistortion itself is tested in test_import_colmap.cpp).
TEST(NerfstudioImport, DistortionMatchesTheColmapImporter) {
  test::TempDir dir;
  Image image(160, 120, 3);
  for (int i = 0; i < 120; ++i)
    for (int j = 0; j < 160; ++j)
      for (int c = 0; c < 3; ++c) image.at(i, j, c) = float(((i / 8 + j / 8 + c) % 3) / 2.0);
  media::write_png(dir / "ns" / "images" / "view.png", image);
  media::write_png(dir / "cm" / "images" / "view.png", image);
  json j = {{"fl_x", 120.0}, {"fl_y", 118.0}, {"cx", 81.5}, {"cy", 59.0},  {"w", 160},
            {"h", 120},      {"k1", -0.18},   {"k2", 0.03}, {"p1", 0.002}, {"p2", -0.0015}};
  j["frames"] = {{{"file_path", "images/view.png"}, {"transform_matrix", transform({0, 0, 0}, 0)}}};
  test::write_text(dir / "ns" / "transforms.json", j.dump());
  test::write_text(dir / "cm" / "sparse" / "0" / "cameras.txt",
                   "1 OPENCV 160 120 120 118 81.5 59 -0.18 0.03 0.002 -0.0015\n");
  // OpenGL identity = OpenCV rotation diag(1, -1, -1): quaternion (0, 1, 0, 0).
  test::write_text(dir / "cm" / "sparse" / "0" / "images.txt", "1 0 1 0 0 0 0 0 1 view.png\n\n");
  ImportOptions options;
  options.progress = false;
  import_nerfstudio(dir / "ns", dir / "a", options);
  import_colmap(dir / "cm", dir / "b", options);
  const io::Scene a = media::read_scene(dir / "a"), b = media::read_scene(dir / "b");
  EXPECT_LT(std::abs(a.cameras[0].fx - b.cameras[0].fx), 1e-9);
  EXPECT_LT(std::abs(a.cameras[0].cy - b.cameras[0].cy), 1e-9);
  EXPECT_LT((a.cameras[0].world_to_camera - b.cameras[0].world_to_camera).norm(), 1e-12);
  EXPECT_LT(a.cameras[0].fx, 119.0);  // barrel distortion: a wider pinhole view
  const Image ia = media::load_image(a, 0, 0), ib = media::load_image(b, 0, 0);
  EXPECT_EQ(ia.data, ib.data);
}

TEST(NerfstudioImport, AlphaChannelBecomesTheMask) {
  test::TempDir dir;
  Image rgba(kW, kH, 4, 0.5f);
  for (int i = 0; i < kH; ++i)
    for (int x = 0; x < kW; ++x) rgba.at(i, x, 3) = x < kW / 2 ? 1.0f : 0.0f;
  media::write_png(dir / "src" / "r_0.png", rgba);
  json j = {{"camera_angle_x", 1.0}};
  j["frames"] = {{{"file_path", "./r_0"}, {"transform_matrix", transform({0, 0, 4}, 0)}}};
  test::write_text(dir / "src" / "transforms.json", j.dump());
  ImportOptions options;
  options.progress = false;
  import_nerfstudio(dir / "src", dir / "scene", options);
  const io::Scene scene = media::read_scene(dir / "scene");
  const auto mask = media::load_mask(scene, 0, 0);
  ASSERT_TRUE(mask.has_value());
  EXPECT_EQ(mask->at(5, 3), 1.0f);
  EXPECT_EQ(mask->at(5, kW - 3), 0.0f);
  EXPECT_NEAR(media::load_image(scene, 0, 0).at(5, 3, 1), 0.5f, 3e-3);
}

// Dynamic capture: per-frame time, camera identity from "camera" or the folder.
json timed_transforms(const fs::path& src, bool camera_key) {
  json j = {{"camera_angle_x", 2 * std::atan(20.0 / 25.0)}, {"fps", 12.5}};
  j["frames"] = json::array();
  // Listed out of order on purpose.
  for (int k : {2, 0, 1})
    for (int c = 0; c < 2; ++c) {
      const std::string rel = "cam" + std::to_string(c) + "/" + std::to_string(k) + ".png";
      write_gray(src / rel, 0.1f + 0.3f * k + 0.05f * c);
      json f = {{"file_path", rel},
                {"transform_matrix", transform({c == 0 ? 0.0 : 5.0, 0, c == 0 ? 5.0 : 0}, c)},
                {"time", k / 2.0 + (c == 1 ? 1e-9 : 0.0)}};  // rounding noise
      if (camera_key) f["camera"] = c == 0 ? "left" : "right";
      j["frames"].push_back(f);
    }
  return j;
}

TEST(NerfstudioImport, FramesGroupedByTimeAndCamera) {
  for (bool camera_key : {true, false}) {
    test::TempDir dir;
    test::write_text(dir / "src" / "transforms.json",
                     timed_transforms(dir / "src", camera_key).dump());
    const auto r = test::run_cli("import nerfstudio --in " + (dir / "src").string() + " --out " +
                                 (dir / "scene").string() + " --frames 1:2");
    ASSERT_EQ(r.status, 0) << r.err;
    const io::Scene scene = media::read_scene(dir / "scene");
    EXPECT_EQ(scene.num_frames, 2);
    EXPECT_DOUBLE_EQ(scene.fps, 12.5);
    ASSERT_EQ(scene.cameras.size(), 2u);
    EXPECT_EQ(scene.cameras[0].name, camera_key ? "left" : "cam0");
    EXPECT_EQ(scene.cameras[1].name, camera_key ? "right" : "cam1");
    EXPECT_NEAR(scene.cameras[0].fx, 25.0, 1e-9);  // camera_angle_x: 0.5 w / tan(angle / 2)
    EXPECT_NEAR(scene.cameras[0].cx, 20.0, 1e-9);
    for (int c = 0; c < 2; ++c)
      for (int k = 0; k < 2; ++k)  // scene frame k is time (k + 1) / 2
        EXPECT_NEAR(media::load_image(scene, c, k).at(1, 1, 0), 0.1f + 0.3f * (k + 1) + 0.05f * c,
                    2e-3)
            << c << " " << k;
  }
}

class NerfstudioBadInput : public ::testing::Test {
 protected:
  void SetUp() override { j_ = timed_transforms(dir_ / "src", true); }
  void expect_error(std::initializer_list<std::string> fragments) {
    test::write_text(dir_ / "src" / "transforms.json", j_.dump());
    const auto r = test::run_cli("import nerfstudio --in " + (dir_ / "src").string() + " --out " +
                                 (dir_ / "out").string());
    EXPECT_EQ(r.status, 2) << r.err;
    for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << r.err;
    EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out"));
  }
  test::TempDir dir_;
  json j_;
};

TEST_F(NerfstudioBadInput, CameraMissingATime) {
  j_["frames"].erase(j_["frames"].begin() + 3);  // right at time 0
  expect_error({"transforms.json", "camera 'right' has no image at time 0"});
}

// A camera name that would leave the scene folder is refused before anything is written.
TEST_F(NerfstudioBadInput, CameraNameOutsideTheScene) {
  for (const char* name : {"../../escape", "/tmp/abs", ".."}) {
    for (auto& f : j_["frames"])
      if (f["camera"] == "left" || f["camera"] == "../../escape" || f["camera"] == "/tmp/abs")
        f["camera"] = name;
    expect_error({"camera name '", "cannot be a folder name"});
    EXPECT_FALSE(fs::exists(dir_ / "escape"));
  }
}

TEST_F(NerfstudioBadInput, MovingCamera) {
  j_["frames"][2]["transform_matrix"][0][3] = 0.5;
  expect_error({"transforms.json", "camera 'left' moves"});
}

TEST_F(NerfstudioBadInput, NonFiniteMatrix) {
  j_["frames"][1]["transform_matrix"][2][1] = "x";
  expect_error({"transforms.json", "frames[1].transform_matrix[2][1]", "finite"});
}

TEST_F(NerfstudioBadInput, MissingImage) {
  j_["frames"][4]["file_path"] = "cam0/99.png";
  expect_error({"frames[4].file_path", "99.png"});
}

TEST_F(NerfstudioBadInput, MixedTime) {
  j_["frames"][0].erase("time");
  expect_error({"frames[0]", "time"});
}

TEST_F(NerfstudioBadInput, NoFocalLength) {
  j_.erase("camera_angle_x");
  expect_error({"frames[0]", "no focal length"});
}

// A declared size is checked against the image before anything is sized by it (fuzz/: w = 1e10
// overflowed an int; a large one sized the undistortion maps before the image was read).
TEST_F(NerfstudioBadInput, DeclaredImageSizeMustMatchTheImage) {
  for (const auto& [w, h] :
       {std::pair<double, double>{1e10, kH}, {kW, 1e9}, {kW + 1, kH}, {-1, kH}, {kW, 0.5}}) {
    j_["w"] = w;
    j_["h"] = h;
    SCOPED_TRACE(j_.dump());
    expect_error({"transforms.json", "frames[0]", "declares image size", "is 40x30"});
  }
}

// A frame rate beyond core/limits.hpp's is refused naming the key.
TEST_F(NerfstudioBadInput, FpsOutsideTheLimit) {
  for (const double fps : {1e-300, 1e308, -1.0}) {
    j_["fps"] = fps;
    SCOPED_TRACE(j_.dump());
    expect_error({"transforms.json: 'fps' = " + fmt::format("{}", fps), "frames per second"});
  }
}

TEST_F(NerfstudioBadInput, MalformedJson) {
  test::write_text(dir_ / "src" / "transforms.json", "{\"frames\": [");
  const auto r = test::run_cli("import nerfstudio --in " + (dir_ / "src").string() + " --out " +
                               (dir_ / "out").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("malformed JSON"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace retimegs::ingest
