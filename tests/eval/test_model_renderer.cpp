// eval's renderer of a model: each scene camera as it recorded (a training camera through its
// colour correction), at any time.
#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/eval/protocol.hpp"
#include "retimegs/model/camera_pose.hpp"

namespace retimegs::eval {
namespace {

TEST(ModelRenderer, ShowsEachSceneCameraAsItRecorded) {
  const test::TwoCameraCloud f;
  const FrameRenderer renderer = model_renderer(f.scene, f.model);
  const float black[3] = {0, 0, 0};
  // Between frames too: stability renders at fractional times.
  for (int c = 0; c < 2; ++c)
    for (const double t : {1.0, 0.5})
      EXPECT_EQ(renderer(c, t).data, playback::render_model(f.model, f.scene.cameras[c], t, black,
                                                            {}, playback::Colors::kCamera)
                                         .data)
          << c << " " << t;
  const Image own = playback::render_model(f.model, f.scene.cameras[0], 1.0, black);
  EXPECT_GT(test::max_abs_diff(renderer(0, 1.0), own), 0.05) << "cam00 through its correction";
  EXPECT_GT(test::max_abs_diff(renderer(1, 0.5), renderer(1, 1.0)), 0.01) << "the model moves";
}

}  // namespace
}  // namespace retimegs::eval

namespace retimegs::eval {
namespace {

// A camera on its own clock is rendered at its frame's own time (io::frame_time): camera 1, half a
// frame late, at frame position 1 shows time 1.5; camera 0 keeps t = k.
TEST(ModelRenderer, RendersEachCameraAtItsOwnClock) {
  test::TwoCameraCloud f;
  f.scene.clocks = {{}, {0.5, {}}};
  const FrameRenderer renderer = model_renderer(f.scene, f.model);
  const float black[3] = {0, 0, 0};
  const auto at = [&](int c, double t) {
    return playback::render_model(f.model, f.scene.cameras[c], t, black, {},
                                  playback::Colors::kCamera)
        .data;
  };
  EXPECT_EQ(renderer(1, 1.0).data, at(1, 1.5));
  EXPECT_EQ(renderer(1, 0.5).data, at(1, 1.0));
  EXPECT_EQ(renderer(0, 1.0).data, at(0, 1.0));
  EXPECT_NE(renderer(1, 1.0).data, at(1, 1.0)) << "the offset changes the render";
}

}  // namespace
}  // namespace retimegs::eval

namespace retimegs::eval {
namespace {

// Issue 65: a training camera's held-out frames are scored as the model saw the camera, through
// the pose correction training learned for it (the uncorrected model from the corrected camera);
// a test camera, which has none, as the scene has it.
TEST(ModelRenderer, DrawsATrainingCameraThroughItsPoseCorrection) {
  test::TwoCameraCloud f;
  f.scene.cameras[1].split = Split::kTest;
  model::Model refined = f.model;
  const model::CameraPose pose{{0.03, -0.05, 0.02}, {0.1, -0.05, 0.08}};
  refined.camera_poses["cam00"] = pose;
  const FrameRenderer renderer = model_renderer(f.scene, refined);
  const float black[3] = {0, 0, 0};
  const auto at = [&](const Camera& camera, double t) {
    return playback::render_model(f.model, camera, t, black, {}, playback::Colors::kCamera);
  };
  const Camera seen0 = model::corrected(f.scene.cameras[0], pose);
  EXPECT_EQ(renderer(0, 1.0).data, at(seen0, 1.0).data);
  EXPECT_EQ(renderer(0, 0.5).data, at(seen0, 0.5).data);
  EXPECT_GT(test::max_abs_diff(renderer(0, 1.0), at(f.scene.cameras[0], 1.0)), 0.05)
      << "the correction moves the image";
  EXPECT_EQ(renderer(1, 1.0).data, at(f.scene.cameras[1], 1.0).data);
}

}  // namespace
}  // namespace retimegs::eval
