// `retimegs render --camera-path camera_path.json`: nerfstudio's per-frame cameras rendered at the
// file's size and frame rate, render_time spanning the model's time range; a camera of the path
// at a scene camera's pose renders what `render --camera` renders there; bad files are refused
// with one line and status 2.
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "moving_model_scene.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/model/model_file.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

// The shared 4D fixture and the start of every render command on it.
struct Fixture : test::MovingModelScene {
  std::string base;  // "render --model M --scene S"
  explicit Fixture(const test::TempDir& dir)
      : MovingModelScene(dir.path()),
        base("render --model " + model_path.string() + " --scene " + scene.root.string()) {}
};

// The camera_to_world entry (16 numbers, row-major, OpenGL axes) of an OpenCV camera.
json opengl_camera_to_world(const Camera& cam) {
  Eigen::Matrix4d c2w = cam.world_to_camera.inverse();
  c2w.col(1) *= -1;
  c2w.col(2) *= -1;
  json out = json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.push_back(c2w(r, c));
  return out;
}

// A path file of the given size and frame rate; one entry per camera, with render_time when
// `times` is not empty.
json path_file(const std::vector<Camera>& cameras, const std::vector<double>& times, int width,
               int height, double fps) {
  json j = {{"camera_type", "perspective"},
            {"render_width", width},
            {"render_height", height},
            {"fps", fps},
            {"seconds", cameras.size() / fps}};
  j["camera_path"] = json::array();
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    // small_camera: fy = 60 over a 48-pixel height.
    json e = {{"camera_to_world", opengl_camera_to_world(cameras[i])},
              {"fov", 2 * std::atan(24.0 / 60.0) * 180 / std::numbers::pi},
              {"aspect", double(width) / height}};
    if (!times.empty()) e["render_time"] = times[i];
    j["camera_path"].push_back(e);
  }
  return j;
}

double mean_abs_diff(const Image& a, const Image& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i) sum += std::abs(a.data[i] - b.data[i]);
  return sum / double(a.data.size());
}

double max_abs_diff(const Image& a, const Image& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i)
    m = std::max(m, double(std::abs(a.data[i] - b.data[i])));
  return m;
}

void run_ok(const std::string& args) {
  const auto r = test::run_cli(args);
  ASSERT_EQ(r.status, 0) << args << "\n" << r.err;
}

// render_time 0, 0.5, 1 is the model's frames 0, 4 and 8: each frame of the path equals
// `render --camera` of the scene camera at its pose and that time, within 8-bit rounding.
TEST(CameraPathCli, APathAtSceneCamerasRendersWhatThoseCamerasRender) {
  test::TempDir dir;
  const Fixture f(dir);
  const Camera &cam0 = f.scene.cameras[0], &cam1 = f.scene.cameras[1];
  test::write_text(dir / "path.json",
                   path_file({cam1, cam0, cam0}, {0.0, 0.5, 1.0}, 64, 48, 24).dump(2));
  run_ok(f.base + " --camera-path " + (dir / "path.json").string() + " --out " +
         (dir / "frames").string());
  const char* expected[3][2] = {{"cam01", "0"}, {"cam00", "4"}, {"cam00", "8"}};
  std::vector<Image> frames;
  for (int i = 0; i < 3; ++i) {
    const fs::path single = dir / ("single" + std::to_string(i) + ".png");
    run_ok(f.base + " --camera " + expected[i][0] + " --time " + expected[i][1] + " --out " +
           single.string());
    frames.push_back(media::read_image(dir / "frames" / fmt::format("{:05d}.png", i)));
    const Image reference = media::read_image(single);
    ASSERT_EQ(frames[i].width, 64);
    ASSERT_EQ(frames[i].height, 48);
    EXPECT_LE(max_abs_diff(frames[i], reference), 1.0 / 255 + 1e-6) << i;
  }
  EXPECT_FALSE(fs::exists(dir / "frames" / "00003.png"));
  // The frames at times 4 and 8 differ: the comparison above sees time, not just the pose.
  EXPECT_GT(mean_abs_diff(frames[1], frames[2]), 0.01);
}

// Without render_time, --time T holds one time (bullet time along the path); the images take the
// file's size, a video its frame rate.
TEST(CameraPathCli, FixedTimeTakesTheFilesSizeAndFrameRate) {
  test::TempDir dir;
  const Fixture f(dir);
  std::vector<Camera> cameras;
  for (double s : {0.0, 0.5, 1.0}) {
    Camera c = test::small_camera("c", {2.0 * s - 1.0, -0.5, -4.0});
    cameras.push_back(c);
  }
  test::write_text(dir / "path.json", path_file(cameras, {}, 80, 40, 12).dump());
  const std::string path = " --camera-path " + (dir / "path.json").string();
  run_ok(f.base + path + " --time 3.5 --out " + (dir / "frames").string());
  for (int i = 0; i < 3; ++i) {
    const Image image = media::read_image(dir / "frames" / fmt::format("{:05d}.png", i));
    EXPECT_EQ(image.width, 80);
    EXPECT_EQ(image.height, 40);
  }
  EXPECT_FALSE(fs::exists(dir / "frames" / "00003.png"));

  run_ok(f.base + path + " --time 3.5 --out " + (dir / "clip.mp4").string());
  cv::VideoCapture video((dir / "clip.mp4").string());
  ASSERT_TRUE(video.isOpened());
  EXPECT_EQ(int(video.get(cv::CAP_PROP_FRAME_COUNT)), 3);
  EXPECT_NEAR(video.get(cv::CAP_PROP_FPS), 12.0, 1e-3);

  // No render_time and no --time: the option is named.
  const auto r = test::run_cli(f.base + path + " --out " + (dir / "none").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--time"), std::string::npos) << r.err;
  EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
  EXPECT_FALSE(fs::exists(dir / "none"));
}

TEST(CameraPathCli, BadFilesExitTwoWithOneLine) {
  test::TempDir dir;
  const Fixture f(dir);
  const Camera& cam0 = f.scene.cameras[0];
  json bad_fov = path_file({cam0, cam0}, {0.0, 1.0}, 64, 48, 24);
  bad_fov["camera_path"][1]["fov"] = 200;
  json fisheye = path_file({cam0}, {0.5}, 64, 48, 24);
  fisheye["camera_type"] = "fisheye";
  struct Case {
    std::string name, text, fragment;
  };
  for (const Case& c : {Case{"fov.json", bad_fov.dump(), "camera_path[1].fov"},
                        Case{"fisheye.json", fisheye.dump(), "camera_type 'fisheye'"},
                        Case{"cut.json", bad_fov.dump().substr(0, 30), "cut.json"}}) {
    test::write_text(dir / c.name, c.text);
    const auto r = test::run_cli(f.base + " --camera-path " + (dir / c.name).string() + " --out " +
                                 (dir / "out").string());
    EXPECT_EQ(r.status, 2) << c.name;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.name), std::string::npos) << r.err;
    EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out")) << c.name;
  }
  // --camera-path is a camera choice and a time choice of its own.
  test::write_text(dir / "ok.json", path_file({cam0}, {0.5}, 64, 48, 24).dump());
  for (const std::string other : {" --camera cam00", " --slowmo 2", " --times 0:1:1"}) {
    const auto r = test::run_cli(f.base + " --camera-path " + (dir / "ok.json").string() + other +
                                 " --out " + (dir / "out").string());
    EXPECT_EQ(r.status, 2) << other;
    EXPECT_FALSE(fs::exists(dir / "out")) << other;
  }
}

}  // namespace
}  // namespace retimegs
