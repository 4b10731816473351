// `import videos`: a user's capture (videos / image folders) with a COLMAP model or a rig file.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "retimegs/core/psnr.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/ingest/rig_file.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/rig_file.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;

constexpr int kWidth = 64, kHeight = 48, kFrames = 6;

// Three cameras around the origin, each with its own intrinsics.
std::vector<Camera> rig() {
  std::vector<Camera> cams = {test::small_camera("cam00", {3, -1, -4}),
                              test::small_camera("cam01", {-3, -1.5, -4}),
                              test::small_camera("cam02", {0.5, -3, -4.5})};
  cams[1].fx = 58.5, cams[1].fy = 59.25;
  cams[2].cx = 31.25, cams[2].cy = 23.5;
  return cams;
}

// Source frame `frame` of camera `camera`: a smooth texture (so that lossy codecs stay close)
// whose brightness rises 20 levels a frame (so that a wrong frame is far off). 8-bit BGR.
cv::Mat source_frame(int camera, int frame) {
  cv::Mat m(kHeight, kWidth, CV_8UC3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      for (int ch = 0; ch < 3; ++ch)
        m.at<cv::Vec3b>(y, x)[ch] = cv::saturate_cast<uchar>(
            100 + 50 * std::sin(0.35 * x + 0.9 * camera + ch) * std::cos(0.3 * y + 0.5 * ch) +
            20 * frame);
  return m;
}

Image source_image(int camera, int frame) {
  cv::Mat rgb;
  cv::cvtColor(source_frame(camera, frame), rgb, cv::COLOR_BGR2RGB);
  Image out(kWidth, kHeight, 3);
  for (std::size_t i = 0; i < out.data.size(); ++i) out.data[i] = rgb.data[i] / 255.0f;
  return out;
}

void write_folder(const fs::path& dir, int camera, int frames = kFrames) {
  fs::create_directories(dir);
  for (int k = 0; k < frames; ++k)
    ASSERT_TRUE(
        cv::imwrite((dir / fmt::format("{:04d}.png", k)).string(), source_frame(camera, k)));
}

// FFV1 (lossless) in .mkv, MJPG (lossy) in .avi: both in Debian's FFmpeg.
void write_video(const fs::path& path, int camera, double fps, int frames = kFrames) {
  const int fourcc = path.extension() == ".avi" ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                                                : cv::VideoWriter::fourcc('F', 'F', 'V', '1');
  fs::create_directories(path.parent_path());
  cv::VideoWriter writer(path.string(), cv::CAP_FFMPEG, fourcc, fps, cv::Size(kWidth, kHeight));
  ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot encode " << path;
  for (int k = 0; k < frames; ++k) writer.write(source_frame(camera, k));
}

// The calibration as a COLMAP model: PINHOLE cameras of `width` x `height` (the footage's size
// times a factor), one image per camera named <camera>.png.
io::ColmapModel colmap_model(const std::vector<Camera>& cams, double scale = 1.0) {
  io::ColmapModel m;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    const Camera& cam = cams[c];
    const auto id = std::uint32_t(c + 1);
    m.cameras.push_back({id,
                         "PINHOLE",
                         int(std::lround(cam.width * scale)),
                         int(std::lround(cam.height * scale)),
                         {cam.fx * scale, cam.fy * scale, cam.cx * scale, cam.cy * scale}});
    m.images.push_back(
        io::ColmapImage::from_world_to_camera(id + 10, id, cam.name + ".png", cam.world_to_camera));
  }
  return m;
}

std::string numbers(const double* v, int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += fmt::format("{}{:.17g}", i ? ", " : "", v[i]);
  return s;
}

// A rig YAML, map form; K as an !!opencv-matrix, R as 9 numbers. `extra[c]` is appended to
// camera c's entry (distortion, size, a broken field).
std::string rig_yaml(const std::vector<Camera>& cams, const std::vector<std::string>& extra = {}) {
  std::string s = "# rig\ncameras:\n";
  for (std::size_t c = 0; c < cams.size(); ++c) {
    const Camera& cam = cams[c];
    // OpenCV's K: the top-left pixel's centre at (0, 0), half a pixel from the scene format's.
    const double k[9] = {cam.fx, 0, cam.cx - 0.5, 0, cam.fy, cam.cy - 0.5, 0, 0, 1};
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> r = cam.rotation();
    const Eigen::Vector3d t = cam.translation();
    s += fmt::format(
        "  {}:\n    K: !!opencv-matrix\n      rows: 3\n      cols: 3\n      dt: d\n"
        "      data: [{}]\n    R: [{}]\n    t: [{}]\n",
        cam.name, numbers(k, 9), numbers(r.data(), 9), numbers(t.data(), 3));
    if (c < extra.size()) s += extra[c];
  }
  return s;
}

