#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "retimegs/ingest/import.hpp"
#include "retimegs/io/npy.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;

constexpr int kWidth = 64, kHeight = 48, kFrames = 5;
constexpr double kFps = 25.0;

// The gray level of source frame k (every pixel), so that frame selection can be checked.
int gray(int k) {
  return 40 + 35 * k;
}

void write_video(const fs::path& path, int frames, double fps = kFps) {
  cv::VideoWriter writer(path.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('m', 'p', '4', 'v'),
                         fps, cv::Size(kWidth, kHeight));
  ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot encode mp4v here";
  for (int k = 0; k < frames; ++k)
    writer.write(cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(gray(k), gray(k), gray(k))));
}

// Three LLFF rows, written by hand from the LLFF convention: the 3x3 block's columns are the
// camera's (down, right, back) axes in world space, then the centre, then (h, w, f). The poses
// claim a 128x96 image with f = 100; the videos are 64x48, so the importer must halve f.
//   cam00: centre (0, 0, 5), looking along -z: down (0,-1,0), right (1,0,0), back (0,0,1).
//   cam01: centre (5, 0, 0), looking along -x: down (0,-1,0), right (0,0,-1), back (1,0,0).
//   cam02: centre (0, 4, 0), looking along -y: down (0,0,1), right (1,0,0), back (0,1,0).
std::vector<float> llff_rows() {
  const double rows[3][3][4] = {
      {{0, 1, 0, 0}, {-1, 0, 0, 0}, {0, 0, 1, 5}},
      {{0, 0, 1, 5}, {-1, 0, 0, 0}, {0, -1, 0, 0}},
      {{0, 1, 0, 0}, {0, 0, 1, 4}, {1, 0, 0, 0}},
  };
  const double hwf[3] = {96, 128, 100};
  std::vector<float> v;
  for (const auto& m : rows) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) v.push_back(float(m[r][c]));
      v.push_back(float(hwf[r]));
    }
    v.push_back(0.5f), v.push_back(20.0f);  // near, far
  }
  return v;
}

void make_source(const fs::path& dir, int cameras = 3) {
  fs::create_directories(dir);
  io::write_npy(dir / "poses_bounds.npy", {3, 17}, llff_rows());
  for (int c = 0; c < cameras; ++c)
    write_video(dir / ("cam0" + std::to_string(c) + ".mp4"), kFrames);
}

TEST(N3dvImport, LlffPosesProjectAKnownPointToTheExpectedPixels) {
  test::TempDir dir;
  make_source(dir / "src");
  ImportOptions options;
  options.progress = false;
  import_n3dv(dir / "src", dir / "scene", options);
  const io::Scene scene = media::read_scene(dir / "scene");  // every image present with its size
  ASSERT_EQ(scene.cameras.size(), 3u);
  EXPECT_EQ(scene.num_frames, kFrames);
  EXPECT_NEAR(scene.fps, kFps, 1e-6);
  EXPECT_EQ(scene.calibration, io::CalibrationSource::kLab);  // the dataset's own
  for (int c = 0; c < 3; ++c) {
    const Camera& cam = scene.cameras[c];
    EXPECT_EQ(cam.name, "cam0" + std::to_string(c));
    EXPECT_EQ(cam.split, c == 0 ? Split::kTest : Split::kTrain) << cam.name;
    EXPECT_EQ(cam.width, kWidth);
    EXPECT_EQ(cam.height, kHeight);
    EXPECT_NEAR(cam.fx, 50.0, 1e-9);  // f = 100 for 128 px wide, video is 64 wide
    EXPECT_NEAR(cam.cx, 32.0, 1e-9);
    EXPECT_NEAR(cam.cy, 24.0, 1e-9);
  }
  // X = (1, 0.5, 0), by hand:
  //   cam00: relative (1, 0.5, -5): right 1, down -0.5, depth 5 -> (32 + 50/5, 24 - 25/5).
  //   cam01: relative (-4, 0.5, 0): right 0, down -0.5, depth 4 -> (32, 24 - 25/4).
  //   cam02: relative (1, -3.5, 0): right 1, down 0, depth 3.5 -> (32 + 50/3.5, 24).
  const Eigen::Vector3d x(1, 0.5, 0);
  const Eigen::Vector2d expected[3] = {{42, 19}, {32, 24 - 6.25}, {32 + 50 / 3.5, 24}};
  const double depth[3] = {5, 4, 3.5};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(scene.cameras[c].world_to_cam(x).z(), depth[c], 1e-6) << c;
    EXPECT_LT((scene.cameras[c].project(x) - expected[c]).norm(), 1e-5)
        << c << ": " << scene.cameras[c].project(x).transpose();
  }
  // Up: the mean of the cameras' -y axes (0,1,0), (0,1,0), (0,0,-1).
  EXPECT_GT(scene.up.y(), 0.8);
  // Frame k of the scene is video frame k.
  for (int k : {0, 3}) {
    const Image image = media::load_image(scene, 1, k);
    EXPECT_NEAR(image.at(20, 30, 1) * 255, gray(k), 4) << k;
  }
}

