#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

#include "retimegs/ingest/import.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;

io::ColmapModel sample_model() {
  io::ColmapModel m;
  m.cameras.push_back({1, "PINHOLE", 40, 30, {50, 51, 20, 15}});
  m.cameras.push_back({7, "OPENCV", 64, 48, {60, 61, 32.5, 23.5, -0.1, 0.01, 0.001, -0.002}});
  io::ColmapImage a;
  a.id = 3, a.camera_id = 1, a.name = "a.png";
  a.qvec = {std::sqrt(0.5), 0, 0, std::sqrt(0.5)};  // 90 degrees about z
  a.tvec = {0.25, -1, 2};
  io::ColmapImage b;
  b.id = 5, b.camera_id = 7, b.name = "left/b.png";
  b.tvec = {0, 0, 2};
  m.images = {a, b};
  m.points.push_back({1, {1, 0, 5}, {255, 0, 10}, 0.5, 0, {}});
  m.points.push_back({4, {-1, 2, 3.5}, {0, 128, 255}, 0.25, 0, {}});
  return m;
}

void expect_same(const io::ColmapModel& a, const io::ColmapModel& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (std::size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].id, b.cameras[i].id);
    EXPECT_EQ(a.cameras[i].model, b.cameras[i].model);
    EXPECT_EQ(a.cameras[i].width, b.cameras[i].width);
    EXPECT_EQ(a.cameras[i].height, b.cameras[i].height);
    EXPECT_EQ(a.cameras[i].params, b.cameras[i].params);
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (std::size_t i = 0; i < a.images.size(); ++i) {
    EXPECT_EQ(a.images[i].id, b.images[i].id);
    EXPECT_EQ(a.images[i].camera_id, b.images[i].camera_id);
    EXPECT_EQ(a.images[i].name, b.images[i].name);
    EXPECT_LT((a.images[i].qvec - b.images[i].qvec).norm(), 1e-15);
    EXPECT_LT((a.images[i].tvec - b.images[i].tvec).norm(), 1e-15);
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].id, b.points[i].id);
    EXPECT_LT((a.points[i].xyz - b.points[i].xyz).norm(), 1e-15);
    EXPECT_EQ(a.points[i].rgb, b.points[i].rgb);
  }
}

TEST(ColmapModelIo, TextAndBinaryRoundTrip) {
  test::TempDir dir;
  const io::ColmapModel m = sample_model();
  io::write_colmap_model_txt(m, dir / "txt");
  io::write_colmap_model_bin(m, dir / "bin");
  expect_same(io::read_colmap_model(dir / "txt"), m);
  expect_same(io::read_colmap_model(dir / "bin"), m);
}

// A point's track: the image of each observation (what prepare's two-view check reads).
TEST(ColmapModelIo, ReadsTheTrackImagesOfTextPoints) {
  test::TempDir dir;
  io::write_colmap_model_txt(sample_model(), dir / "txt");
  test::write_text(dir / "txt" / "points3D.txt",
                   "1 1 0 5 255 0 10 0.5 3 0 5 7\n4 0 0 1 1 2 3 0.1\n");
  const io::ColmapModel m = io::read_colmap_model(dir / "txt");
  ASSERT_EQ(m.points.size(), 2u);
  EXPECT_EQ(m.points[0].track_length, 2u);
  EXPECT_EQ(m.points[0].track_images, (std::vector<std::uint32_t>{3, 5}));
  EXPECT_EQ(m.points[1].track_length, 0u);
  EXPECT_TRUE(m.points[1].track_images.empty());
}