// The same rig as JSON, sequence form; K and R nested 3x3, with distortion `dist` on every camera.
std::string rig_json(const std::vector<Camera>& cams, const std::string& dist = "[]") {
  std::string s = "{\n  \"cameras\": [\n";
  for (std::size_t c = 0; c < cams.size(); ++c) {
    const Camera& cam = cams[c];
    const Eigen::Matrix3d r = cam.rotation();
    const Eigen::Vector3d t = cam.translation();
    auto row = [&](int i) {
      return fmt::format("[{:.17g}, {:.17g}, {:.17g}]", r(i, 0), r(i, 1), r(i, 2));
    };
    s += fmt::format(
        "    {{\"name\": \"{}\", \"camera_matrix\": [[{:.17g}, 0, {:.17g}], [0, {:.17g}, {:.17g}], "
        "[0, 0, 1]],\n     \"distortion_coefficients\": {}, \"R\": [{}, {}, {}], \"tvec\": "
        "[{}]}}{}\n",
        cam.name, cam.fx, cam.cx - 0.5, cam.fy, cam.cy - 0.5, dist, row(0), row(1), row(2),
        numbers(t.data(), 3), c + 1 < cams.size() ? "," : "");
  }
  return s + "  ]\n}\n";
}

ImportOptions quiet() {
  ImportOptions options;
  options.progress = false;
  return options;
}

VideosOptions calib(const fs::path& path) {
  VideosOptions v;
  v.calibration = path;
  return v;
}

void expect_same_camera(const Camera& got, const Camera& want) {
  EXPECT_EQ(got.name, want.name);
  EXPECT_EQ(got.width, want.width);
  EXPECT_EQ(got.height, want.height);
  EXPECT_EQ(got.fx, want.fx) << got.name;
  EXPECT_EQ(got.fy, want.fy) << got.name;
  EXPECT_EQ(got.cx, want.cx) << got.name;
  EXPECT_EQ(got.cy, want.cy) << got.name;
  EXPECT_LT((got.world_to_camera - want.world_to_camera).cwiseAbs().maxCoeff(), 1e-15)
      << got.name << "\n"
      << got.world_to_camera << "\n"
      << want.world_to_camera;
}

// Image of scene camera c, frame j is source frame k of camera c: bit for bit (PNG footage, a
// lossless video) or within `min_psnr` dB (a lossy video).
void expect_frame(const io::Scene& scene, int c, int j, int k, double min_psnr = INFINITY) {
  const Image image = media::load_image(scene, c, j), source = source_image(c, k);
  if (!std::isinf(min_psnr)) {
    EXPECT_GT(psnr(image, source), min_psnr) << "camera " << c << " frame " << j << " vs " << k;
    return;
  }
  int differ = 0;
  for (std::size_t i = 0; i < image.data.size(); ++i)
    differ += std::lround(image.data[i] * 255) != std::lround(source.data[i] * 255);
  EXPECT_EQ(differ, 0) << "camera " << c << " frame " << j << " vs source frame " << k;
}

// detail::mean_camera_up, by hand: the normalised mean of the cameras' -y axes.
Eigen::Vector3d mean_up(const std::vector<Camera>& cams) {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (const Camera& cam : cams) up -= cam.rotation().row(1).transpose();
  return up.normalized();
}

TEST(VideosImport, PngFoldersWithColmapModelKeepTheCalibrationAndThePixels) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c);
  // The model lies inside the footage folder: a folder without images is not a camera.
  const io::ColmapModel model = colmap_model(cams);
  io::write_colmap_model_txt(model, dir / "src" / "sparse" / "0");
  const VideosReport r = import_videos(dir / "src", dir / "scene", quiet(), calib(dir / "src"));
  const io::Scene scene = media::read_scene(dir / "scene");
  ASSERT_EQ(scene.cameras.size(), 3u);
  EXPECT_EQ(scene.num_frames, kFrames);
  EXPECT_EQ(scene.fps, 30.0);                                  // image folders: the default
  EXPECT_EQ(scene.calibration, io::CalibrationSource::kUser);  // the user's COLMAP model
  EXPECT_NE(r.fps_source.find("default"), std::string::npos) << r.fps_source;
  EXPECT_NE(r.calibration.find("COLMAP"), std::string::npos) << r.calibration;
  EXPECT_EQ(r.undistorted, 0);
  EXPECT_TRUE(r.without_footage.empty());
  for (int c = 0; c < 3; ++c) {
    Camera want = cams[c];
    want.world_to_camera = model.images[c].world_to_camera();  // COLMAP's quaternion
    expect_same_camera(scene.cameras[c], want);
    EXPECT_LT((scene.cameras[c].world_to_camera - cams[c].world_to_camera).norm(), 1e-12);
    EXPECT_EQ(scene.cameras[c].split, Split::kTrain);
    for (int k = 0; k < kFrames; ++k) expect_frame(scene, c, k, k);
  }
  EXPECT_LT((scene.up - mean_up(cams)).norm(), 1e-9);
  EXPECT_FALSE(fs::exists(dir / "scene" / "masks"));
}

TEST(VideosImport, RigYamlAndJsonGiveTheCalibrationExactly) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c, 2);
  test::write_text(dir / "rig.yaml", rig_yaml(cams));
  test::write_text(dir / "rig.json", rig_json(cams, "[0, 0, 0, 0, 0]"));
  for (const char* file : {"rig.yaml", "rig.json"}) {
    const fs::path out = dir / (std::string(file) + ".scene");
    const VideosReport r = import_videos(dir / "src", out, quiet(), calib(dir / file));
    EXPECT_NE(r.calibration.find(file), std::string::npos) << r.calibration;
    EXPECT_EQ(r.undistorted, 0) << file;  // zero coefficients: a pinhole
    const io::Scene scene = media::read_scene(out);
    EXPECT_EQ(scene.calibration, io::CalibrationSource::kUser) << file;  // the user's rig file
    ASSERT_EQ(scene.cameras.size(), 3u);
    for (int c = 0; c < 3; ++c) {
      expect_same_camera(scene.cameras[c], cams[c]);
      expect_frame(scene, c, 1, 1);
    }
  }
}

