// `prepare_scene`: exactly the flow pairs training reads, estimated close to the synthetic
// scene's exact flows, resumable, imports validated before anything is written.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "retimegs/core/error.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/prepare.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::prepare {
namespace {
namespace fs = std::filesystem;

// A 5-frame, 3-camera minimal synthetic scene; its exact flows and points are moved to
// `exact` so that the scene has none.
io::Scene bare_scene(const fs::path& root, const fs::path& exact, int frames = 5) {
  synth::SynthOptions options;
  options.preset = "minimal";
  options.cameras = 3;
  options.frames = frames;
  options.width = 64, options.height = 48;
  options.progress = false;
  synth::synthesize_scene(options, root);
  fs::create_directories(exact);
  fs::rename(root / "flow", exact / "flow");
  fs::rename(root / "points", exact / "points");
  return media::read_scene(root);
}

// Without COLMAP (whether or not this machine has it): the default points are then hull + random
// or random, fast and deterministic on these tiny scenes.
PrepareOptions quiet() {
  PrepareOptions o;
  o.progress = false;
  o.hull.resolution = 48;
  o.colmap.executable = "/nonexistent/colmap";
  return o;
}

std::set<std::string> files_under(const fs::path& dir) {
  std::set<std::string> names;
  if (!fs::exists(dir)) return names;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) names.insert(fs::relative(e.path(), dir).generic_string());
  return names;
}

// Mean |a - b| over pixels known in both.
double epe(const Flow& a, const Flow& b) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.pixels(); ++i)
    if (a.valid[i] && b.valid[i]) {
      sum += std::hypot(a.uv[2 * i] - b.uv[2 * i], a.uv[2 * i + 1] - b.uv[2 * i + 1]);
      ++n;
    }
  return n ? sum / double(n) : 1e9;
}

TEST(Prepare, WritesExactlyThePairsTrainingReadsForEvenFrames) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  const PrepareReport r = prepare_scene(scene, quiet());
  // Frames 0, 2, 4: pairs (0, 2) and (2, 4), both directions, for each of the 3 cameras.
  std::set<std::string> expected;
  for (const char* cam : {"cam00", "cam01", "cam02"})
    for (const char* name : {"00000_00002", "00002_00000", "00002_00004", "00004_00002"})
      expected.insert(std::string(cam) + "/" + name + ".flo");
  EXPECT_EQ(files_under(scene.root / "flow"), expected);
  EXPECT_EQ(files_under(scene.root / "points"),
            (std::set<std::string>{"00000.ply", "00002.ply", "00004.ply"}));
  EXPECT_EQ(r.flows_written, 12u);
  EXPECT_EQ(r.flows_kept, 0u);
  EXPECT_EQ(r.points_source, "hull,random");  // the synthetic scene has masks; "no COLMAP"
  EXPECT_NE(r.points_note.find("COLMAP not found"), std::string::npos) << r.points_note;
  ASSERT_EQ(r.points_written.size(), 3u);
  for (const auto& [frame, n] : r.points_written) EXPECT_GT(n, 100u) << frame;

  // Close to the exact flows (small, textured scene), and not swapped.
  for (int c = 0; c < 3; ++c)
    for (const auto& [from, to] : {std::pair{0, 2}, std::pair{2, 0}, std::pair{4, 2}}) {
      const Flow estimated = io::read_flo(scene.flow_path(c, from, to));
      EXPECT_EQ(estimated.width, 64);
      EXPECT_EQ(estimated.height, 48);
      const fs::path rel = fs::relative(scene.flow_path(c, from, to), scene.root);
      const Flow truth = io::read_flo(dir / "exact" / rel);
      const Flow reverse =
          io::read_flo(dir / "exact" / fs::relative(scene.flow_path(c, to, from), scene.root));
      EXPECT_LT(epe(estimated, truth), 1.0) << rel;
      EXPECT_LT(epe(estimated, truth), epe(estimated, reverse)) << rel;
    }
}

