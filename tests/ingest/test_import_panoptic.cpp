#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs::ingest {
namespace {
namespace fs = std::filesystem;

const char* kClip = "panoptic-basketball";

// The shared clip is imported once for the whole suite (527 JPEGs -> PNG).
class PanopticImport : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(test::shared_data() / kClip)) return;
    dir_ = new test::TempDir;
    ImportOptions options;
    options.progress = false;
    import_panoptic(test::shared_data() / kClip, *dir_ / "scene", options);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override { RETIMEGS_REQUIRE_DATA(kClip); }
  static fs::path scene_dir() { return *dir_ / "scene"; }
  static test::TempDir* dir_;
};
test::TempDir* PanopticImport::dir_ = nullptr;

TEST_F(PanopticImport, CamerasFramesSplitsAndMasks) {
  const io::Scene scene =
      media::read_scene(scene_dir());  // also checks every image exists with its size
  EXPECT_EQ(scene.num_frames, 17);
  EXPECT_EQ(scene.calibration, io::CalibrationSource::kLab);  // the dome's own
  ASSERT_EQ(scene.cameras.size(), 31u);
  int train = 0, with_masks = 0;
  for (int c = 0; c < 31; ++c) {
    const Camera& cam = scene.cameras[c];
    EXPECT_EQ(cam.name, std::to_string(c));
    EXPECT_EQ(cam.width, 640);
    EXPECT_EQ(cam.height, 360);
    const bool test_camera = c == 0 || c == 10 || c == 15 || c == 30;
    EXPECT_EQ(cam.split, test_camera ? Split::kTest : Split::kTrain) << cam.name;
    train += cam.split == Split::kTrain;
    bool all_masks = true, any_mask = false;
    for (int k = 0; k < 17; ++k) {
      const bool has = fs::exists(scene.mask_path(c, k));
      all_masks &= has;
      any_mask |= has;
    }
    EXPECT_EQ(all_masks, !test_camera) << cam.name;
    EXPECT_EQ(any_mask, !test_camera) << cam.name;
    with_masks += all_masks;
  }
  EXPECT_EQ(train, 27);
  EXPECT_EQ(with_masks, 27);
  // Camera 1's intrinsics as in train_meta.json.
  EXPECT_NEAR(scene.cameras[1].fx, 465.6666666666667, 1e-9);
  EXPECT_NEAR(scene.cameras[1].cy, 186.84466666666668, 1e-9);
  EXPECT_NEAR(scene.cameras[1].world_to_camera(2, 3), 3.608606891, 1e-12);
  EXPECT_EQ(scene.up, Eigen::Vector3d(0, -1, 0));
}

TEST_F(PanopticImport, ImagesAreLosslessCopiesOfTheDecodedJpegs) {
  const io::Scene scene = media::read_scene(scene_dir(), media::SceneCheck::kJson);
  const Image source = media::read_image(test::shared_data() / kClip / "ims" / "22" / "000009.jpg");
  const Image imported = media::load_image(scene, 22, 9);
  ASSERT_EQ(source.data.size(), imported.data.size());
  float max_diff = 0;
  for (std::size_t i = 0; i < source.data.size(); ++i)
    max_diff = std::max(max_diff, std::abs(source.data[i] - imported.data[i]));
  EXPECT_LT(max_diff, 1e-6);
}

// The ball triangulated from 30 cameras (verification.json, frame 0) must land inside every
// camera, in front of it, and on the foreground mask of the training cameras that see it: image,
// mask and calibration agree.
TEST_F(PanopticImport, TriangulatedBallProjectsOntoForegroundEverywhere) {
  const io::Scene scene = media::read_scene(scene_dir(), media::SceneCheck::kJson);
  const auto verification =
      nlohmann::json::parse(test::read_text(test::shared_data() / kClip / "verification.json"));
  const auto& x = verification["ball_triangulation"]["0"]["X"];
  const Eigen::Vector3d ball(x[0].get<double>(), x[1].get<double>(), x[2].get<double>());
  int on_mask = 0, masked = 0;
  for (int c = 0; c < int(scene.cameras.size()); ++c) {
    const Camera& cam = scene.cameras[c];
    const Eigen::Vector3d p = cam.world_to_cam(ball);
    EXPECT_GT(p.z(), 1.5) << cam.name;
    const Eigen::Vector2d uv = cam.project(ball);
    EXPECT_TRUE(cam.in_image(uv)) << cam.name << " " << uv.transpose();
    if (const auto mask = media::load_mask(scene, c, 0)) {
      ++masked;
      // Any foreground within 3 px (the ball is ~10 px across; residuals are ~1 px).
      bool hit = false;
      for (int dy = -3; dy <= 3; ++dy)
        for (int dx = -3; dx <= 3; ++dx) {
          const int px = int(uv.x()) + dx, py = int(uv.y()) + dy;
          if (px >= 0 && py >= 0 && px < cam.width && py < cam.height)
            hit |= mask->at(py, px) > 0.5f;
        }
      on_mask += hit;
    }
  }
  EXPECT_EQ(masked, 27);
  EXPECT_GE(on_mask, 26) << "ball on the foreground mask in only " << on_mask << " of 27 cameras";
}