// io::write_rig_file (calibration_true.json beside a perturbed scene) writes what `import videos
// --calib` and read_rig_cameras read.
TEST(VideosImport, AWrittenRigFileGivesTheCamerasBack) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c, 2);
  io::write_rig_file(dir / "calibration_true.json", cams);
  const std::vector<Camera> read = read_rig_cameras(dir / "calibration_true.json");
  ASSERT_EQ(read.size(), 3u);
  for (int c = 0; c < 3; ++c) expect_same_camera(read[c], cams[c]);
  import_videos(dir / "src", dir / "scene", quiet(), calib(dir / "calibration_true.json"));
  const io::Scene scene = media::read_scene(dir / "scene");
  ASSERT_EQ(scene.cameras.size(), 3u);
  for (int c = 0; c < 3; ++c) expect_same_camera(scene.cameras[c], cams[c]);

  // Values of every digit come back to a rounding.
  std::vector<Camera> odd = cams;
  odd[0].fx = 61.234567890123456, odd[0].cx = 31.987654321098765;
  odd[0].world_to_camera.topRightCorner<3, 1>() += Eigen::Vector3d(1e-7, -3.3e-5, 0.123456789);
  io::write_rig_file(dir / "odd.json", odd);
  const Camera back = read_rig_cameras(dir / "odd.json")[0];
  EXPECT_NEAR(back.fx, odd[0].fx, 1e-13);
  EXPECT_NEAR(back.cx, odd[0].cx, 1e-13);
  EXPECT_LT((back.world_to_camera - odd[0].world_to_camera).cwiseAbs().maxCoeff(), 1e-15);

  // A rig with distortion or without a size is no scene camera as it is.
  test::write_text(dir / "distorted.json", rig_json(cams, "[0.1, 0, 0, 0]"));
  try {
    read_rig_cameras(dir / "distorted.json");
    FAIL() << "no error";
  } catch (const Error& e) {
    for (const std::string f : {"distorted.json", "'cam00'", "distortion"})
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
  }
  test::write_text(dir / "sizeless.json", rig_json(cams));
  EXPECT_THROW(read_rig_cameras(dir / "sizeless.json"), Error);
}

TEST(VideosImport, RodriguesVectorAndImageSizeScaleTheIntrinsics) {
  test::TempDir dir;
  const auto cams = rig();
  write_folder(dir / "src" / "cam01", 1, 1);
  // Rotation by 90 degrees about z as rvec; K given for a 128x96 image: halved for the footage.
  // (63.5, 47.5) is that image's centre in OpenCV's pixel convention, (64, 48) in the scene's.
  test::write_text(dir / "rig.yml",
                   "cameras:\n  - name: cam01\n    K: [100, 0, 63.5, 0, 120, 47.5, 0, 0, 1]\n"
                   "    rvec: [0, 0, 1.5707963267948966]\n    T: [0.5, 0, 3]\n"
                   "    image_size: [128, 96]\n");
  import_videos(dir / "src", dir / "scene", quiet(), calib(dir / "rig.yml"));
  const Camera cam = media::read_scene(dir / "scene").cameras[0];
  EXPECT_EQ(cam.width, kWidth);
  EXPECT_DOUBLE_EQ(cam.fx, 50);
  EXPECT_DOUBLE_EQ(cam.fy, 60);
  EXPECT_DOUBLE_EQ(cam.cx, 32);
  EXPECT_DOUBLE_EQ(cam.cy, 24);
  // (1, 0, 0) -> R: (0, 1, 0), + t: (0.5, 1, 3).
  EXPECT_LT((cam.world_to_cam({1, 0, 0}) - Eigen::Vector3d(0.5, 1, 3)).norm(), 1e-12);
}

TEST(VideosImport, VideosDecodeCloseToTheSourceWithTheirFrameRate) {
  test::TempDir dir;
  const auto cams = rig();
  write_video(dir / "src" / "cam00.mkv", 0, 25);  // lossless
  write_video(dir / "src" / "cam01.avi", 1, 25);  // MJPG
  write_video(dir / "src" / "cam02.mkv", 2, 25);
  // A COLMAP model of twice the footage's size: the intrinsics follow the footage.
  io::write_colmap_model_bin(colmap_model(cams, 2.0), dir / "model");
  const VideosReport r = import_videos(dir / "src", dir / "scene", quiet(), calib(dir / "model"));
  EXPECT_EQ(r.fps_source, "from the videos");
  const io::Scene scene = media::read_scene(dir / "scene");
  EXPECT_NEAR(scene.fps, 25.0, 1e-9);
  EXPECT_EQ(scene.num_frames, kFrames);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(scene.cameras[c].width, kWidth);
    EXPECT_NEAR(scene.cameras[c].fx, cams[c].fx, 1e-12);
    EXPECT_NEAR(scene.cameras[c].cy, cams[c].cy, 1e-12);
    for (int k = 0; k < kFrames; ++k) expect_frame(scene, c, k, k, c == 1 ? 30.0 : INFINITY);
  }
}