// A camera whose middle frame is noise (a dropped or corrupted frame): both of its flow pairs fail
// the forward-backward check, and the report names that camera first, far above the others.
TEST(Prepare, ReportsTheUnknownShareOfEachCameraWorstFirst) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  Image noise(64, 48, 3);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  for (float& v : noise.data) v = uniform(rng);
  media::write_png(scene.image_path(1, 2), noise);
  const PrepareReport r = prepare_scene(scene, quiet());
  ASSERT_EQ(r.flow_by_camera.size(), 3u);
  EXPECT_EQ(r.flow_by_camera[0].camera, 1);
  for (const CameraFlowCheck& c : r.flow_by_camera) EXPECT_EQ(c.flows, 4u) << c.camera;
  EXPECT_GT(r.flow_by_camera[0].unknown_fraction, 2 * r.flow_by_camera[1].unknown_fraction);
  EXPECT_GE(r.flow_by_camera[1].unknown_fraction, r.flow_by_camera[2].unknown_fraction);
  const double mean = (r.flow_by_camera[0].unknown_fraction + r.flow_by_camera[1].unknown_fraction +
                       r.flow_by_camera[2].unknown_fraction) /
                      3;
  EXPECT_NEAR(r.unknown_fraction, mean, 1e-12);  // the cameras' flows are the same size
}

TEST(Prepare, KeepsExistingFilesAndForceRewritesThem) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  PrepareOptions o = quiet();
  o.points = {PointsSource::kRandom};
  prepare_scene(scene, o);
  const fs::path flow = scene.flow_path(1, 2, 0);
  fs::remove(flow);
  const PrepareReport again = prepare_scene(scene, o);
  EXPECT_EQ(again.flows_written, 1u);  // only the removed one
  EXPECT_EQ(again.flows_kept, 11u);
  EXPECT_TRUE(again.points_written.empty());
  EXPECT_EQ(again.points_kept, 3u);
  EXPECT_TRUE(fs::exists(flow));
  o.force = true;
  const PrepareReport forced = prepare_scene(scene, o);
  EXPECT_EQ(forced.flows_written, 12u);
  EXPECT_EQ(forced.points_written.size(), 3u);
}

TEST(Prepare, AllFramesUseStrideOne) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact", 3);
  PrepareOptions o = quiet();
  o.frames = io::FrameSelection::kAll;
  o.points = {PointsSource::kRandom};
  const PrepareReport r = prepare_scene(scene, o);
  EXPECT_EQ(r.flows_written, 3u * 2 * 2);
  EXPECT_TRUE(fs::exists(scene.flow_path(0, 1, 2)));
  EXPECT_TRUE(fs::exists(scene.flow_path(2, 1, 0)));
  EXPECT_FALSE(fs::exists(scene.flow_path(0, 0, 2)));
  EXPECT_EQ(files_under(scene.root / "points").size(), 3u);
  // Random points per frame: training's 20 000 spread over the frames, at least 1 000.
  for (const auto& [frame, n] : r.points_written) EXPECT_EQ(n, 20000u / 3) << frame;
}

TEST(Prepare, ImportsFlowFilesByteForByte) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  PrepareOptions o = quiet();
  o.flow_dir = dir / "exact" / "flow";  // the scene's own naming: <camera>/<from>_<to>.flo
  o.points = {PointsSource::kRandom};
  const PrepareReport r = prepare_scene(scene, o);
  EXPECT_TRUE(r.flows_imported);
  EXPECT_EQ(r.flows_written, 12u);
  for (const std::string& rel : files_under(scene.root / "flow"))
    EXPECT_EQ(test::read_text(scene.root / "flow" / rel), test::read_text(o.flow_dir / rel)) << rel;
}