TEST(N3dvImport, FrameRangeAndDownscale) {
  test::TempDir dir;
  make_source(dir / "src");
  const auto r = test::run_cli("import n3dv --in " + (dir / "src").string() + " --out " +
                               (dir / "scene").string() + " --frames 1:3 --downscale 2");
  ASSERT_EQ(r.status, 0) << r.err;
  const io::Scene scene = media::read_scene(dir / "scene");
  EXPECT_EQ(scene.num_frames, 3);
  EXPECT_EQ(scene.cameras[2].width, kWidth / 2);
  EXPECT_EQ(scene.cameras[2].height, kHeight / 2);
  EXPECT_NEAR(scene.cameras[2].fx, 25.0, 1e-9);
  const Eigen::Vector3d x(1, 0.5, 0);
  EXPECT_LT((scene.cameras[2].project(x) - Eigen::Vector2d(16 + 25 / 3.5, 12)).norm(), 1e-5);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(media::load_image(scene, 2, k).at(10, 10, 0) * 255, gray(k + 1), 4) << k;
}

// Bad inputs: one line naming the file, exit status 2, nothing written.
class N3dvBadInput : public ::testing::Test {
 protected:
  void SetUp() override { make_source(dir_ / "src"); }
  void expect_error(std::initializer_list<std::string> fragments, const std::string& extra = "") {
    test::expect_import_refused("n3dv", dir_.path(), fragments, extra);
  }
  test::TempDir dir_;
};

TEST_F(N3dvBadInput, CameraCountMismatch) {
  fs::remove(dir_ / "src" / "cam02.mp4");
  expect_error({"2 camera videos", "poses_bounds.npy", "3 pose rows"});
}

TEST_F(N3dvBadInput, WrongNpyShape) {
  std::vector<float> v = llff_rows();
  v.resize(3 * 15);
  io::write_npy(dir_ / "src" / "poses_bounds.npy", {3, 15}, v);
  expect_error({"poses_bounds.npy", "shape [N, 17]", "[3, 15]"});
}

TEST_F(N3dvBadInput, UndecodableVideo) {
  test::write_text(dir_ / "src" / "cam01.mp4", "this is not a video");
  expect_error({"cam01.mp4", "video"});
}

// The scene's frame rate is the videos': one beyond core/limits.hpp's is refused naming the video.
TEST_F(N3dvBadInput, VideoFrameRateOutsideTheLimit) {
  write_video(dir_ / "src" / "cam00.mp4", kFrames, 50000);
  expect_error({"cam00.mp4: the video's frame rate = 50000", "frames per second"});
}

TEST_F(N3dvBadInput, NonRigidPose) {
  std::vector<float> v = llff_rows();
  v[17 + 0] = 0.5f;  // row 1, matrix [0][0]
  io::write_npy(dir_ / "src" / "poses_bounds.npy", {3, 17}, v);
  expect_error({"poses_bounds.npy", "row 1", "cam01.mp4"});
}

TEST_F(N3dvBadInput, NonFiniteValue) {
  std::vector<float> v = llff_rows();
  v[2 * 17 + 16] = std::numeric_limits<float>::quiet_NaN();
  io::write_npy(dir_ / "src" / "poses_bounds.npy", {3, 17}, v);
  expect_error({"poses_bounds.npy", "[2][16]", "not finite"});
}

TEST_F(N3dvBadInput, FrameRangeOutside) {
  expect_error({"--frames", "0:4"}, " --frames 2:9");
}

}  // namespace
}  // namespace retimegs::ingest