TEST(VideosImport, FpsOptionOverridesAndIsReported) {
  test::TempDir dir;
  const auto cams = rig();
  write_video(dir / "src" / "cam00.mkv", 0, 24, 2);
  write_folder(dir / "src" / "cam01", 1, 2);  // a folder beside a video takes its rate
  test::write_text(dir / "rig.yaml", rig_yaml(cams));
  VideosOptions v = calib(dir / "rig.yaml");
  VideosReport r = import_videos(dir / "src", dir / "a", quiet(), v);
  EXPECT_NEAR(media::read_scene(dir / "a").fps, 24.0, 1e-9);
  EXPECT_EQ(r.without_footage, std::vector<std::string>{"cam02"});
  v.fps = 12.5;
  r = import_videos(dir / "src", dir / "b", quiet(), v);
  EXPECT_EQ(media::read_scene(dir / "b").fps, 12.5);
  EXPECT_NE(r.fps_source.find("the videos say 24"), std::string::npos) << r.fps_source;
}

TEST(VideosImport, OffsetsShiftEachCameraAndFramesSelectWithin) {
  test::TempDir dir;
  const auto cams = rig();
  write_folder(dir / "src" / "cam00", 0);
  write_video(dir / "src" / "cam01.mkv", 1, 30);  // decoding skips the offset frames
  write_folder(dir / "src" / "cam02", 2);
  io::write_colmap_model_txt(colmap_model(cams), dir / "model");
  VideosOptions v = calib(dir / "model");
  // k + 2 for cam01, k - 1 for cam02: k runs 1..3 (cam02 has no source frame -1, cam01 no 6).
  v.offsets = {{"cam01", 2}, {"cam02", -1}};
  VideosReport r = import_videos(dir / "src", dir / "a", quiet(), v);
  EXPECT_EQ(r.first_frame, 1);
  io::Scene scene = media::read_scene(dir / "a");
  ASSERT_EQ(scene.num_frames, 3);
  for (int j = 0; j < 3; ++j) {
    expect_frame(scene, 0, j, 1 + j);
    expect_frame(scene, 1, j, 3 + j);
    expect_frame(scene, 2, j, j);
  }
  ImportOptions options = quiet();
  options.first_frame = 1, options.last_frame = 2;
  r = import_videos(dir / "src", dir / "b", options, v);
  EXPECT_EQ(r.first_frame, 2);
  // scene.json records each camera's source frames: k + offset over the scene's frames 1..2 of k.
  const nlohmann::json cameras =
      nlohmann::json::parse(test::read_text(dir / "b" / "scene.json"))["cameras"];
  EXPECT_EQ(cameras[0]["source"], nlohmann::json::parse(R"({"file": "cam00", "first_frame": 2,
                                    "last_frame": 3, "offset": 0})"));
  EXPECT_EQ(cameras[1]["source"], nlohmann::json::parse(R"({"file": "cam01.mkv", "first_frame": 4,
                                    "last_frame": 5, "offset": 2, "fps": 30.0})"));
  EXPECT_EQ(cameras[2]["source"]["first_frame"], 1);
  EXPECT_EQ(cameras[2]["source"]["offset"], -1);
  scene = media::read_scene(dir / "b");
  ASSERT_EQ(scene.num_frames, 2);
  expect_frame(scene, 0, 0, 2);
  expect_frame(scene, 1, 1, 5);
  expect_frame(scene, 2, 1, 2);
}

TEST(VideosImport, TestCamerasGetSplitTest) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c, 1);
  test::write_text(dir / "rig.yaml", rig_yaml(cams));
  VideosOptions v = calib(dir / "rig.yaml");
  v.test_cameras = {"cam02", "cam00"};
  const VideosReport r = import_videos(dir / "src", dir / "scene", quiet(), v);
  EXPECT_EQ(r.test_cameras, 2);
  const io::Scene scene = media::read_scene(dir / "scene");
  EXPECT_EQ(scene.cameras[0].split, Split::kTest);
  EXPECT_EQ(scene.cameras[1].split, Split::kTrain);
  EXPECT_EQ(scene.cameras[2].split, Split::kTest);
}