TEST(Prepare, RejectsAWrongSizeImportBeforeWritingAnything) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  const fs::path bad = dir / "exact" / "flow" / "cam01" / "00002_00004.flo";
  io::write_flo(bad, Flow(32, 48));
  PrepareOptions o = quiet();
  o.flow_dir = dir / "exact" / "flow";
  test::expect_error([&] { prepare_scene(scene, o); }, {bad.string(), "32x48", "64x48", "cam01"});
  EXPECT_TRUE(files_under(scene.root / "flow").empty());
  EXPECT_TRUE(files_under(scene.root / "points").empty());

  fs::remove(bad);
  test::expect_error([&] { prepare_scene(scene, o); }, {bad.string(), "missing", "1 of the 12"});
  EXPECT_TRUE(files_under(scene.root / "flow").empty());
}

TEST(Prepare, ImportsPerFramePlyFiles) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  PrepareOptions o = quiet();
  o.points = {PointsSource::kPly};
  o.points_dir = dir / "exact" / "points";
  const PrepareReport r = prepare_scene(scene, o);
  EXPECT_EQ(r.points_source, "ply");
  for (int k : {0, 2, 4})
    EXPECT_EQ(io::read_points_ply(scene.points_path(k)).xyz,
              io::read_points_ply(o.points_dir / fmt::format("{:05d}.ply", k)).xyz);
  // A missing frame is named, and nothing is written.
  test::TempDir dir2;
  const io::Scene scene2 = bare_scene(dir2 / "scene", dir2 / "exact");
  fs::remove(dir2 / "exact" / "points" / "00004.ply");
  o.points_dir = dir2 / "exact" / "points";
  test::expect_error([&] { prepare_scene(scene2, o); }, {"00004.ply"});
  EXPECT_TRUE(files_under(scene2.root / "flow").empty());
}

TEST(Prepare, DefaultsToRandomPointsWithoutMasksAndHullNeedsThem) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  fs::remove_all(scene.root / "masks");
  PrepareOptions o = quiet();
  o.points = {PointsSource::kHull};
  test::expect_error([&] { prepare_scene(scene, o); }, {"no mask", "--points hull"});
  EXPECT_TRUE(files_under(scene.root / "flow").empty());
  o.points = {PointsSource::kColmap};
  o.colmap.executable = (dir / "no-such-colmap").string();
  test::expect_error([&] { prepare_scene(scene, o); }, {"COLMAP not found"});
  EXPECT_TRUE(files_under(scene.root / "flow").empty());
  o.points = {};
  EXPECT_EQ(prepare_scene(scene, o).points_source, "random");
}

// A COLMAP failure names its log, which is still there to read (the temporary folder is kept).
TEST(Prepare, AColmapFailureNamesALogThatExists) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact", 3);
  const fs::path fake = dir / "fake-colmap";
  test::write_text(fake, "#!/bin/sh\necho \"E0101 error: out of cheese in $1\" >&2\nexit 3\n");
  fs::permissions(fake, fs::perms::owner_all);
  PrepareOptions o = quiet();
  o.points = {PointsSource::kColmap};
  o.colmap.executable = fake.string();
  const std::string message = test::message_of([&] { prepare_scene(scene, o); });
  EXPECT_NE(message.find("out of cheese in feature_extractor"), std::string::npos) << message;
  const std::size_t at = message.find("(log: ");
  ASSERT_NE(at, std::string::npos) << message;
  const fs::path log = message.substr(at + 6, message.find(')', at) - at - 6);
  EXPECT_TRUE(fs::exists(log)) << log;
  fs::remove_all(log.parent_path().parent_path());
}

