// What render draws in each frame: the times its flags give over the model's time range (a static
// model's: the scene's clip), bullet time along a path of scene cameras, a camera path file's
// cameras at its render_times, at the output size; the colours of one camera and of a path.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/core/camera_path.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/playback/shot.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
namespace fs = std::filesystem;
using test::expect_error;

// A 4D model of no primitives whose time range, 0.5 to 1.5, is not the scene's clip (0 to 2).
LoadedModel empty_model() {
  model::Model m;
  m.grid = {0.5, 0.5, 3};
  return m;
}

SceneShotRequest at_camera(const std::string& camera) {
  SceneShotRequest request;
  request.camera = camera;
  return request;
}

double distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (a - b).norm();
}

TEST(SceneShot, SlowMotionCoversTheModelsTimeRangeOrAStaticModelsClip) {
  const test::TwoCameraCloud f;
  SceneShotRequest request = at_camera("cam01");
  request.slowmo = 4;
  const Shot shot = scene_shot(request, f.scene, empty_model());
  EXPECT_EQ(shot.times, (std::vector<double>{0.5, 0.75, 1, 1.25, 1.5}));
  const Shot still = scene_shot(request, f.scene, Splats{});
  ASSERT_EQ(still.times.size(), 9u);  // scene frames 0..2 at 4x
  EXPECT_EQ(still.times.back(), 2.0);
  // One camera, staying put, with its own colours, at the scene's frame rate.
  ASSERT_EQ(shot.cameras.size(), 1u);
  EXPECT_EQ(shot.cameras[0].name, "cam01");
  EXPECT_FALSE(shot.per_frame);
  EXPECT_EQ(shot_colors(shot), Colors::kCamera);
  EXPECT_EQ(shot.fps, 24);
  EXPECT_EQ(shot_camera(shot, 3).world_to_camera, f.scene.cameras[1].world_to_camera);
}

TEST(SceneShot, TimesAndRampsGiveOneFramePerTime) {
  const test::TwoCameraCloud f;
  SceneShotRequest request = at_camera("cam00");
  request.times = TimeRange{0.5, 1.5, 0.25};
  EXPECT_EQ(scene_shot(request, f.scene, empty_model()).times,
            (std::vector<double>{0.5, 0.75, 1, 1.25, 1.5}));
  test::TempDir dir;
  test::write_text(dir / "ramp.csv", "output_frame,t\n0,0.5\n2,1.5\n3,1.5\n");
  request.times.reset();
  request.retime = dir / "ramp.csv";
  EXPECT_EQ(scene_shot(request, f.scene, empty_model()).times,
            (std::vector<double>{0.5, 1.0, 1.5, 1.5}));
}

TEST(SceneShot, APathAtOneTimeIsBulletTime) {
  const test::TwoCameraCloud f;
  SceneShotRequest request;
  request.path = {"cam00", "cam01"};
  request.time = 1.0;
  request.path_frames = 5;
  const Shot shot = scene_shot(request, f.scene, empty_model());
  EXPECT_EQ(shot.times, std::vector<double>(5, 1.0));
  EXPECT_EQ(shot_colors(shot), Colors::kModel);
  const Eigen::Vector3d a = f.scene.cameras[0].center(), b = f.scene.cameras[1].center();
  EXPECT_LT(distance(shot_camera(shot, 0).center(), a), 1e-12);
  EXPECT_LT(distance(shot_camera(shot, 2).center(), (a + b) / 2), 1e-12);
  EXPECT_LT(distance(shot_camera(shot, 4).center(), b), 1e-12);
  // With a time range the camera moves while time runs: --path-frames does not apply.
  request.time.reset();
  request.times = TimeRange{0.5, 1.5, 0.5};
  const Shot moving = scene_shot(request, f.scene, empty_model());
  EXPECT_EQ(moving.times, (std::vector<double>{0.5, 1.0, 1.5}));
  EXPECT_LT(distance(shot_camera(moving, 1).center(), (a + b) / 2), 1e-12);
}