// A rig camera with OpenCV distortion is the COLMAP camera of the same numbers: `import videos`
// and `import colmap` give the same pinhole camera and the same pixels.
TEST(VideosImport, DistortedRigMatchesTheColmapImporter) {
  struct Case {
    std::string rig_dist, model;
    std::vector<double> colmap_dist;
  };
  const std::vector<Case> cases = {
      {"    dist: [-0.12, 0.02, 0.001, -0.002]\n", "OPENCV", {-0.12, 0.02, 0.001, -0.002}},
      {"    D: [-0.1, 0.02, 0, 0.001, 0.01, 0.05, 0.01, 0.002]\n",
       "FULL_OPENCV",
       {-0.1, 0.02, 0, 0.001, 0.01, 0.05, 0.01, 0.002}},
      {"    model: fisheye\n    dist: [0.05, -0.02, 0.01, 0]\n",
       "OPENCV_FISHEYE",
       {0.05, -0.02, 0.01, 0}},
      // An equidistant fisheye without coefficients is still no pinhole.
      {"    model: fisheye\n", "OPENCV_FISHEYE", {0, 0, 0, 0}},
  };
  for (const Case& cs : cases) {
    test::TempDir dir;
    Camera cam = rig()[0];
    write_folder(dir / "src" / "cam00", 0, 1);
    test::write_text(dir / "rig.yaml", rig_yaml({cam}, {cs.rig_dist}));
    const VideosReport r =
        import_videos(dir / "src", dir / "videos", quiet(), calib(dir / "rig.yaml"));
    EXPECT_EQ(r.undistorted, 1) << cs.model;

    io::ColmapModel m = colmap_model({cam});
    m.cameras[0].model = cs.model;
    for (double d : cs.colmap_dist) m.cameras[0].params.push_back(d);
    io::write_colmap_model_txt(m, dir / "colmap" / "sparse" / "0");
    fs::create_directories(dir / "colmap" / "images");
    fs::copy_file(dir / "src" / "cam00" / "0000.png", dir / "colmap" / "images" / "cam00.png");
    import_colmap(dir / "colmap", dir / "reference", quiet());

    const io::Scene a = media::read_scene(dir / "videos"), b = media::read_scene(dir / "reference");
    Camera want = b.cameras[0];
    want.world_to_camera = cam.world_to_camera;
    expect_same_camera(a.cameras[0], want);
    EXPECT_NE(a.cameras[0].fx, cam.fx) << cs.model << ": resampled, so the focal length moved";
    EXPECT_TRUE(std::isinf(psnr(media::load_image(a, 0, 0), media::load_image(b, 0, 0))))
        << cs.model;
    EXPECT_LT(psnr(media::load_image(a, 0, 0), source_image(0, 0)), 40) << cs.model;
  }
}

// ---------------------------------------------------------------------------------------------
// Errors: one Error naming the culprit, nothing written.

class VideosBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int c = 0; c < 3; ++c) write_folder(dir_ / "src" / cams_[c].name, c, 3);
    test::write_text(dir_ / "rig.yaml", rig_yaml(cams_));
    options_ = calib(dir_ / "rig.yaml");
  }
  void expect_refused(std::initializer_list<std::string> parts) {
    test::expect_error([&] { import_videos(dir_ / "src", dir_ / "out", quiet(), options_); },
                       parts);
    EXPECT_FALSE(fs::exists(dir_ / "out"));
  }
  // The rig with `extra` appended to cam01's entry.
  void bad_rig(const std::string& extra) {
    test::write_text(dir_ / "rig.yaml", rig_yaml(cams_, {"", extra}));
  }
  test::TempDir dir_;
  std::vector<Camera> cams_ = rig();
  VideosOptions options_;
};

TEST_F(VideosBadInput, MissingCalibrationNamesTheCameras) {
  write_folder(dir_ / "src" / "cam07", 0, 3);
  write_folder(dir_ / "src" / "cam08", 0, 3);
  expect_refused({"rig.yaml", "no calibration for cameras cam07, cam08"});
}

TEST_F(VideosBadInput, RigFieldsAreChecked) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"    dist: [0.1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]\n",
       {"camera 'cam01'", "'dist'", "12 coefficients", "at most 8"}},
      {"    dist: [0.1, 0.2]\n", {"camera 'cam01'", "'dist'", "0, 4, 5 or 8"}},
      {"    model: fisheye\n    dist: [0.1, 0, 0, 0, 0]\n", {"'dist'", "fisheye", "4 coeff"}},
      {"    model: kannala\n", {"camera 'cam01'", "'model'", "kannala"}},
      {"    width: 64\n", {"camera 'cam01'", "'width' and 'height'"}},
      {"    camera_matrix: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n", {"'K'", "'camera_matrix'", "aliases"}},
  };
  for (const auto& [extra, parts] : cases) {
    bad_rig(extra);
    const std::string message =
        test::message_of([&] { import_videos(dir_ / "src", dir_ / "out", quiet(), options_); });
    EXPECT_NE(message.find("rig.yaml"), std::string::npos) << message;
    for (const std::string& part : parts)
      EXPECT_NE(message.find(part), std::string::npos) << message << " / " << part;
    EXPECT_FALSE(fs::exists(dir_ / "out"));
  }
}