TEST_F(PanopticImport, FrameRangeAndDownscale) {
  test::TempDir dir;
  ImportOptions options;
  options.first_frame = 4;
  options.last_frame = 6;
  options.downscale = 2;
  options.progress = false;
  import_panoptic(test::shared_data() / kClip, dir / "half", options);
  const io::Scene scene = media::read_scene(dir / "half");
  EXPECT_EQ(scene.num_frames, 3);
  EXPECT_EQ(scene.cameras[3].width, 320);
  EXPECT_EQ(scene.cameras[3].height, 180);
  const io::Scene full = media::read_scene(scene_dir(), media::SceneCheck::kJson);
  EXPECT_NEAR(scene.cameras[3].fx, full.cameras[3].fx / 2, 1e-9);
  EXPECT_NEAR(scene.cameras[3].cx, full.cameras[3].cx / 2, 1e-9);
  // Same 3D point, half the pixel coordinates.
  const Eigen::Vector3d x(0.1, -1.2, 0.3);
  EXPECT_LT((scene.cameras[3].project(x) - full.cameras[3].project(x) / 2).norm(), 1e-9);
  // Frame 0 of the import is source frame 4.
  const Image a = media::load_image(scene, 3, 0);
  const Image b = media::load_image(full, 3, 4);
  double mean_a = 0, mean_b = 0;
  for (float v : a.data) mean_a += v;
  for (float v : b.data) mean_b += v;
  EXPECT_NEAR(mean_a / a.data.size(), mean_b / b.data.size(), 2e-3);
}

// Bad inputs: one line naming the file, nothing written.
class PanopticBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    RETIMEGS_REQUIRE_DATA(kClip);
    // A copy of the metadata with 2 frames; images linked from the shared clip.
    const fs::path src = test::shared_data() / kClip;
    fs::create_directories(dir_ / "src");
    fs::create_directory_symlink(src / "ims", dir_ / "src" / "ims");
    fs::create_directory_symlink(src / "seg", dir_ / "src" / "seg");
    for (const char* name : {"train_meta.json", "test_meta.json"}) {
      auto j = nlohmann::json::parse(test::read_text(src / name));
      for (const char* key : {"k", "w2c", "fn", "cam_id"})
        j[key] = nlohmann::json(j[key].begin(), j[key].begin() + 2);
      metas_[name] = j;
      test::write_text(dir_ / "src" / name, j.dump());
    }
  }
  void expect_error(std::initializer_list<std::string> fragments) {
    test::expect_import_refused("panoptic", dir_.path(), fragments);
  }
  test::TempDir dir_;
  std::map<std::string, nlohmann::json> metas_;
};