TEST(SceneShot, CamerasRenderAtTheOutputSize) {
  const test::TwoCameraCloud f;
  SceneShotRequest request = at_camera("cam00");
  request.time = 1.0;
  request.size.scale = 2.0;
  const Shot shot = scene_shot(request, f.scene, empty_model());
  EXPECT_EQ(shot.cameras[0].width, 80);
  EXPECT_EQ(shot.cameras[0].height, 60);
  EXPECT_EQ(shot.cameras[0].fx, 2 * f.scene.cameras[0].fx);
}

TEST(SceneShot, BadRequestsAreRefusedNamingTheFlag) {
  const test::TwoCameraCloud f;
  const LoadedModel model = empty_model();
  expect_error([&] { scene_shot(at_camera("cam00"), f.scene, model); },
               {"give one of --time, --times, --slowmo or --retime"});
  SceneShotRequest request = at_camera("cam00");
  request.time = 1.75;  // beyond the model's last training frame
  expect_error([&] { scene_shot(request, f.scene, model); }, {"render", "1.75", "time range"});
  // A static model has no time range, and needs no time: one frame.
  EXPECT_EQ(scene_shot(request, f.scene, Splats{}).times, std::vector<double>{1.75});
  EXPECT_EQ(scene_shot(at_camera("cam00"), f.scene, Splats{}).times, std::vector<double>{0.0});
  request = at_camera("cam07");
  request.time = 1.0;
  expect_error([&] { scene_shot(request, f.scene, model); }, {"cam07"});
  request.camera.clear();
  request.path = {"cam00", "cam01"};
  request.path_frames = 0;
  expect_error([&] { scene_shot(request, f.scene, model); }, {"--path-frames", ">= 1"});
  request.path_frames = 2'000'000;
  expect_error([&] { scene_shot(request, f.scene, model); }, {"--path-frames", "2000000 frames"});
}

// Three frames of a camera path file at cam00, between the cameras and at cam01.
io::CameraPathFile camera_path(const io::Scene& scene, bool timed) {
  io::CameraPathFile file;
  file.source = "path/camera_path.json";
  file.fps = 12.5;
  file.timed = timed;
  for (int k = 0; k < 3; ++k) {
    io::CameraPathFrame frame;
    frame.camera = interpolate_camera(scene.cameras[0], scene.cameras[1], k / 2.0);
    frame.camera.name = "camera_path[" + std::to_string(k) + "]";
    if (timed) frame.render_time = k / 2.0;
    file.frames.push_back(frame);
  }
  return file;
}

TEST(CameraPathShot, RenderTimesSpanTheModelsTimeRange) {
  const test::TwoCameraCloud f;
  const io::CameraPathFile file = camera_path(f.scene, true);
  const Shot shot = camera_path_shot(file, {}, empty_model(), {});
  EXPECT_EQ(shot.times, (std::vector<double>{0.5, 1.0, 1.5}));
  EXPECT_TRUE(shot.per_frame);
  EXPECT_EQ(shot_colors(shot), Colors::kModel);
  EXPECT_EQ(shot.fps, 12.5);
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(shot_camera(shot, k).world_to_camera, file.frames[k].camera.world_to_camera) << k;
  // --time holds every frame at one time; the output size applies to each camera.
  const Shot held = camera_path_shot(file, 0.75, empty_model(), {0, 0, 0.5});
  EXPECT_EQ(held.times, std::vector<double>(3, 0.75));
  EXPECT_EQ(held.cameras[2].width, 20);
}