// Counts in the binary files are checked against the file's size before allocating (issue 26):
// each edited count is refused naming the file and the count.
TEST(ColmapModelIo, BinaryCountsBeyondTheFileAreRefusedNamingThem) {
  test::TempDir dir;
  io::ColmapModel m = sample_model();
  m.points[0].track_length = 0;
  io::write_colmap_model_bin(m, dir / "good");
  struct Case {
    const char* file;
    std::size_t offset;  // of the uint64 count
    std::uint64_t count;
    const char* fragment;
  };
  // images.bin: count (8), id (4), qvec + tvec (56), camera id (4), "a.png\0" (6): 2-D points.
  // points3D.bin: count (8), id (8), xyz (24), rgb (3), error (8): track length.
  const Case cases[] = {
      {"cameras.bin", 0, 1'000'000'000, "1000000000 cameras do not fit in the file"},
      {"cameras.bin", 0, ~std::uint64_t(0), "18446744073709551615 cameras do not fit"},
      {"images.bin", 0, 1'000'000'000, "1000000000 images do not fit in the file"},
      {"images.bin", 8 + 4 + 56 + 4 + 6, 1'000'000'000, "1000000000 2-D points do not fit"},
      {"points3D.bin", 0, 1'000'000'000, "1000000000 points do not fit in the file"},
      {"points3D.bin", 8 + 8 + 24 + 3 + 8, ~std::uint64_t(0) / 2,
       "9223372036854775807 track elements do not fit"},
  };
  for (const Case& c : cases) {
    fs::remove_all(dir / "bad");
    fs::copy(dir / "good", dir / "bad");
    std::string bytes = test::read_text(dir / "bad" / c.file);
    std::memcpy(bytes.data() + c.offset, &c.count, sizeof c.count);
    test::write_text(dir / "bad" / c.file, bytes);
    SCOPED_TRACE(std::string(c.file) + " " + c.fragment);
    test::expect_error([&] { io::read_colmap_model(dir / "bad"); },
                       {(dir / "bad" / c.file).string(), c.fragment});
  }
}

// COLMAP's own converter writes the binary files: an independent check of the binary reader.
TEST(ColmapModelIo, ReadsWhatColmapModelConverterWrites) {
  if (!test::have_colmap()) GTEST_SKIP() << "colmap not installed";
  test::TempDir dir;
  io::write_colmap_model_txt(sample_model(), dir / "txt");
  fs::create_directories(dir / "bin");
  const std::string cmd = "QT_QPA_PLATFORM=offscreen colmap model_converter --input_path " +
                          (dir / "txt").string() + " --output_path " + (dir / "bin").string() +
                          " --output_type BIN >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  ASSERT_TRUE(fs::exists(dir / "bin" / "images.bin"));
  io::ColmapModel from_colmap = io::read_colmap_model(dir / "bin");
  // COLMAP writes in its own (id) order.
  io::ColmapModel expected = sample_model();
  auto by_id = [](const auto& x, const auto& y) { return x.id < y.id; };
  for (auto* m : {&from_colmap, &expected}) {
    std::sort(m->cameras.begin(), m->cameras.end(), by_id);
    std::sort(m->images.begin(), m->images.end(), by_id);
    std::sort(m->points.begin(), m->points.end(), by_id);
  }
  expect_same(from_colmap, expected);
}

TEST(ColmapModelIo, QuaternionIsWorldToCamera) {
  const io::ColmapImage a = sample_model().images[0];
  // R = rotation by 90 degrees about z: (x, y, z) -> (-y, x, z); then + t.
  const Eigen::Matrix4d w2c = a.world_to_camera();
  const Eigen::Vector3d x(1, 0, 5);
  const Eigen::Vector3d c = w2c.topLeftCorner<3, 3>() * x + w2c.topRightCorner<3, 1>();
  EXPECT_LT((c - Eigen::Vector3d(0.25, 0, 7)).norm(), 1e-12);
  const io::ColmapImage back = io::ColmapImage::from_world_to_camera(1, 1, "x", w2c);
  EXPECT_LT((back.qvec - a.qvec).norm(), 1e-12);
}

// A COLMAP project with images of the right sizes (noise).
void make_project(const fs::path& dir, const io::ColmapModel& m, bool binary) {
  if (binary)
    io::write_colmap_model_bin(m, dir / "sparse" / "0");
  else
    io::write_colmap_model_txt(m, dir / "sparse" / "0");
  for (const auto& im : m.images) {
    const io::ColmapCamera& cam = m.camera(im.camera_id);
    Image image(cam.width, cam.height, 3);
    for (std::size_t i = 0; i < image.data.size(); ++i) image.data[i] = float((i * 37) % 101) / 100;
    media::write_png(dir / "images" / im.name, image);
  }
}

TEST(ColmapImport, PinholeCamerasPosesAndPoints) {
  for (bool binary : {false, true}) {
    test::TempDir dir;
    io::ColmapModel m = sample_model();
    m.cameras[1] = {7, "SIMPLE_PINHOLE", 64, 48, {60, 32, 24}};
    make_project(dir / "src", m, binary);
    ImportOptions options;
    options.progress = false;
    import_colmap(dir / "src", dir / "scene", options);
    const io::Scene scene = media::read_scene(dir / "scene");
    EXPECT_EQ(scene.num_frames, 1);
    EXPECT_EQ(scene.calibration, io::CalibrationSource::kUser);  // a user's reconstruction
    ASSERT_EQ(scene.cameras.size(), 2u);
    EXPECT_EQ(scene.cameras[0].name, "a");
    EXPECT_EQ(scene.cameras[1].name, "b");
    // a: R X + t = (0, 1, 5) + (0.25, -1, 2) = (0.25, 0, 7) -> (20 + 50 * 0.25 / 7, 15).
    const Eigen::Vector3d x(1, 0, 5);
    EXPECT_LT((scene.cameras[0].project(x) - Eigen::Vector2d(20 + 12.5 / 7, 15)).norm(), 1e-9);
    // b: X + (0, 0, 2) = (1, 0, 7) -> (32 + 60 / 7, 24).
    EXPECT_LT((scene.cameras[1].project(x) - Eigen::Vector2d(32 + 60.0 / 7, 24)).norm(), 1e-9);
    const auto points = io::load_points(scene, 0);
    ASSERT_TRUE(points.has_value());
    ASSERT_EQ(points->size(), 2u);
    EXPECT_FLOAT_EQ(points->xyz[3], -1.0f);
    EXPECT_NEAR(points->rgb[4], 128 / 255.0, 1e-6);
    // Pinhole images are copied unchanged.
    const Image src = media::read_image(dir / "src" / "images" / "left" / "b.png");
    const Image out = media::load_image(scene, 1, 0);
    ASSERT_EQ(src.data.size(), out.data.size());
    for (std::size_t i = 0; i < src.data.size(); i += 97)
      EXPECT_NEAR(src.data[i], out.data[i], 1e-6);
  }
}

// The public OpenCV / COLMAP distortion formulas, written out independently of the importer.
Eigen::Vector2d distorted_pixel(const io::ColmapCamera& c, double x, double y) {
  const auto& p = c.params;
  const double r2 = x * x + y * y;
  if (c.model == "SIMPLE_RADIAL") {
    const double s = 1 + p[3] * r2;
    return {p[0] * x * s + p[1], p[0] * y * s + p[2]};
  }
  if (c.model == "OPENCV_FISHEYE") {  // fx, fy, cx, cy, k1..k4 on the angle theta
    const double r = std::sqrt(r2), theta = std::atan(r);
    const double t2 = theta * theta;
    const double td =
        theta * (1 + p[4] * t2 + p[5] * t2 * t2 + p[6] * t2 * t2 * t2 + p[7] * t2 * t2 * t2 * t2);
    const double s = r > 0 ? td / r : 1.0;
    return {p[0] * x * s + p[2], p[1] * y * s + p[3]};
  }
  // OPENCV: fx, fy, cx, cy, k1, k2, p1, p2 (FULL_OPENCV adds k3..k6: rational radial term)
  double s = 1 + p[4] * r2 + p[5] * r2 * r2;
  if (c.model == "FULL_OPENCV")
    s = (s + p[8] * r2 * r2 * r2) / (1 + p[9] * r2 + p[10] * r2 * r2 + p[11] * r2 * r2 * r2);
  const double xd = x * s + 2 * p[6] * x * y + p[7] * (r2 + 2 * x * x);
  const double yd = y * s + p[6] * (r2 + 2 * y * y) + 2 * p[7] * x * y;
  return {p[0] * xd + p[2], p[1] * yd + p[3]};
}

// Blobs drawn at the distorted projections of known rays must land, after undistortion, where
// the imported pinhole camera projects those rays.
TEST(ColmapImport, UndistortedImagesMatchThePinholeCamera) {
  for (const io::ColmapCamera& source :
       {io::ColmapCamera{1, "OPENCV", 160, 120, {120, 118, 81.5, 59, -0.18, 0.03, 0.002, -0.0015}},
        io::ColmapCamera{1, "SIMPLE_RADIAL", 160, 120, {110, 80, 60, 0.12}},
        io::ColmapCamera{1,
                         "FULL_OPENCV",
                         160,
                         120,
                         {120, 120, 80, 60, -0.1, 0.02, 0, 0.001, 0.01, 0.05, 0.01, 0.002}},
        io::ColmapCamera{1, "OPENCV_FISHEYE", 160, 120, {90, 90, 80, 60, 0.05, -0.02, 0.01, 0}}}) {
    test::TempDir dir;
    io::ColmapModel m;
    m.cameras = {source};
    io::ColmapImage im;
    im.id = 1, im.camera_id = 1, im.name = "view.png";
    m.images = {im};
    io::write_colmap_model_txt(m, dir / "src" / "sparse" / "0");
    std::vector<Eigen::Vector2d> rays;
    for (double y : {-0.3, 0.0, 0.3})
      for (double x : {-0.4, 0.0, 0.4}) rays.emplace_back(x, y);
    const double sigma = 1.5;
    Image image(source.width, source.height, 3);
    for (const auto& ray : rays) {
      const Eigen::Vector2d q = distorted_pixel(source, ray.x(), ray.y());
      for (int i = 0; i < image.height; ++i)
        for (int j = 0; j < image.width; ++j) {
          const double d2 = (Eigen::Vector2d(j + 0.5, i + 0.5) - q).squaredNorm();
          for (int c = 0; c < 3; ++c)
            image.at(i, j, c) += float(std::exp(-d2 / (2 * sigma * sigma)));
        }
    }
    media::write_png(dir / "src" / "images" / "view.png", image, 16);
    ImportOptions options;
    options.progress = false;
    import_colmap(dir / "src", dir / "scene", options);
    const io::Scene scene = media::read_scene(dir / "scene");
    const Camera& cam = scene.cameras[0];
    EXPECT_EQ(cam.width, source.width);
    EXPECT_EQ(cam.height, source.height);
    const Image out = media::load_image(scene, 0, 0);
    for (const auto& ray : rays) {
      const Eigen::Vector2d expected = cam.project(Eigen::Vector3d(ray.x(), ray.y(), 1));
      ASSERT_TRUE(cam.in_image(expected)) << source.model << " " << expected.transpose();
      Eigen::Vector2d sum(0, 0);
      double weight = 0;
      for (int i = int(expected.y()) - 6; i <= int(expected.y()) + 6; ++i)
        for (int j = int(expected.x()) - 6; j <= int(expected.x()) + 6; ++j) {
          if (i < 0 || j < 0 || i >= out.height || j >= out.width) continue;
          const double w = out.at(i, j, 0);
          sum += w * Eigen::Vector2d(j + 0.5, i + 0.5);
          weight += w;
        }
      ASSERT_GT(weight, 1.0) << source.model;
      EXPECT_LT((sum / weight - expected).norm(), 0.3)
          << source.model << " ray " << ray.transpose() << ": blob at "
          << (sum / weight).transpose() << ", camera projects to " << expected.transpose();
    }
    // Alpha 0: the corners sample inside the source, so they are not the replicated border
    // only; the focal length moved (barrel distortion widens the view, pincushion narrows it).
    EXPECT_NE(cam.fx, source.params[0]);
  }
}

class ColmapBadInput : public ::testing::Test {
 protected:
  void SetUp() override { make_project(dir_ / "src", sample_model(), false); }
  void expect_error(std::initializer_list<std::string> fragments) {
    const auto r = test::run_cli("import colmap --in " + (dir_ / "src").string() + " --out " +
                                 (dir_ / "out").string());
    EXPECT_EQ(r.status, 2) << r.err;
    for (const auto& f : fragments) EXPECT_NE(r.err.find(f), std::string::npos) << r.err;
    EXPECT_TRUE(test::is_one_error_line(r.err)) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out"));
  }
  fs::path model() const { return dir_ / "src" / "sparse" / "0"; }
  test::TempDir dir_;
};

TEST_F(ColmapBadInput, ImportsWhenIntact) {
  const auto r = test::run_cli("import colmap --in " + (dir_ / "src").string() + " --out " +
                               (dir_ / "out").string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(media::read_scene(dir_ / "out").cameras.size(), 2u);
}

TEST_F(ColmapBadInput, MissingImage) {
  fs::remove(dir_ / "src" / "images" / "left" / "b.png");
  expect_error({"b.png", "missing image"});
}

// a.png and a.jpg in one folder would both be camera "a".
TEST_F(ColmapBadInput, TwoImagesOneCameraName) {
  io::ColmapModel m = sample_model();
  m.images[1].name = "a.jpg";
  io::write_colmap_model_txt(m, model());
  fs::copy_file(dir_ / "src" / "images" / "a.png", dir_ / "src" / "images" / "a.jpg");
  expect_error({"images", "'a.png'", "'a.jpg'", "would both be camera 'a'"});
}

TEST_F(ColmapBadInput, UnknownCameraOfImage) {
  io::ColmapModel m = sample_model();
  m.images[1].camera_id = 9;
  io::write_colmap_model_txt(m, model());
  expect_error({"images.txt", "camera 9"});
}

TEST_F(ColmapBadInput, UnsupportedCameraModel) {
  io::ColmapModel m = sample_model();
  m.cameras[1] = {7, "FOV", 64, 48, {60, 61, 32, 24, 0.9}};
  io::write_colmap_model_txt(m, model());
  expect_error({"camera 7", "FOV", "not supported"});
}

TEST_F(ColmapBadInput, TruncatedBinary) {
  io::write_colmap_model_bin(sample_model(), model());
  for (const char* n : {"cameras.txt", "images.txt", "points3D.txt"}) fs::remove(model() / n);
  fs::resize_file(model() / "images.bin", fs::file_size(model() / "images.bin") - 5);
  expect_error({"images.bin", "truncated"});
}

TEST_F(ColmapBadInput, MalformedText) {
  test::write_text(model() / "cameras.txt", "# comment\n1 PINHOLE 40 thirty 50 50 20 15\n");
  expect_error({"cameras.txt:2", "HEIGHT"});
}

TEST_F(ColmapBadInput, ImageSizeMismatch) {
  media::write_png(dir_ / "src" / "images" / "a.png", Image(41, 30, 3));
  expect_error({"a.png", "41x30", "40x30"});
}

TEST_F(ColmapBadInput, NoModel) {
  fs::remove_all(dir_ / "src" / "sparse");
  expect_error({"no COLMAP sparse model"});
}

}  // namespace
}  // namespace retimegs::ingest
