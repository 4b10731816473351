// `retimegs import videos` end to end: a tiny capture of image folders and a rig YAML.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// dir/src/cam00, cam01: 3 frames each; dir/rig.yaml: cam00, cam01 and cam02 (no footage).
void make_capture(const fs::path& dir, const std::string& cam01_extra = "") {
  std::string rig = "cameras:\n";
  for (int c = 0; c < 3; ++c) {
    const Camera cam = test::small_camera(fmt::format("cam0{}", c), {2.0 * c - 2, -1, -4});
    const Eigen::Matrix3d r = cam.rotation();
    const Eigen::Vector3d t = cam.translation();
    rig += fmt::format(
        "  {}:\n    K: [[{}, 0, {}], [0, {}, {}], [0, 0, 1]]\n"
        "    R: [{:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}, {:.17g}]\n"
        "    t: [{:.17g}, {:.17g}, {:.17g}]\n",
        cam.name, cam.fx, cam.cx, cam.fy, cam.cy, r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1),
        r(1, 2), r(2, 0), r(2, 1), r(2, 2), t.x(), t.y(), t.z());
    if (c == 1) rig += cam01_extra;
    if (c == 2) break;
    for (int k = 0; k < 3; ++k) {
      Image image(cam.width, cam.height, 3);
      for (std::size_t i = 0; i < image.data.size(); ++i)
        image.data[i] = float((i * 7 + 40 * k + 90 * c) % 256) / 255;
      media::write_png(dir / "src" / cam.name / fmt::format("frame{:03d}.png", k), image);
    }
  }
  test::write_text(dir / "rig.yaml", rig);
}

// Runs the CLI with stdout (the log) and stderr together in `err`.
test::CommandResult run_logged(const std::string& args, const fs::path& dir) {
  const fs::path log = dir / "log.txt";
  const std::string command =
      std::string(RETIMEGS_BINARY) + " " + args + " >" + log.string() + " 2>&1";
  const int raw = std::system(command.c_str());
  test::CommandResult result;
  result.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  result.err = test::read_text(log);
  return result;
}

TEST(ImportVideosCli, ImportsImageFoldersWithARigFile) {
  test::TempDir dir;
  make_capture(dir.path());
  const auto r = run_logged("import videos --in " + (dir / "src").string() + " --calib " +
                                (dir / "rig.yaml").string() + " --out " + (dir / "scene").string() +
                                " --test-cameras cam01 --offsets cam00:1 --fps 24",
                            dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const io::Scene scene = media::read_scene(dir / "scene");
  ASSERT_EQ(scene.cameras.size(), 2u);
  EXPECT_EQ(scene.num_frames, 2);  // cam00 from its frame 1: frames 1, 2 of cam00, 0, 1 of cam01
  EXPECT_EQ(scene.fps, 24.0);
  EXPECT_EQ(scene.cameras[1].split, Split::kTest);
  const Image first = media::load_image(scene, 0, 0);
  EXPECT_NEAR(first.data[0], 40.0f / 255, 1e-6);  // cam00's source frame 1
  EXPECT_NE(r.err.find("import videos: 2 cameras (1 test) x 2 frames at 24 fps"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("no masks"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 calibrated camera without footage left out: cam02"), std::string::npos)
      << r.err;
}

TEST(ImportVideosCli, BadRigIsRefusedInOneLine) {
  test::TempDir dir;
  make_capture(dir.path(), "    dist: [0.1, 0, 0, 0, 0, 0, 0, 0, 0]\n");
  const std::string calib = " --calib " + (dir / "rig.yaml").string();
  test::expect_import_refused("videos", dir.path(),
                              {"rig.yaml", "camera 'cam01'", "'dist'", "9 coefficients"}, calib);
  make_capture(dir.path());
  test::expect_import_refused("videos", dir.path(), {"--offsets", "cam00+1"},
                              calib + " --offsets cam00+1");
}

// A fraction in --offsets: cam00:1.25 takes source frame k + 1 as scene frame k (as cam00:1) and
// records time_offset 1 - 1.25 = -0.25; a value that is not a number names the flag.
TEST(ImportVideosCli, FractionalOffsetsAreRecordedAsTimeOffsets) {
  test::TempDir dir;
  make_capture(dir.path());
  const auto r = run_logged("import videos --in " + (dir / "src").string() + " --calib " +
                                (dir / "rig.yaml").string() + " --out " + (dir / "scene").string() +
                                " --offsets cam00:1.25,cam01:0.5",
                            dir.path());
  ASSERT_EQ(r.status, 0) << r.err;
  const io::Scene scene = media::read_scene(dir / "scene");
  EXPECT_NEAR(media::load_image(scene, 0, 0).data[0], 40.0f / 255, 1e-6);  // cam00's frame 1
  ASSERT_EQ(scene.clocks.size(), 2u);
  EXPECT_EQ(scene.clocks[0].time_offset, -0.25);
  EXPECT_EQ(scene.clocks[1].time_offset, 0.5);  // 1 - 0.5: source frame k + 1, at k + 0.5
  test::expect_import_refused("videos", dir.path(), {"--offsets", "cam00:half"},
                              " --calib " + (dir / "rig.yaml").string() + " --offsets cam00:half");
}

}  // namespace
}  // namespace retimegs