TEST_F(PanopticBadInput, SmallCopyImports) {
  const auto r = test::run_cli("import panoptic --in " + (dir_ / "src").string() + " --out " +
                               (dir_ / "out").string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(media::read_scene(dir_ / "out").num_frames, 2);
}

TEST_F(PanopticBadInput, MissingMetadata) {
  fs::remove(dir_ / "src" / "train_meta.json");
  expect_error({"train_meta.json", "cannot open"});
}

TEST_F(PanopticBadInput, MalformedJson) {
  test::write_text(dir_ / "src" / "test_meta.json", "{\"w\": 640,");
  expect_error({"test_meta.json", "malformed JSON"});
}

TEST_F(PanopticBadInput, MissingKey) {
  auto j = metas_["train_meta.json"];
  j.erase("w2c");
  test::write_text(dir_ / "src" / "train_meta.json", j.dump());
  expect_error({"train_meta.json", "missing required key 'w2c'"});
}

TEST_F(PanopticBadInput, NoCameras) {
  auto j = metas_["train_meta.json"];
  for (const char* key : {"k", "w2c", "fn", "cam_id"})
    for (auto& step : j[key]) step = nlohmann::json::array();
  test::write_text(dir_ / "src" / "train_meta.json", j.dump());
  expect_error({"train_meta.json", "lists no camera"});
}

TEST_F(PanopticBadInput, NonRigidMatrix) {
  auto j = metas_["train_meta.json"];
  j["w2c"][0][3][1][1] = 1.5;
  test::write_text(dir_ / "src" / "train_meta.json", j.dump());
  expect_error({"train_meta.json", "w2c[0][3]", "orthonormal"});
}

TEST_F(PanopticBadInput, NonFiniteIntrinsics) {
  auto j = metas_["test_meta.json"];
  j["k"][0][1][0][0] = nullptr;  // what json.dump writes for NaN
  test::write_text(dir_ / "src" / "test_meta.json", j.dump());
  expect_error({"test_meta.json", "k[0][1][0][0]", "finite"});
}

TEST_F(PanopticBadInput, ImageSizeMismatch) {
  auto j = metas_["train_meta.json"];
  j["w"] = 600;
  test::write_text(dir_ / "src" / "train_meta.json", j.dump());
  auto t = metas_["test_meta.json"];
  t["w"] = 600;
  test::write_text(dir_ / "src" / "test_meta.json", t.dump());
  expect_error({".jpg", "640x360", "600x360"});
}

TEST_F(PanopticBadInput, MissingImage) {
  auto j = metas_["train_meta.json"];
  j["fn"][1][2] = "3/000099.jpg";
  test::write_text(dir_ / "src" / "train_meta.json", j.dump());
  expect_error({"000099.jpg", "missing"});
}

// 'fn' names a file below ims/: an absolute path, a '..' component, an empty name or a NUL is
// refused, naming the file, the entry and the value (a NUL shown as \x00).
TEST_F(PanopticBadInput, FrameFileOutsideTheSourceIsRefused) {
  const std::pair<std::string, std::string> cases[] = {
      {"/etc/hostname", "absolute path"},          {"../ims/3/000000.jpg", "'..'"},
      {"3/../../ims/3/000000.jpg", "'..'"},        {"", "empty name"},
      {std::string("3/000000.jpg\0x", 14), "NUL"},
  };
  for (const auto& [value, why] : cases) {
    auto j = metas_["train_meta.json"];
    j["fn"][1][2] = value;
    test::write_text(dir_ / "src" / "train_meta.json", j.dump());
    const std::string shown = value.find('\0') == std::string::npos ? value : "3/000000.jpg\\x00x";
    expect_error({"train_meta.json", "'fn[1][2]'", "'" + shown + "'", why});
  }
}

// A name the file system cannot look up (a component longer than NAME_MAX, found by fuzzing) is an
// Error naming it, not std::filesystem's exception.
TEST_F(PanopticBadInput, FrameFileNameTooLongIsAnError) {
  auto j = metas_["train_meta.json"];
  const std::string name = "3/" + std::string(300, 'x') + ".jpg";
  j["fn"][1][2] = name;
  test::write_text(dir_ / "src" / "train_meta.json", j.dump());
  expect_error({name, "cannot look it up", "File name too long"});
}

TEST_F(PanopticBadInput, FrameRangeOutside) {
  const auto r = test::run_cli("import panoptic --in " + (dir_ / "src").string() + " --out " +
                               (dir_ / "out").string() + " --frames 0:5");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--frames"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// `import panoptic --help` describes this format and its options, not every format's layout.
TEST(ImportCli, EachFormatHasItsOwnHelp) {
  const auto help = [](const std::string& format) {
    const std::string command = std::string(RETIMEGS_BINARY) + " import " + format + " --help";
    std::string out;
    if (FILE* pipe = ::popen(command.c_str(), "r")) {
      char buffer[4096];
      while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, n);
      EXPECT_EQ(::pclose(pipe), 0) << command;
    }
    return out;
  };
  const std::string panoptic = help("panoptic"), n3dv = help("n3dv");
  EXPECT_NE(panoptic.find("train_meta.json"), std::string::npos) << panoptic;
  EXPECT_EQ(panoptic.find("poses_bounds.npy"), std::string::npos) << panoptic;
  EXPECT_NE(panoptic.find("--downscale"), std::string::npos) << panoptic;
  EXPECT_NE(n3dv.find("poses_bounds.npy"), std::string::npos) << n3dv;
  EXPECT_EQ(n3dv.find("train_meta.json"), std::string::npos) << n3dv;
  const std::string all = help("");
  for (const char* format : {"panoptic", "n3dv", "colmap", "nerfstudio"})
    EXPECT_NE(all.find(format), std::string::npos) << all;
}

// A missing or misspelt format or command names the word and the choices in one line.
TEST(ImportCli, AnUnknownFormatIsNamedWithTheChoices) {
  auto r = test::run_cli("import foo --in a --out b");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("retimegs import: unknown command 'foo' (one of: "), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("videos"), std::string::npos) << r.err;
  r = test::run_cli("import");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("retimegs import: give one of: "), std::string::npos) << r.err;
  r = test::run_cli("frobnicate");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("retimegs: unknown command 'frobnicate' (one of: synth, import"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace retimegs::ingest
