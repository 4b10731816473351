// nerfstudio's camera_path.json: intrinsics from the vertical fov, OpenGL camera-to-world poses
// turned into OpenCV cameras, render_time onto the model's time range, and every malformed value
// refused with the file and the entry's field named.
#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/io/camera_path_json.hpp"
#include "test_util.hpp"

namespace retimegs::io {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

// Row-major OpenGL camera-to-world (x right, y up, z backward) of a camera at `eye` whose view
// (-z) runs along -z world (axes 0) or along -x world (axes 1: right = -z, up = y, back = x).
json opengl_pose(const Eigen::Vector3d& eye, int axes) {
  if (axes == 0) return {1, 0, 0, eye.x(), 0, 1, 0, eye.y(), 0, 0, 1, eye.z(), 0, 0, 0, 1};
  return {0, 0, 1, eye.x(), 0, 1, 0, eye.y(), -1, 0, 0, eye.z(), 0, 0, 0, 1};
}

// A 64x48 path of three cameras at 24 fps with a 60 degree vertical fov, as the viewer writes it.
json sample_path() {
  json j = {{"camera_type", "perspective"},
            {"render_width", 64},
            {"render_height", 48},
            {"fps", 24},
            {"seconds", 0.125},
            {"smoothness_value", 0.5},
            {"keyframes", json::array()}};
  j["camera_path"] = json::array();
  j["camera_path"].push_back({{"camera_to_world", opengl_pose({0, 0, 5}, 0)},
                              {"fov", 60},
                              {"aspect", 64.0 / 48.0},
                              {"render_time", 0.0}});
  j["camera_path"].push_back({{"camera_to_world", opengl_pose({5, 0, 0}, 1)},
                              {"fov", 60},
                              {"aspect", 64.0 / 48.0},
                              {"render_time", 0.25}});
  j["camera_path"].push_back({{"camera_to_world", opengl_pose({0, 0, 5}, 0)},
                              {"fov", 90},
                              {"aspect", 64.0 / 48.0},
                              {"render_time", 1.0}});
  return j;
}

CameraPathFile read(const test::TempDir& dir, const json& j) {
  test::write_text(dir / "camera_path.json", j.dump(2));
  return read_camera_path_json(dir / "camera_path.json");
}

TEST(CameraPathJson, IntrinsicsComeFromTheVerticalFovAndTheRenderSize) {
  test::TempDir dir;
  const CameraPathFile path = read(dir, sample_path());
  ASSERT_EQ(path.frames.size(), 3u);
  EXPECT_DOUBLE_EQ(path.fps, 24);
  EXPECT_TRUE(path.timed);
  const double f60 = 24 / std::tan(std::numbers::pi / 6);  // half height / tan(fov / 2)
  for (int i = 0; i < 3; ++i) {
    const Camera& cam = path.frames[i].camera;
    EXPECT_EQ(cam.width, 64);
    EXPECT_EQ(cam.height, 48);
    EXPECT_NEAR(cam.fy, i == 2 ? 24.0 : f60, 1e-9) << i;
    EXPECT_DOUBLE_EQ(cam.fx, cam.fy);
    EXPECT_DOUBLE_EQ(cam.cx, 32);
    EXPECT_DOUBLE_EQ(cam.cy, 24);
    EXPECT_EQ(cam.name, "camera_path[" + std::to_string(i) + "]");
  }
}

TEST(CameraPathJson, OpenGlPosesProjectAKnownPoint) {
  test::TempDir dir;
  const CameraPathFile path = read(dir, sample_path());
  const double f = path.frames[0].camera.fy;
  // X = (1, 0.5, 0). Camera 0 at (0, 0, 5) looking along -z with y up: right 1, up 0.5 (image
  // y down), depth 5. Camera 1 at (5, 0, 0) looking along -x: right 0, up 0.5, depth 4.
  const Eigen::Vector3d x(1, 0.5, 0);
  const Camera& c0 = path.frames[0].camera;
  const Camera& c1 = path.frames[1].camera;
  EXPECT_NEAR(c0.world_to_cam(x).z(), 5, 1e-12);
  EXPECT_LT((c0.project(x) - Eigen::Vector2d(32 + f / 5, 24 - f * 0.5 / 5)).norm(), 1e-9);
  EXPECT_NEAR(c1.world_to_cam(x).z(), 4, 1e-12);
  EXPECT_LT((c1.project(x) - Eigen::Vector2d(32, 24 - f * 0.5 / 4)).norm(), 1e-9);
  EXPECT_LT((c1.center() - Eigen::Vector3d(5, 0, 0)).norm(), 1e-12);
  EXPECT_NO_THROW(check_rigid(c1.world_to_camera, "converted pose"));

  // Four rows of four read the same as sixteen numbers.
  json rows = sample_path();
  json& m = rows["camera_path"][1]["camera_to_world"];
  m = json::array({json::array({m[0], m[1], m[2], m[3]}), json::array({m[4], m[5], m[6], m[7]}),
                   json::array({m[8], m[9], m[10], m[11]}),
                   json::array({m[12], m[13], m[14], m[15]})});
  EXPECT_EQ(read(dir, rows).frames[1].camera.world_to_camera, c1.world_to_camera);
}

TEST(CameraPathJson, RenderTimeSpansTheModelsTimeRange) {
  test::TempDir dir;
  const CameraPathFile path = read(dir, sample_path());
  const std::vector<double> times = camera_path_times(path, 2.0, 10.0);
  ASSERT_EQ(times.size(), 3u);
  EXPECT_DOUBLE_EQ(times[0], 2.0);
  EXPECT_DOUBLE_EQ(times[1], 4.0);
  EXPECT_DOUBLE_EQ(times[2], 10.0);

  json untimed = sample_path();
  for (auto& e : untimed["camera_path"]) e.erase("render_time");
  const CameraPathFile still = read(dir, untimed);
  EXPECT_FALSE(still.timed);
  EXPECT_FALSE(still.frames[0].render_time.has_value());
  test::expect_error([&] { camera_path_times(still, 0, 1); }, {"camera_path.json", "render_time"});
}

TEST(CameraPathJson, WithoutFpsTheFrameRateIsFramesPerSecond) {
  test::TempDir dir;
  json j = sample_path();
  j.erase("fps");
  j["seconds"] = 2.0;
  EXPECT_DOUBLE_EQ(read(dir, j).fps, 1.5);  // ns-render: len(camera_path) / seconds
}

TEST(CameraPathJson, MalformedValuesNameTheFileAndTheField) {
  test::TempDir dir;
  struct Case {
    std::string what;
    std::function<void(json&)> edit;
    std::vector<std::string> fragments;
  };
  auto entry = [](json& j) -> json& { return j["camera_path"][1]; };
  const std::vector<Case> cases = {
      {"no width", [](json& j) { j.erase("render_width"); }, {"'render_width'"}},
      {"zero height", [](json& j) { j["render_height"] = 0; }, {"render_height", "positive"}},
      {"fractional width", [](json& j) { j["render_width"] = 12.5; }, {"render_width", "12.5"}},
      {"fisheye", [](json& j) { j["camera_type"] = "fisheye"; }, {"camera_type 'fisheye'"}},
      {"equirectangular",
       [](json& j) { j["camera_type"] = "equirectangular"; },
       {"camera_type 'equirectangular'", "perspective"}},
      {"unknown type", [](json& j) { j["camera_type"] = "ortho"; }, {"camera_type 'ortho'"}},
      {"no path", [](json& j) { j.erase("camera_path"); }, {"'camera_path'"}},
      {"empty path", [](json& j) { j["camera_path"] = json::array(); }, {"camera_path", "empty"}},
      {"no frame rate",
       [](json& j) {
         j.erase("fps");
         j.erase("seconds");
       },
       {"'fps'", "'seconds'"}},
      {"negative fps", [](json& j) { j["fps"] = -1; }, {"fps", "-1"}},
      // Limits of core/limits.hpp: a 400-byte file must not ask for 16 GB of pixels.
      {"65536 wide", [](json& j) { j["render_width"] = 65536; }, {"render_width", "16384"}},
      {"a frame in 1e300 s", [](json& j) { j["fps"] = 1e-300; }, {"fps = 1e-300", "[0.01667"}},
      {"a camera 1e308 away",
       [&](json& j) { entry(j)["camera_to_world"][3] = 1e308; },
       {"camera_path[1].camera_to_world[0][3] = 1e+308", "beyond"}},
      {"zero seconds",
       [](json& j) {
         j.erase("fps");
         j["seconds"] = 0;
       },
       {"seconds", "positive"}},
      {"entry not an object", [](json& j) { j["camera_path"][1] = 3; }, {"camera_path[1]"}},
      {"no pose",
       [&](json& j) { entry(j).erase("camera_to_world"); },
       {"camera_path[1]", "'camera_to_world'"}},
      {"15 numbers",
       [&](json& j) { entry(j)["camera_to_world"].erase(15); },
       {"camera_path[1].camera_to_world", "16 numbers"}},
      {"text in the matrix",
       [&](json& j) { entry(j)["camera_to_world"][3] = "5"; },
       {"camera_path[1].camera_to_world[3]", "number"}},
      {"scaled rotation",
       [&](json& j) { entry(j)["camera_to_world"][2] = 2; },
       {"camera_path[1].camera_to_world", "orthonormal"}},
      {"mirrored",
       [&](json& j) {
         entry(j)["camera_to_world"] = opengl_pose({0, 0, 5}, 0);
         entry(j)["camera_to_world"][0] = -1;  // x flipped: orthonormal, determinant -1
       },
       {"camera_path[1].camera_to_world", "determinant"}},
      {"projective row",
       [&](json& j) { entry(j)["camera_to_world"][12] = 0.5; },
       {"camera_path[1].camera_to_world", "last row"}},
      {"no fov", [&](json& j) { entry(j).erase("fov"); }, {"camera_path[1]", "'fov'"}},
      {"zero fov", [&](json& j) { entry(j)["fov"] = 0; }, {"camera_path[1].fov", "(0, 180)"}},
      {"flat fov", [&](json& j) { entry(j)["fov"] = 180; }, {"camera_path[1].fov", "180"}},
      {"null fov", [&](json& j) { entry(j)["fov"] = nullptr; }, {"camera_path[1].fov", "null"}},
      {"negative aspect",
       [&](json& j) { entry(j)["aspect"] = -1; },
       {"camera_path[1].aspect", "positive"}},
      {"late time",
       [&](json& j) { entry(j)["render_time"] = 1.5; },
       {"camera_path[1].render_time", "[0, 1]", "1.5"}},
      {"text time",
       [&](json& j) { entry(j)["render_time"] = "0.5"; },
       {"camera_path[1].render_time", "number"}},
      {"time on some entries",
       [&](json& j) { entry(j).erase("render_time"); },
       {"camera_path[1]", "render_time", "every entry"}},
  };
  for (const Case& c : cases) {
    json j = sample_path();
    c.edit(j);
    SCOPED_TRACE(c.what);
    test::write_text(dir / "camera_path.json", j.dump());
    const std::string message =
        test::message_of([&] { read_camera_path_json(dir / "camera_path.json"); });
    EXPECT_NE(message.find((dir / "camera_path.json").string()), std::string::npos) << message;
    for (const auto& fragment : c.fragments)
      EXPECT_NE(message.find(fragment), std::string::npos) << message << " / " << fragment;
  }
}

TEST(CameraPathJson, NonFiniteNumbersAndBadJsonAreRefused) {
  test::TempDir dir;
  // JSON has no NaN or Inf; an overflowing literal, the one way to write one, is refused by the
  // parser with the file and the literal named.
  std::string text = sample_path().dump();
  const std::string fov = "\"fov\":90";
  ASSERT_NE(text.find(fov), std::string::npos);
  text.replace(text.find(fov), fov.size(), "\"fov\":1e999");
  test::write_text(dir / "inf.json", text);
  test::expect_error([&] { read_camera_path_json(dir / "inf.json"); }, {"inf.json", "1e999"});

  test::write_text(dir / "cut.json", sample_path().dump().substr(0, 40));
  test::expect_error([&] { read_camera_path_json(dir / "cut.json"); }, {"cut.json", "JSON"});
  test::expect_error([&] { read_camera_path_json(dir / "none.json"); }, {"none.json"});
  test::write_text(dir / "list.json", "[1, 2]");
  test::expect_error([&] { read_camera_path_json(dir / "list.json"); }, {"list.json", "object"});
}

}  // namespace
}  // namespace retimegs::io