TEST(CameraPathShot, AnUntimedPathNeedsATimeForA4dModel) {
  const test::TwoCameraCloud f;
  const io::CameraPathFile file = camera_path(f.scene, false);
  expect_error([&] { camera_path_shot(file, {}, empty_model(), {}); },
               {"path/camera_path.json", "render_time", "--time"});
  EXPECT_EQ(camera_path_shot(file, {}, Splats{}, {}).times, std::vector<double>(3, 0.0));
  expect_error([&] { camera_path_shot(file, 0.25, empty_model(), {}); }, {"render", "0.25"});
}

// The largest difference of a written frame from `image` as a PNG holds it: clamped to [0, 1],
// 8 bits (half a level).
void expect_written(const fs::path& png, Image image) {
  for (float& v : image.data) v = std::clamp(v, 0.0f, 1.0f);
  EXPECT_LT(test::max_abs_diff(media::read_image(png), image), 0.5 / 255 + 1e-6) << png;
}

// The frames of `shot` as PNGs in `folder`.
void render_to(const fs::path& folder, const model::Model& model, const Shot& shot) {
  const float black[3] = {0, 0, 0};
  media::FrameWriter writer(folder, int(shot.times.size()), 24);
  render_shot(ModelRenderer(model), shot, black, writer);
}

TEST(RenderShot, OneCameraUsesItsColoursAPathTheModels) {
  test::TempDir dir;
  const test::TwoCameraCloud f;
  const float black[3] = {0, 0, 0};
  const Camera &cam0 = f.scene.cameras[0], &cam1 = f.scene.cameras[1];
  render_to(dir / "one", f.model, {{0.5, 1.0}, {cam0}});
  render_to(dir / "path", f.model, {{1.0, 1.0}, {cam0, cam1}});
  render_to(dir / "frames", f.model, {{1.0, 0.5}, {cam1, cam0}, true});
  expect_written(dir / "one" / "00001.png",
                 render_model(f.model, cam0, 1.0, black, {}, Colors::kCamera));
  // The path starts at cam00's pose, with the model's colours (no jump where it passes a camera).
  expect_written(dir / "path" / "00000.png", render_model(f.model, cam0, 1.0, black));
  expect_written(dir / "path" / "00001.png", render_model(f.model, cam1, 1.0, black));
  // A camera per frame: each at its own time, with the model's colours.
  expect_written(dir / "frames" / "00000.png", render_model(f.model, cam1, 1.0, black));
  expect_written(dir / "frames" / "00001.png", render_model(f.model, cam0, 0.5, black));
  expect_error(
      [&] {
        render_to(dir / "mismatch", f.model, {{1.0, 0.5}, {cam0}, true});
      },
      {"1 cameras for 2 times"});
}

}  // namespace
}  // namespace retimegs::playback

namespace retimegs::playback {
namespace {

// --own-clock: the times are positions among the camera's frames, drawn at its own times (cam01
// a quarter frame late: positions 0.5..1.25 at 0.75..1.5); only with --camera, not --slowmo.
TEST(SceneShot, OwnClockDrawsTheCamerasFramesAtItsTimes) {
  test::TwoCameraCloud f;
  f.scene.clocks = {{}, {0.25, {}}};
  SceneShotRequest request = at_camera("cam01");
  request.times = TimeRange{0.5, 1.25, 0.25};
  request.own_clock = true;
  EXPECT_EQ(scene_shot(request, f.scene, empty_model()).times,
            (std::vector<double>{0.75, 1, 1.25, 1.5}));
  request.camera = "cam00";  // on the scene's clock
  EXPECT_EQ(scene_shot(request, f.scene, empty_model()).times,
            (std::vector<double>{0.5, 0.75, 1, 1.25}));
  request.camera = "cam01";
  request.times = TimeRange{1, 1.5, 0.5};  // 1.75 is beyond the model's range
  expect_error([&] { scene_shot(request, f.scene, empty_model()); }, {"render"});
  request.times.reset();
  request.slowmo = 2;
  expect_error([&] { scene_shot(request, f.scene, empty_model()); }, {"--own-clock", "--slowmo"});
}

}  // namespace
}  // namespace retimegs::playback
