// `retimegs synth`: the scenes are checked through the files on disk, as every consumer reads them.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "retimegs/core/error.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/perturb_calibration.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/rig_file.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/synth/synth.hpp"
#include "test_util.hpp"

namespace retimegs::synth {
namespace {

SynthOptions small_options(const std::string& preset, int cameras, int frames, int width,
                           int height) {
  SynthOptions o;
  o.preset = preset;
  o.cameras = cameras;
  o.frames = frames;
  o.width = width;
  o.height = height;
  o.progress = false;
  return o;
}

// Writes a scene and reads it back through the scene format (checking every file's size).
io::Scene make_scene(const test::TempDir& dir, const SynthOptions& options) {
  const auto root = dir / "scene";
  synthesize_scene(options, root);
  return media::read_scene(root, media::SceneCheck::kFiles);
}

double flow_norm(const Flow& f, std::size_t p) {
  return std::hypot(f.uv[p * 2], f.uv[p * 2 + 1]);
}

// Mean absolute colour error between frame `from` and frame `to` sampled at p + flow(p), and
// without the warp, over valid pixels that move by more than half a pixel.
struct WarpErrors {
  double warped = 0, unwarped = 0;
  std::size_t pixels = 0;
};

void add_warp_errors(const io::Scene& scene, int cam, int from, int to, WarpErrors& e) {
  const Image a = media::read_image(scene.image_path(cam, from));
  const Image b = media::read_image(scene.image_path(cam, to));
  const Flow f = io::read_flo(scene.flow_path(cam, from, to));
  for (int y = 0; y < f.height; ++y) {
    for (int x = 0; x < f.width; ++x) {
      const std::size_t p = std::size_t(y) * f.width + x;
      if (!f.valid[p] || flow_norm(f, p) <= 0.5) continue;
      for (int c = 0; c < 3; ++c) {
        const double warped =
            sample_bilinear(b, x + 0.5 + f.uv[p * 2], y + 0.5 + f.uv[p * 2 + 1], c);
        e.warped += std::abs(warped - a.at(y, x, c));
        e.unwarped += std::abs(b.at(y, x, c) - a.at(y, x, c));
      }
      ++e.pixels;
    }
  }
}

TEST(Synth, FlowWarpsTheTargetFrameOntoTheSource) {
  test::TempDir dir;
  const io::Scene scene = make_scene(dir, small_options("default", 3, 5, 128, 96));
  for (int stride : {1, 2}) {
    WarpErrors forward, backward;
    for (int cam = 0; cam < 3; ++cam) {
      for (int k = 0; k + stride < scene.num_frames; ++k) {
        add_warp_errors(scene, cam, k, k + stride, forward);
        add_warp_errors(scene, cam, k + stride, k, backward);
      }
    }
    for (const WarpErrors* e : {&forward, &backward}) {
      ASSERT_GT(e->pixels, 5000u) << "stride " << stride;
      // Measured (seed 0): 0.21-0.24 of the error without warping; what remains is shading that
      // changes as the objects turn, and pixels that mix two surfaces. Flows with a 10 % error in
      // x measure 0.26-0.30 (ForwardAndBackwardFlowsCancel catches those).
      EXPECT_LT(e->warped, 0.3 * e->unwarped)
          << "stride " << stride << ": mean error with warp " << e->warped / (3 * e->pixels)
          << ", without " << e->unwarped / (3 * e->pixels);
    }
  }
}

TEST(Synth, ForwardAndBackwardFlowsCancel) {
  test::TempDir dir;
  const io::Scene scene = make_scene(dir, small_options("default", 3, 5, 128, 96));
  std::vector<double> errors;
  for (int cam = 0; cam < 3; ++cam) {
    for (int k = 0; k + 1 < scene.num_frames; ++k) {
      const Flow fwd = io::read_flo(scene.flow_path(cam, k, k + 1));
      const Flow bwd = io::read_flo(scene.flow_path(cam, k + 1, k));
      Image bwd_uv(bwd.width, bwd.height, 2);  // to sample it bilinearly
      bwd_uv.data = bwd.uv;
      for (int y = 0; y < fwd.height; ++y) {
        for (int x = 0; x < fwd.width; ++x) {
          const std::size_t p = std::size_t(y) * fwd.width + x;
          if (!fwd.valid[p] || flow_norm(fwd, p) <= 0.5) continue;
          const double qx = x + 0.5 + fwd.uv[p * 2], qy = y + 0.5 + fwd.uv[p * 2 + 1];
          // The backward flow must be known at all four bilinear taps around q.
          const int x0 = int(std::floor(qx - 0.5)), y0 = int(std::floor(qy - 0.5));
          bool known = true;
          for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
              const int xx = std::clamp(x0 + dx, 0, bwd.width - 1);
              const int yy = std::clamp(y0 + dy, 0, bwd.height - 1);
              known = known && bwd.valid[std::size_t(yy) * bwd.width + xx];
            }
          if (!known) continue;
          const double u = sample_bilinear(bwd_uv, qx, qy, 0);
          const double v = sample_bilinear(bwd_uv, qx, qy, 1);
          errors.push_back(std::hypot(fwd.uv[p * 2] + u, fwd.uv[p * 2 + 1] + v));
        }
      }
    }
  }
  ASSERT_GT(errors.size(), 5000u);  // measured: 8.2k moving pixels
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double under_half =
      double(std::lower_bound(errors.begin(), errors.end(), 0.5) - errors.begin()) / errors.size();
  // Measured (seed 0): median 0.0004 px, 96.7 % under half a pixel; the misses are bilinear taps
  // that straddle a motion boundary.
  EXPECT_LT(median, 0.01);
  EXPECT_GT(under_half, 0.93);
}

double fastest_motion(const io::Scene& scene) {
  double fastest = 0;
  for (int cam = 0; cam < int(scene.cameras.size()); ++cam) {
    for (int k = 0; k + 1 < scene.num_frames; ++k) {
      const Flow f = io::read_flo(scene.flow_path(cam, k, k + 1));
      for (std::size_t p = 0; p < f.pixels(); ++p)
        if (f.valid[p]) fastest = std::max(fastest, flow_norm(f, p));
    }
  }
  return fastest;
}

TEST(Synth, DefaultPresetHasAFastObjectAndFastPresetDoublesIt) {
  test::TempDir a, b;
  const double normal = fastest_motion(make_scene(a, small_options("default", 3, 3, 256, 192)));
  const double fast = fastest_motion(make_scene(b, small_options("fast", 3, 3, 256, 192)));
  // Measured (seed 0): 21 px per frame, and 46 px (2.2x) in the fast preset.
  EXPECT_GE(normal, 10.0);
  EXPECT_GT(fast, 1.6 * normal);
  EXPECT_LT(fast, 2.5 * normal);
}

TEST(Synth, OcclusionsMakeFlowUnknown) {
  test::TempDir dir;
  const io::Scene scene = make_scene(dir, small_options("default", 3, 5, 128, 96));
  std::size_t unknown = 0, total = 0, appearing = 0;
  const int last = scene.num_frames - 1;
  for (int cam = 0; cam < 3; ++cam) {
    for (int k = 0; k + 1 < scene.num_frames; ++k) {
      const Flow f = io::read_flo(scene.flow_path(cam, k, k + 1));
      for (std::size_t p = 0; p < f.pixels(); ++p) unknown += !f.valid[p];
      total += f.pixels();
    }
    // Foreground at the last frame that has no correspondence in the frame before: the sphere
    // that emerges from the box (and whatever the others uncover).
    const Image mask = media::read_mask(scene.mask_path(cam, last));
    const Flow back = io::read_flo(scene.flow_path(cam, last, last - 1));
    for (std::size_t p = 0; p < back.pixels(); ++p) appearing += mask.data[p] > 0 && !back.valid[p];
  }
  // Measured (seed 0): 1.3 % unknown, 93 appearing pixels.
  EXPECT_GT(unknown, 0u);
  EXPECT_LT(double(unknown) / total, 0.3);
  EXPECT_GT(appearing, 20u);
}

std::string file_bytes(const std::filesystem::path& path) {
  return test::read_text(path);
}

TEST(Synth, SameSeedGivesIdenticalFilesForAnyThreadCount) {
  test::TempDir dir;
  const int threads = max_threads();
  SynthOptions options = small_options("default", 2, 3, 64, 48);
  options.seed = 7;
  set_threads(1);
  const io::Scene one = make_scene(dir, options);
  set_threads(2);
  options.force = true;
  synthesize_scene(options, dir / "again");
  options.seed = 8;
  synthesize_scene(options, dir / "other");
  set_threads(threads);
  const io::Scene again = media::read_scene(dir / "again"),
                  other = media::read_scene(dir / "other");
  for (const auto& file :
       {std::filesystem::path("scene.json"), std::filesystem::path("points/00001.ply")})
    EXPECT_EQ(file_bytes(one.root / file), file_bytes(again.root / file)) << file;
  EXPECT_EQ(file_bytes(one.image_path(1, 2)), file_bytes(again.image_path(1, 2)));
  EXPECT_EQ(file_bytes(one.mask_path(1, 2)), file_bytes(again.mask_path(1, 2)));
  EXPECT_EQ(file_bytes(one.flow_path(1, 2, 0)), file_bytes(again.flow_path(1, 2, 0)));
  EXPECT_NE(file_bytes(one.image_path(1, 2)), file_bytes(other.image_path(1, 2)));
}

TEST(Synth, APerturbedCalibrationKeepsTheImagesAndWritesTheTruthBeside) {
  test::TempDir dir;
  SynthOptions options = small_options("minimal", 4, 2, 32, 24);
  options.seed = 5;
  const io::Scene truth = make_scene(dir, options);
  EXPECT_EQ(truth.calibration, io::CalibrationSource::kLab);
  EXPECT_FALSE(std::filesystem::exists(truth.root / io::kTrueCalibrationFile));
  options.perturb_calibration = io::CalibrationPerturbation{1.0, 0.02, 0.02};
  synthesize_scene(options, dir / "perturbed");
  const io::Scene perturbed = media::read_scene(dir / "perturbed");
  EXPECT_EQ(perturbed.calibration, io::CalibrationSource::kUser);
  // The images are the true cameras' ...
  for (int c = 0; c < 4; ++c)
    EXPECT_EQ(file_bytes(perturbed.image_path(c, 1)), file_bytes(truth.image_path(c, 1)));
  // ... scene.json holds them perturbed as io::perturb_calibration does with the seed ...
  const io::Scene expected = io::perturb_calibration(truth, *options.perturb_calibration, 5);
  for (int c = 0; c < 4; ++c) {
    EXPECT_GT((perturbed.cameras[c].center() - truth.cameras[c].center()).norm(), 1e-3);
    EXPECT_LT((perturbed.cameras[c].world_to_camera - expected.cameras[c].world_to_camera).norm(),
              1e-12);
    EXPECT_EQ(perturbed.cameras[c].fx, expected.cameras[c].fx);
  }
  // ... and the truth lies beside it as a rig file.
  EXPECT_EQ(test::read_text(dir / "perturbed" / io::kTrueCalibrationFile),
            io::rig_json(truth.cameras));
}

TEST(Synth, PointsLieOnTheObjectsOfTheirFrame) {
  test::TempDir dir;
  const io::Scene scene = make_scene(dir, small_options("default", 3, 3, 96, 72));
  // Points above the ground (world up is -y) belong to the moving objects.
  constexpr float kAboveGround = -0.01f;
  constexpr double kStageRadius = 8;  // metres: objects move within it; the sky dome is at 14
  std::vector<Eigen::Vector3d> object_centroids;
  for (int k = 0; k < scene.num_frames; ++k) {
    const io::PointCloud points = io::read_points_ply(scene.points_path(k));
    ASSERT_GE(points.size(), 1000u) << "frame " << k;  // measured: 14k
    ASSERT_LE(points.size(), 30000u) << "frame " << k;
    ASSERT_EQ(points.rgb.size(), points.xyz.size());
    // Foreground coverage of camera 0 (read_image keeps the fraction, read_mask thresholds it).
    const Image coverage = media::read_image(scene.mask_path(0, k));
    auto near_foreground = [&](const Eigen::Vector2d& uv) {
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = std::clamp(int(uv.x()) + dx, 0, coverage.width - 1);
          const int y = std::clamp(int(uv.y()) + dy, 0, coverage.height - 1);
          if (coverage.at(y, x, 0) > 0) return true;
        }
      return false;
    };
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    std::size_t objects = 0, unseen = 0, off_mask = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d x(points.xyz[i * 3], points.xyz[i * 3 + 1], points.xyz[i * 3 + 2]);
      ASSERT_TRUE(x.allFinite());
      bool seen = false;
      for (const Camera& cam : scene.cameras) {
        const Eigen::Vector3d xc = cam.world_to_cam(x);
        seen = seen || (xc.z() > 0 && cam.in_image(cam.project_cam(xc)));
      }
      unseen += !seen;
      if (x.y() >= kAboveGround || x.norm() > kStageRadius) continue;  // ground, sky dome
      ++objects;
      centroid += x;
      // A closed surface projects inside its own silhouette, hidden side included (within a pixel:
      // a sliver of surface may miss all the supersamples of its pixel).
      const Eigen::Vector2d uv = scene.cameras[0].project(x);
      if (!scene.cameras[0].in_image(uv) || !near_foreground(uv)) ++off_mask;
    }
    EXPECT_EQ(unseen, 0u) << "frame " << k;
    ASSERT_GT(objects, 500u) << "frame " << k;
    EXPECT_LT(double(off_mask) / objects, 0.002) << "frame " << k;  // measured: none
    object_centroids.push_back(centroid / double(objects));
  }
  // The orbiting sphere alone moves the centroid of the object points by centimetres per frame
  // (measured 6.5 cm).
  EXPECT_GT((object_centroids[1] - object_centroids[0]).norm(), 0.02);
}