// Whole-field replacements: the rig written by hand for cam00 alone.
TEST_F(VideosBadInput, RigValuesAreChecked) {
  const std::string k = "    K: [60, 0, 32, 0, 60, 24, 0, 0, 1]\n";
  const std::string r = "    R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n";
  const std::string t = "    t: [0, 0, 4]\n";
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {k + "    R: [1, 0, 0, 0, 2, 0, 0, 0, 1]\n" + t, {"'R'", "not orthonormal"}},
      {k + "    R: [1, 0, 0, 0, 1, 0, 0, 0, -1]\n" + t, {"'R'", "determinant"}},
      {k + r + "    t: [0, .nan, 4]\n", {"'t'", "non-finite"}},
      {k + r + "    t: [0, 4]\n", {"'t'", "3 numbers"}},
      {k + r, {"missing 't'"}},
      {k + t, {"missing 'R'"}},
      {r + t, {"missing 'K'"}},
      {"    K: [[60, 0, 32], [0, 60, 24]]\n" + r + t, {"'K'", "3x3", "2x3"}},
      {"    K: [60, 0.5, 32, 0, 60, 24, 0, 0, 1]\n" + r + t, {"'K'", "no skew"}},
      {"    K: [-60, 0, 32, 0, 60, 24, 0, 0, 1]\n" + r + t, {"'K'", "positive"}},
      {k + "    R: [1, 0, 0, 0, one, 0, 0, 0, 1]\n" + t, {"'R'", "numbers", "one"}},
      // A matrix's declared size is checked against its data before OpenCV allocates it.
      {"    K: !!opencv-matrix\n      rows: 100000\n      cols: 100000\n      dt: d\n"
       "      data: [1]\n" +
           r + t,
       {"'K'", "declared 100000x100000", "holds 1 number"}},
      {"    K: !!opencv-matrix\n      rows: -3\n      cols: 3\n      dt: d\n      data: [1]\n" + r +
           t,
       {"'K'", "rows and cols must be positive integers"}},
  };
  for (const auto& [body, parts] : cases) {
    test::write_text(dir_ / "rig.yaml", "cameras:\n  cam00:\n" + body);
    fs::remove_all(dir_ / "src");
    write_folder(dir_ / "src" / "cam00", 0, 1);
    const std::string message =
        test::message_of([&] { import_videos(dir_ / "src", dir_ / "out", quiet(), options_); });
    EXPECT_NE(message.find("rig.yaml: camera 'cam00'"), std::string::npos) << message;
    for (const std::string& part : parts)
      EXPECT_NE(message.find(part), std::string::npos) << message << " / " << part;
    EXPECT_FALSE(fs::exists(dir_ / "out"));
  }
}

TEST_F(VideosBadInput, RigFileStructure) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"rig:\n  cam00: {}\n", "missing top-level 'cameras'"},
      {"cameras:\n  - K: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n", "cameras[0]: 'name'"},
      {"cameras:\n  cam00: [1, 2\n", "cannot parse the rig file (line 2"},
      {" \n\n", "the rig file is empty"},
      // OpenCV's YAML parser throws std::length_error on this (found by fuzzing).
      {"  K:d\n  :", "cannot parse the rig file"},
      // A top level that is not a map: OpenCV asserts on storage["cameras"] (found by fuzzing).
      {"- a\n- b\n", "top level must be a map"},
      {"%cameras:\n  - name: \"YAML:0.07\"\n    K:", "rig.yaml"},
      // OpenCV's YAML parser never returns on text after the top-level collection that starts
      // with '-' (found by fuzzing): the top level must be a block map from column 0.
      {" T:]\n1, -\n ", "top level must be a map"},
      {" T:]\n1, -\n:", "top level must be a map"},
      {"{a: 1}\n- x\n", "top level must be a map"},
      {"cameras: {}\n...\n- x\n", "starts with '...'"},
      {"----\n\nz\nras:\n  K:\xff", "top level must be a map"},
      {std::string("cameras:\0\n", 10), "NUL byte"},
  };
  for (const auto& [text, part] : cases) {
    test::write_text(dir_ / "rig.yaml", text);
    const std::string message =
        test::message_of([&] { import_videos(dir_ / "src", dir_ / "out", quiet(), options_); });
    EXPECT_NE(message.find("rig.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find(part), std::string::npos) << message << " / " << part;
  }
  test::write_text(dir_ / "rig.json", "{\"cameras\": {\"cam00\": {\"K\": [1, NaN]}}}");
  options_.calibration = dir_ / "rig.json";
  expect_refused({"rig.json", "cannot parse", "line 1"});
  options_.calibration = dir_ / "rig.txt";
  test::write_text(dir_ / "rig.txt", "cameras: {}\n");
  expect_refused({"rig.txt", "COLMAP model folder or a rig file"});
}

// Frame rates beyond core/limits.hpp's, given (--fps) or read from a video, are refused naming
// the option or the video.
TEST_F(VideosBadInput, FrameRatesOutsideTheLimitAreRefused) {
  for (const double fps : {1e-300, 1e308, -1.0, 0.0}) {
    options_.fps = fps;
    expect_refused({fmt::format("--fps = {}", fps), "frames per second"});
  }
  options_.fps.reset();
  fs::remove_all(dir_ / "src");
  write_video(dir_ / "src" / "cam00.avi", 0, 0.01, 2);  // a frame every 100 s
  expect_refused({"cam00.avi: the video's frame rate = 0.01", "frames per second"});
}

TEST_F(VideosBadInput, FrameRatesMustAgree) {
  fs::remove_all(dir_ / "src");
  write_video(dir_ / "src" / "cam00.mkv", 0, 25, 2);
  write_video(dir_ / "src" / "cam01.mkv", 1, 30, 2);
  expect_refused({"disagree on the frame rate", "cam00.mkv 25", "cam01.mkv 30", "--fps"});
  options_.fps = 25;  // the override is accepted
  EXPECT_NO_THROW(import_videos(dir_ / "src", dir_ / "out", quiet(), options_));
}

TEST_F(VideosBadInput, UnknownCamerasInOptions) {
  options_.test_cameras = {"cam01", "cam9"};
  expect_refused({"--test-cameras", "'cam9'", "cam00, cam01, cam02"});
  options_.test_cameras.clear();
  options_.offsets = {{"camX", 1}};
  expect_refused({"--offsets", "'camX'"});
}

// --calib-frames chooses the frames COLMAP calibrates from: meaningless beside --calib, and a
// count.
TEST_F(VideosBadInput, CalibrationFramesNeedNoCalibrationAndACount) {
  options_.calibration_instants = 5;
  expect_refused({"--calib-frames", "only without --calib"});
  options_.calibration.clear();
  options_.calibration_instants = 0;
  expect_refused({"--calib-frames", "0 is not a positive count"});
}

// --camera-model chooses the model COLMAP fits to every camera: meaningless beside --calib, and
// one of the models a calibration is recovered with.
TEST_F(VideosBadInput, CameraModelNeedsNoCalibrationAndARecoveredModel) {
  options_.camera_model = "SIMPLE_PINHOLE";
  expect_refused({"--camera-model", "only without --calib"});
  options_.calibration.clear();
  options_.camera_model = "OPENCV";
  expect_refused({"--camera-model", "OPENCV is not one", "SIMPLE_RADIAL, SIMPLE_PINHOLE"});
}

TEST_F(VideosBadInput, OffsetsThatLeaveNoFrame) {
  options_.offsets = {{"cam01", 3}};  // 3 frames each
  expect_refused({"--offsets", "cam01:3", "no frame", "3 frames"});
  options_.offsets = {{"cam01", -2}, {"cam02", 1}};  // k >= 2 for cam01, k <= 1 for cam02
  expect_refused({"--offsets", "cam01:-2", "cam02", "no frame is common"});
  options_.offsets = {{"cam01", 1}};
  ImportOptions options = quiet();
  options.first_frame = 0, options.last_frame = 2;
  test::expect_error([&] { import_videos(dir_ / "src", dir_ / "out", options, options_); },
                     {"--frames", "0:1", "after --offsets"});
}

TEST_F(VideosBadInput, FootageProblems) {
  // Aspect ratio of the calibration and the footage.
  test::write_text(dir_ / "rig.yaml", rig_yaml(cams_, {"", "    width: 64\n    height: 64\n"}));
  expect_refused({"cam01", "64x48", "64x64", "aspect ratio"});
  test::write_text(dir_ / "rig.yaml", rig_yaml(cams_));
  // Two sources for one camera.
  write_video(dir_ / "src" / "cam01.mkv", 1, 30, 3);
  expect_refused({"camera 'cam01' has two sources", "cam01.mkv"});
  fs::remove(dir_ / "src" / "cam01.mkv");
  // An image of another size within a folder.
  cv::imwrite((dir_ / "src" / "cam02" / "0001.png").string(), cv::Mat(10, 10, CV_8UC3));
  expect_refused({"0001.png", "10x10", "64x48"});
  // Nothing to import.
  fs::remove_all(dir_ / "src");
  fs::create_directories(dir_ / "src" / "empty");
  expect_refused({"no footage"});
}

TEST_F(VideosBadInput, BrokenFootageNamesTheFileAndFrame) {
  test::write_text(dir_ / "src" / "cam02" / "0001.png", "not a png");
  expect_refused({"0001.png"});
  fs::remove_all(dir_ / "src" / "cam02");
  test::write_text(dir_ / "src" / "cam02.mp4", "not a video");
  expect_refused({"cam02.mp4", "video"});
  fs::remove(dir_ / "src" / "cam02.mp4");
  // A video that ends before its header says: the tail of the stream is cut off.
  const fs::path video = dir_ / "src" / "cam02.mkv";
  write_video(video, 2, 30, 3);
  fs::resize_file(video, fs::file_size(video) * 2 / 3);
  expect_refused({"cam02.mkv", "frame"});
}

}  // namespace
}  // namespace retimegs::ingest