// The default covers the whole scene: the hull's foreground plus COLMAP's background with the
// capture's own masks, COLMAP alone without (two-view tracks on a rig of few cameras); the hull of
// --masks' approximate masks only where COLMAP fails; pair stereo beside COLMAP on a rig of few
// cameras without masks of its own; random stands in for a missing COLMAP, with a note saying so.
// The summary is the one line that says what and why.
TEST(Prepare, DefaultPointsCoverForegroundAndBackground) {
  using enum PointsSource;
  auto plan = [](std::size_t cameras, bool masks, bool estimated, bool colmap,
                 std::size_t stereo_pairs = 0) {
    return default_points({cameras, masks, estimated, colmap, stereo_pairs});
  };
  PointsPlan p = plan(27, true, false, true);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kHull, kColmap}));
  EXPECT_TRUE(p.fallbacks.empty());
  EXPECT_TRUE(p.note.empty());
  EXPECT_EQ(p.summary, "hull (masks at every training view) + colmap (27 training cameras)");
  p = plan(4, true, false, true);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kHull, kColmap}));
  EXPECT_EQ(p.summary,
            "hull (masks at every training view) + colmap with two-view tracks (4 training "
            "cameras)");
  p = plan(4, false, false, true);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kColmap}));
  EXPECT_EQ(p.summary,
            "colmap with two-view tracks (4 training cameras); no hull: not every training view "
            "has a mask");
  p = plan(6, true, true, true);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kColmap}));
  EXPECT_EQ(p.fallbacks, (std::vector<PointsSource>{kHull}));
  EXPECT_NE(p.summary.find("approximate masks only where colmap finds no point"), std::string::npos)
      << p.summary;
  p = plan(8, true, false, false);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kHull, kRandom}));
  EXPECT_NE(p.note.find("COLMAP not found"), std::string::npos) << p.note;
  EXPECT_NE(p.note.find("background"), std::string::npos) << p.note;
  p = plan(8, false, false, false);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kRandom}));
  EXPECT_NE(p.note.find("COLMAP not found"), std::string::npos) << p.note;
  // Pair stereo joins a rig of few cameras without masks of its own where a pair is usable.
  p = plan(2, false, false, true, 1);
  EXPECT_EQ(p.sources, (std::vector<PointsSource>{kColmap, kStereo}));
  EXPECT_NE(p.summary.find("stereo (1 camera pair)"), std::string::npos) << p.summary;
  EXPECT_EQ(plan(4, true, false, true, 3).sources, (std::vector<PointsSource>{kHull, kColmap}));
  EXPECT_EQ(plan(27, false, false, true, 40).sources, (std::vector<PointsSource>{kColmap}));
  // Two-view tracks: below twelve training cameras (a ring's neighbours 30 degrees apart).
  EXPECT_TRUE(keeps_two_view_tracks(2));
  EXPECT_TRUE(keeps_two_view_tracks(11));
  EXPECT_FALSE(keeps_two_view_tracks(12));
  EXPECT_FALSE(keeps_two_view_tracks(27));
}

// A COLMAP that fails at every frame: by default the hull's points stand for every frame and the
// report names the frames and why; asked for explicitly, colmap still stops prepare; without masks
// nothing builds, and the error says what to bring.
TEST(Prepare, DefaultPointsFallBackWhereColmapFailsAndSayWhatToBringWhereNothingBuilds) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  const fs::path fake = dir / "fake-colmap";
  test::write_text(fake, "#!/bin/sh\necho \"E0101 error: no features in $1\" >&2\nexit 3\n");
  fs::permissions(fake, fs::perms::owner_all);
  PrepareOptions o = quiet();
  o.colmap.executable = fake.string();
  const PrepareReport r = prepare_scene(scene, o);
  EXPECT_EQ(r.points_source, "hull,colmap");
  EXPECT_EQ(r.points_plan,
            "hull (masks at every training view) + colmap with two-view tracks (3 training "
            "cameras)");
  ASSERT_EQ(r.points_written.size(), 3u);
  ASSERT_EQ(r.points_fallbacks.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(r.points_fallbacks[i].frame, r.points_written[i].first);
    EXPECT_EQ(r.points_fallbacks[i].used, "hull");
    EXPECT_NE(r.points_fallbacks[i].reason.find("colmap: colmap feature_extractor failed"),
              std::string::npos)
        << r.points_fallbacks[i].reason;
    EXPECT_GT(r.points_written[i].second, 100u);
  }

  o.force = true;
  o.points = {PointsSource::kHull, PointsSource::kColmap};
  test::expect_error([&] { prepare_scene(scene, o); },
                     {"colmap feature_extractor failed", "Other point sources"});

  fs::remove_all(scene.root / "masks");
  fs::remove_all(scene.root / "points");
  o.points = {};
  test::expect_error([&] { prepare_scene(scene, o); },
                     {"too few points for frame 0 (0, at least 100 needed)",
                      "colmap: colmap feature_extractor failed", "a mask for every training view",
                      "overlap", "--points ply DIR"});
  EXPECT_TRUE(files_under(scene.root / "points").empty());
}