void expect_error(const SynthOptions& options, const std::string& fragment) {
  test::TempDir dir;
  try {
    synthesize_scene(options, dir / "scene");
    ADD_FAILURE() << "no error for " << fragment;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "scene"));
}

TEST(Synth, BadOptionsNameTheOption) {
  const SynthOptions good = small_options("minimal", 1, 2, 16, 16);
  SynthOptions o = good;
  o.preset = "nope";
  expect_error(o, "--preset: unknown preset 'nope'");
  o = good;
  o.cameras = 0;
  expect_error(o, "--cameras: must lie in [1, 1000], got 0");
  o = good;
  o.frames = 1;
  expect_error(o, "--frames: must lie in [2, 100000], got 1");
  o = good;
  o.width = 7;
  expect_error(o, "--size 7x16: each side must lie in [8, 16384] pixels");
  // Checked before anything is allocated (100000x100000 ended in std::bad_alloc).
  o = good;
  o.width = o.height = 100000;
  expect_error(o, "--size 100000x100000");
  o = good;
  o.cameras = 1000000;
  expect_error(o, "--cameras: must lie in [1, 1000], got 1000000");
  o = good;
  o.height = 4;
  expect_error(o, "--size 16x4");
  o = good;
  o.supersample = 0;
  expect_error(o, "supersample: must be >= 1, got 0");
  o = good;
  o.perturb_calibration = io::CalibrationPerturbation{120, 0, 0};
  expect_error(o, "--perturb-calibration: the rotation (degrees) must lie in [0, 90], got 120");

  test::TempDir dir;
  std::filesystem::create_directories(dir / "taken");
  EXPECT_THROW(synthesize_scene(good, dir / "taken"), Error);
}