namespace retimegs::ingest {
namespace {

// --offsets X: whole frames X rounded (halves away from zero), the rest N - X the clock's
// time_offset, so that source frame j shows the scene at j - X.
TEST(VideosImport, SplitOffsetRoundsAndKeepsTheFraction) {
  const auto check = [](double x, int frames, double time_offset) {
    const WholeOffset w = split_offset(x);
    EXPECT_EQ(w.frames, frames) << x;
    EXPECT_DOUBLE_EQ(w.time_offset, time_offset) << x;
  };
  check(0, 0, 0);
  check(3, 3, 0);
  check(2.5, 3, 0.5);
  check(-0.5, -1, -0.5);
  check(0.25, 0, -0.25);
  check(-1.75, -2, -0.25);
  check(0.4, 0, -0.4);
  EXPECT_THROW(split_offset(std::nan("")), Error);
  EXPECT_THROW(split_offset(1e300), Error);
}

// Fractional offsets pick the same source frames as their rounded whole frames and record the
// rest as the cameras' time_offset; a camera without one keeps the default clock.
TEST(VideosImport, FractionalOffsetsBecomeTimeOffsets) {
  test::TempDir dir;
  const auto cams = rig();
  write_folder(dir / "src" / "cam00", 0);
  write_video(dir / "src" / "cam01.mkv", 1, 30);
  write_folder(dir / "src" / "cam02", 2);
  io::write_colmap_model_txt(colmap_model(cams), dir / "model");
  VideosOptions v = calib(dir / "model");
  v.offsets = {{"cam01", 1.5}, {"cam02", -0.75}};  // whole frames 2 and -1, as above
  const VideosReport r = import_videos(dir / "src", dir / "a", quiet(), v);
  EXPECT_EQ(r.first_frame, 1);
  const io::Scene scene = media::read_scene(dir / "a");
  ASSERT_EQ(scene.num_frames, 3);
  for (int j = 0; j < 3; ++j) {
    expect_frame(scene, 0, j, 1 + j);
    expect_frame(scene, 1, j, 3 + j);
    expect_frame(scene, 2, j, j);
  }
  ASSERT_EQ(scene.clocks.size(), 3u);
  EXPECT_EQ(scene.clocks[0].time_offset, 0);
  EXPECT_EQ(scene.clocks[1].time_offset, 0.5);    // 2 - 1.5: source frame j at j - 1.5
  EXPECT_EQ(scene.clocks[2].time_offset, -0.25);  // -1 + 0.75
  EXPECT_DOUBLE_EQ(io::frame_time(scene, 1, 1), 1.5);
}

}  // namespace
}  // namespace retimegs::ingest