TEST(Prepare, SeveralPointSourcesAreConcatenated) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact");
  PrepareOptions o = quiet();
  o.points = {PointsSource::kRandom};
  const PrepareReport random = prepare_scene(scene, o);
  o.points = {PointsSource::kHull};
  o.force = true;
  const PrepareReport hull = prepare_scene(scene, o);
  o.points = {PointsSource::kHull, PointsSource::kRandom};
  const PrepareReport both = prepare_scene(scene, o);
  EXPECT_EQ(both.points_source, "hull,random");
  ASSERT_EQ(both.points_written.size(), hull.points_written.size());
  for (std::size_t i = 0; i < both.points_written.size(); ++i) {
    EXPECT_GT(hull.points_written[i].second, 0u);
    EXPECT_EQ(both.points_written[i].second,
              hull.points_written[i].second + random.points_written[i].second);
    const io::PointCloud cloud =
        io::read_points_ply(scene.points_path(both.points_written[i].first));
    EXPECT_EQ(cloud.size(), both.points_written[i].second);
    EXPECT_EQ(cloud.rgb.size(), cloud.xyz.size());
  }
}

// A COLMAP that crashes in its bundle adjustment (as COLMAP 3.8 aborts on a frame with too few
// matched features): one error that says so in words, names the log that stays in the scene, and
// the other point sources to try; COLMAP's temporary folder is gone, no points are written.
TEST(Prepare, ColmapFailureIsExplainedWithItsLogAndTheOtherSources) {
  test::TempDir dir;
  const io::Scene scene = bare_scene(dir / "scene", dir / "exact", 3);
  const fs::path fake = dir / "fake-colmap";
  test::write_text(fake,
                   "#!/bin/sh\n"
                   "[ \"$1\" = point_triangulator ] || exit 0\n"
                   "echo 'F1126 12:00:00.000 sfm.cc:473] Check failed: "
                   "bundle_adjuster.Solve(&reconstruction) ' >&2\n"
                   "echo '*** Check failure stack trace: ***' >&2\n"
                   "kill -6 $$\n");
  fs::permissions(fake, fs::perms::owner_all);
  PrepareOptions o = quiet();
  o.colmap.executable = fake.string();
  o.points = {PointsSource::kColmap};
  const fs::path log = scene.root / "logs" / "colmap" / "00000" / "point_triangulator.log";
  test::expect_error(
      [&] { prepare_scene(scene, o); },
      {"colmap point_triangulator failed (crashed with signal 6): its bundle adjustment",
       "too few matched features", log.string(), "--points hull", "--points random"});
  EXPECT_TRUE(fs::is_regular_file(log));
  EXPECT_TRUE(files_under(scene.root / "points").empty());
  for (const auto& e : fs::directory_iterator(fs::temp_directory_path()))
    EXPECT_NE(e.path().filename().string().rfind(
                  "retimegs-colmap-" + std::to_string(::getpid()) + "-", 0),
              0u)
        << e.path();
}

}  // namespace
}  // namespace retimegs::prepare