TEST(Synth, CommandLineWritesASceneAndRejectsBadFlags) {
  test::TempDir dir;
  const auto out = dir / "scene";
  auto ok = test::run_cli("synth --preset minimal --out " + out.string() +
                          " --cameras 2 --frames 2 --size 24x16 --seed 3 --threads 1");
  ASSERT_EQ(ok.status, 0) << ok.err;
  const io::Scene scene = media::read_scene(out);
  EXPECT_EQ(scene.cameras.size(), 2u);
  EXPECT_EQ(scene.cameras[1].name, "cam01");
  EXPECT_EQ(scene.cameras[0].width, 24);
  EXPECT_EQ(scene.num_frames, 2);
  EXPECT_TRUE(std::filesystem::exists(scene.flow_path(1, 1, 0)));
  EXPECT_EQ(scene.calibration, io::CalibrationSource::kLab);  // the exact cameras

  const auto perturbed = dir / "perturbed";
  ok = test::run_cli("synth --preset minimal --out " + perturbed.string() +
                     " --cameras 3 --frames 2 --size 24x16 --threads 1 "
                     "--perturb-calibration 0.5,0.01,0.01");
  ASSERT_EQ(ok.status, 0) << ok.err;
  EXPECT_EQ(media::read_scene(perturbed).calibration, io::CalibrationSource::kUser);
  EXPECT_TRUE(std::filesystem::exists(perturbed / io::kTrueCalibrationFile));
  auto amounts = test::run_cli("synth --preset minimal --out " + (dir / "c").string() +
                               " --perturb-calibration 0.5,0.01");
  EXPECT_EQ(amounts.status, 2);
  EXPECT_NE(amounts.err.find("--perturb-calibration"), std::string::npos) << amounts.err;

  auto exists = test::run_cli("synth --preset minimal --out " + out.string());
  EXPECT_EQ(exists.status, 2);
  EXPECT_NE(exists.err.find("already exists"), std::string::npos) << exists.err;
  auto size = test::run_cli("synth --preset minimal --out " + (dir / "b").string() + " --size 24");
  EXPECT_EQ(size.status, 2);
  EXPECT_NE(size.err.find("--size"), std::string::npos) << size.err;
}

}  // namespace
}  // namespace retimegs::synth