namespace retimegs::ingest {
namespace {

// --timestamps with whole-frame --offsets: the offsets choose the source frames, the timestamps
// give their times, relative to cam00's scene frame 0 (its source frame 1 here), at the scene's
// rate (30 fps: image folders). The clocks stay "given".
TEST(VideosImport, TimestampsBecomeFrameTimes) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c);
  io::write_colmap_model_txt(colmap_model(cams), dir / "model");
  // cam00 on time at 30 fps from 5 s, cam01 10 ms late, cam02 a frame (33.3 ms) early but
  // running 1 % slow.
  std::string csv = "camera,frame,seconds\n";
  for (int j = 0; j < kFrames; ++j)
    csv += fmt::format("cam00,{},{:.17g}\ncam01,{},{:.17g}\ncam02,{},{:.17g}\n", j, 5 + j / 30.0, j,
                       5.01 + j / 30.0, j, 5 - 1 / 30.0 + 1.01 * j / 30.0);
  test::write_text(dir / "t.csv", csv);
  VideosOptions v = calib(dir / "model");
  v.offsets = {{"cam01", 2}, {"cam02", -1}};  // scene frames k = 1..3, as above
  v.timestamps = dir / "t.csv";
  import_videos(dir / "src", dir / "a", quiet(), v);
  const io::Scene scene = media::read_scene(dir / "a");
  ASSERT_EQ(scene.num_frames, 3);
  EXPECT_EQ(scene.clock_source, io::ClockSource::kGiven);
  ASSERT_EQ(scene.clocks.size(), 3u);
  for (int j = 0; j < 3; ++j) {
    expect_frame(scene, 1, j, 3 + j);
    EXPECT_NEAR(scene.clocks[0].frame_times[j], j, 1e-9);
    EXPECT_NEAR(scene.clocks[1].frame_times[j], 2 + j + 0.3, 1e-9);  // source frame 3 + j
    EXPECT_NEAR(scene.clocks[2].frame_times[j], -1 - 1 + 1.01 * j, 1e-9);
  }
}

// What --timestamps refuses: fractional --offsets (the timestamps say when frames show the
// scene), --sync auto, and a scene frame without a timestamp; nothing is written.
TEST(VideosImport, TimestampsRefuseFractionsSyncAndMissingFrames) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c);
  io::write_colmap_model_txt(colmap_model(cams), dir / "model");
  std::string csv;
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < kFrames - (c == 2); ++j) csv += fmt::format("cam0{},{},{}\n", c, j, j);
  test::write_text(dir / "t.csv", csv);
  VideosOptions v = calib(dir / "model");
  v.timestamps = dir / "t.csv";
  v.offsets = {{"cam01", 0.5}};
  test::expect_error([&] { import_videos(dir / "src", dir / "a", quiet(), v); },
                     {"--offsets: cam01:0.5 is not a whole number of frames", "--timestamps"});
  v.offsets.clear();
  v.sync_auto = true;
  test::expect_error([&] { import_videos(dir / "src", dir / "a", quiet(), v); },
                     {"--sync auto: not with --timestamps"});
  v.sync_auto = false;
  test::expect_error([&] { import_videos(dir / "src", dir / "a", quiet(), v); },
                     {"t.csv: no timestamp for camera 'cam02' frame 5 (its scene frame 5)"});
  EXPECT_FALSE(fs::exists(dir / "a"));
}

// --sync auto estimates every camera's offset: not with --offsets; --sync-max-lag only with it.
TEST(VideosImport, SyncAutoRefusesOffsetsAndAMaxLagAlone) {
  test::TempDir dir;
  const auto cams = rig();
  for (int c = 0; c < 3; ++c) write_folder(dir / "src" / cams[c].name, c);
  io::write_colmap_model_txt(colmap_model(cams), dir / "model");
  VideosOptions v = calib(dir / "model");
  v.sync_auto = true;
  v.offsets = {{"cam01", 1}};
  test::expect_error([&] { import_videos(dir / "src", dir / "a", quiet(), v); },
                     {"--sync auto: not with --offsets"});
  v.sync_auto = false;
  v.offsets.clear();
  v.sync_max_lag = 2;
  test::expect_error([&] { import_videos(dir / "src", dir / "a", quiet(), v); },
                     {"--sync-max-lag: only with --sync auto"});
  EXPECT_FALSE(fs::exists(dir / "a"));
}

}  // namespace
}  // namespace retimegs::ingest
