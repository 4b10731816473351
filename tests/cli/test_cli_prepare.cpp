// `retimegs prepare` end to end: fills in a synthetic scene's flows and points, resumes without
// touching finished files, --force rewrites them, bad imports exit 2 with nothing written.
#include <sys/stat.h>

#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/ply.hpp"
#include "test_util.hpp"

namespace retimegs {
namespace {
namespace fs = std::filesystem;

// Modification time in nanoseconds and inode: an atomic rewrite changes both.
std::pair<long long, unsigned long> stamp(const fs::path& p) {
  struct stat s {};
  EXPECT_EQ(::stat(p.c_str(), &s), 0) << p;
  return {s.st_mtim.tv_sec * 1000000000LL + s.st_mtim.tv_nsec, s.st_ino};
}

// Runs the CLI and returns its stdout (the summary is logged there); status in `status`.
std::string run_stdout(const std::string& args, const test::TempDir& dir, int& status) {
  const fs::path out = dir / "stdout.txt";
  const std::string command =
      std::string(RETIMEGS_BINARY) + " " + args + " >" + out.string() + " 2>/dev/null";
  const int raw = std::system(command.c_str());
  status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return test::read_text(out);
}

// A 3-camera, 5-frame synthetic scene without flow/ and points/.
fs::path bare_scene(const test::TempDir& dir) {
  const fs::path scene = dir / "scene";
  const auto r = test::run_cli("synth --preset minimal --cameras 3 --frames 5 --size 64x48 --out " +
                               scene.string());
  EXPECT_EQ(r.status, 0) << r.err;
  fs::rename(scene / "flow", dir / "exact-flow");
  fs::remove_all(scene / "points");
  return scene;
}

// --window 2:4 prepares what train --window 2:4 reads: the flows between 2 and 4 and out of its
// first frame to 0, the points of 2 and 4, not those of frame 0; the rest of the clip follows
// with a later run, which finds the shared flows made.
TEST(PrepareCli, WindowPreparesOnlyItsFrames) {
  test::TempDir dir;
  const fs::path scene = bare_scene(dir);
  const std::string cmd = "prepare --scene " + scene.string() + " --points random";
  int status = -1;
  const std::string out = run_stdout(cmd + " --window 2:4", dir, status);
  ASSERT_EQ(status, 0);
  // 3 cameras x 2 pairs x 2 directions.
  EXPECT_NE(out.find("12 files written"), std::string::npos) << out;
  for (const char* name :
       {"00002_00004.flo", "00004_00002.flo", "00000_00002.flo", "00002_00000.flo"})
    EXPECT_TRUE(fs::exists(scene / "flow" / "cam01" / name)) << name;
  EXPECT_TRUE(fs::exists(scene / "points" / "00002.ply"));
  EXPECT_TRUE(fs::exists(scene / "points" / "00004.ply"));
  EXPECT_FALSE(fs::exists(scene / "points" / "00000.ply"));
  const std::string rest = run_stdout(cmd + " --window 0:2", dir, status);
  ASSERT_EQ(status, 0);
  EXPECT_NE(rest.find("0 files written"), std::string::npos) << rest;  // 0 <-> 2, 2 <-> 4 made
  EXPECT_TRUE(fs::exists(scene / "points" / "00000.ply"));
  // Not a training frame; masks learn from the whole clip.
  auto r = test::run_cli(cmd + " --window 1:4");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("frame 1 is not a training frame"), std::string::npos) << r.err;
  r = test::run_cli(cmd + " --window 0:2 --masks");
  EXPECT_EQ(r.status, 2);
}

TEST(PrepareCli, FillsInResumesAndForceRewrites) {
  test::TempDir dir;
  const fs::path scene = bare_scene(dir);
  const std::string cmd = "prepare --scene " + scene.string();
  // Hull points: the default's COLMAP part would depend on this machine having COLMAP.
  const std::string hull = cmd + " --points hull";
  int status = -1;
  const std::string first = run_stdout(hull, dir, status);
  ASSERT_EQ(status, 0);
  EXPECT_NE(first.find("12 files written"), std::string::npos) << first;
  const fs::path flow = scene / "flow" / "cam02" / "00004_00002.flo";
  const fs::path points = scene / "points" / "00002.ply";
  ASSERT_TRUE(fs::exists(flow));
  ASSERT_TRUE(fs::exists(points));
  const Flow f = io::read_flo(flow);
  EXPECT_EQ(f.width, 64);
  EXPECT_EQ(f.height, 48);
  EXPECT_EQ(fs::file_size(flow), 12u + 64 * 48 * 8);
  EXPECT_GT(io::read_points_ply(points).size(), 100u);
  EXPECT_FALSE(fs::exists(scene / "flow" / "cam00" / "00000_00001.flo"));  // stride 2 only

  const auto flow_before = stamp(flow), points_before = stamp(points);
  const std::string second = run_stdout(hull, dir, status);
  ASSERT_EQ(status, 0);
  EXPECT_EQ(stamp(flow), flow_before);
  EXPECT_EQ(stamp(points), points_before);
  EXPECT_NE(second.find("0 files written"), std::string::npos) << second;
  EXPECT_NE(second.find("12 kept"), std::string::npos) << second;

  const auto r = test::run_cli(cmd + " --force --points random");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(stamp(flow), flow_before);
  EXPECT_NE(stamp(points), points_before);
}

TEST(PrepareCli, WrongSizeImportExitsTwoAndWritesNothing) {
  test::TempDir dir;
  const fs::path scene = bare_scene(dir);
  const fs::path bad = dir / "exact-flow" / "cam00" / "00002_00000.flo";
  io::write_flo(bad, Flow(64, 40));
  const auto r = test::run_cli("prepare --scene " + scene.string() + " --flow-dir " +
                               (dir / "exact-flow").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find(bad.string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("64x40"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  EXPECT_FALSE(fs::exists(scene / "flow"));
  EXPECT_FALSE(fs::exists(scene / "points"));
}

TEST(PrepareCli, RejectsBadPointsArguments) {
  test::TempDir dir;
  const fs::path scene = bare_scene(dir);
  const std::string cmd = "prepare --scene " + scene.string();
  // COLMAP missing: refused before any flow is written.
  const std::string path = std::getenv("PATH") ? std::getenv("PATH") : "";
  setenv("PATH", "/nonexistent", 1);
  auto r = test::run_cli(cmd + " --points colmap");
  setenv("PATH", path.c_str(), 1);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("COLMAP not found"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(scene / "flow"));
  r = test::run_cli(cmd + " --points ply");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("needs a folder"), std::string::npos) << r.err;
  r = test::run_cli(cmd + " --points cloud");
  EXPECT_EQ(r.status, 2);
  r = test::run_cli(cmd + " --flow dis --flow-dir " + (dir / "exact-flow").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_FALSE(fs::exists(scene / "flow"));
}

// --points stereo: a ring of 12 cameras (neighbours 30 degrees apart) gets dense points from its
// camera pairs; the 3-camera ring (120 degrees apart) has no usable pair and stops in one line.
TEST(PrepareCli, StereoPointsFromCameraPairs) {
  test::TempDir dir;
  const fs::path ring = dir / "ring";
  auto r = test::run_cli("synth --preset minimal --cameras 12 --frames 3 --size 96x72 --out " +
                         ring.string());
  ASSERT_EQ(r.status, 0) << r.err;
  fs::remove_all(ring / "points");
  int status = 0;
  const std::string log =
      run_stdout("prepare --scene " + ring.string() + " --points stereo", dir, status);
  EXPECT_EQ(status, 0) << log;
  EXPECT_NE(log.find("points (stereo)"), std::string::npos) << log;
  for (const char* frame : {"00000.ply", "00002.ply"})
    EXPECT_GT(io::read_points_ply(ring / "points" / frame).size(), 50u) << frame;

  const fs::path scene = bare_scene(dir);
  r = test::run_cli("prepare --scene " + scene.string() + " --points stereo");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no usable pair"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
}

// A capture without masks: --masks writes one per camera and frame and says so in one line.
TEST(PrepareCli, MasksForACaptureWithoutThem) {
  test::TempDir dir;
  const fs::path scene = bare_scene(dir);
  fs::remove_all(scene / "masks");
  int status = 0;
  const std::string log =
      run_stdout("prepare --scene " + scene.string() + " --masks --points random", dir, status);
  EXPECT_EQ(status, 0) << log;
  EXPECT_NE(log.find("masks (approximate): 15 files written"), std::string::npos) << log;
  for (const char* camera : {"cam00", "cam01", "cam02"})
    for (int k = 0; k < 5; ++k)
      EXPECT_TRUE(fs::exists(scene / "masks" / camera / fmt::format("{:05d}.png", k)))
          << camera << " " << k;
}

}  // namespace
}  // namespace retimegs