namespace retimegs::synth {
namespace {

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  return test::read_text(a) == test::read_text(b);
}

// A camera on its own clock shows the world at its own times: cam01 at +0.5 in one scene and at
// -0.5 in another see the same instants one frame apart (t = k + 0.5), images, masks and flows
// alike, bit for bit; the other cameras are the unshifted scene's; scene.json records the offset
// unless asked not to, and the unrecorded scene's files are the recorded one's.
TEST(Synth, TimeOffsetsRenderEachCameraAtItsOwnTimes) {
  test::TempDir dir;
  SynthOptions o = small_options("minimal", 2, 4, 48, 32);
  synthesize_scene(o, dir / "plain");
  o.time_offsets = {{"cam01", 0.5}};
  synthesize_scene(o, dir / "late");
  o.record_offsets = false;
  synthesize_scene(o, dir / "unrecorded");
  o.record_offsets = true;
  o.time_offsets = {{"cam01", -0.5}};
  synthesize_scene(o, dir / "early");
  const io::Scene plain = io::read_scene_json(dir / "plain");
  const io::Scene late = io::read_scene_json(dir / "late");
  const io::Scene early = io::read_scene_json(dir / "early");
  const io::Scene unrecorded = io::read_scene_json(dir / "unrecorded");
  ASSERT_EQ(late.clocks.size(), 2u);
  EXPECT_EQ(late.clocks[0].time_offset, 0);
  EXPECT_EQ(late.clocks[1].time_offset, 0.5);
  EXPECT_DOUBLE_EQ(io::frame_time(late, 1, 2), 2.5);
  EXPECT_TRUE(unrecorded.clocks.empty());
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(same_file(plain.image_path(0, k), late.image_path(0, k))) << k;
    EXPECT_FALSE(same_file(plain.image_path(1, k), late.image_path(1, k))) << k;
    EXPECT_TRUE(same_file(late.image_path(1, k), unrecorded.image_path(1, k))) << k;
    if (k + 1 < 4) {
      EXPECT_TRUE(same_file(late.image_path(1, k), early.image_path(1, k + 1))) << k;
      EXPECT_TRUE(same_file(late.mask_path(1, k), early.mask_path(1, k + 1))) << k;
    }
    if (k + 2 < 4) {
      EXPECT_TRUE(same_file(late.flow_path(1, k, k + 1), early.flow_path(1, k + 1, k + 2))) << k;
      EXPECT_TRUE(same_file(late.flow_path(1, k + 1, k), early.flow_path(1, k + 2, k + 1))) << k;
    }
  }
  // Points stay at the scene's frame times.
  EXPECT_TRUE(same_file(plain.points_path(1), late.points_path(1)));
  o.time_offsets = {{"cam07", 0.5}};
  EXPECT_THROW(synthesize_scene(o, dir / "bad"), Error);
  o.time_offsets = {{"cam01", std::nan("")}};
  EXPECT_THROW(synthesize_scene(o, dir / "bad"), Error);
}

}  // namespace
}  // namespace retimegs::synth
