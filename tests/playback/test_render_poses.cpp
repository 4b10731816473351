// Scene cameras drawn through a model's pose corrections (issue 65): render's one camera and its
// path between scene cameras take the corrected ones, as the model saw them in training; a camera
// path file's cameras and a static model's are drawn as they are.
#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/core/camera_path.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/playback/shot.hpp"

namespace retimegs::playback {
namespace {

// About 3 px of turn and 1 px of shift at 40 px focal length and 4 units away.
const model::CameraPose kPose{{0.03, -0.05, 0.02}, {0.1, -0.05, 0.08}};

// The fixture's model with a pose correction of cam00.
model::Model refined(const test::TwoCameraCloud& f) {
  model::Model m = f.model;
  m.camera_poses["cam00"] = kPose;
  return m;
}

TEST(SeenCamera, A4dModelsCorrectionAppliesAStaticModelHasNone) {
  const test::TwoCameraCloud f;
  const Camera& cam0 = f.scene.cameras[0];
  EXPECT_EQ(seen_camera(LoadedModel{refined(f)}, cam0).world_to_camera,
            model::corrected(cam0, kPose).world_to_camera);
  EXPECT_EQ(seen_camera(LoadedModel{Splats{}}, cam0).world_to_camera, cam0.world_to_camera);
}

// The test that a corrected model's render of its training camera is what training compared with
// its images: the uncorrected model from the corrected camera, to the bit.
TEST(SceneShot, ARefinedCameraIsDrawnThroughItsCorrection) {
  const test::TwoCameraCloud f;
  const model::Model model = refined(f);
  const Camera &cam0 = f.scene.cameras[0], &cam1 = f.scene.cameras[1];
  const Camera seen0 = model::corrected(cam0, kPose);
  SceneShotRequest request;
  request.camera = "cam00";
  request.time = 1.0;
  const Shot shot = scene_shot(request, f.scene, model);
  EXPECT_EQ(shot_camera(shot, 0).world_to_camera, seen0.world_to_camera);
  EXPECT_EQ(shot_camera(shot, 0).name, "cam00");
  const float black[3] = {0, 0, 0};
  const ModelRenderer renderer(model);
  const Image image = renderer.render(shot_camera(shot, 0), 1.0, black, {}, shot_colors(shot));
  EXPECT_EQ(image.data, render_model(f.model, seen0, 1.0, black, {}, Colors::kCamera).data);
  EXPECT_GT(test::max_abs_diff(image, render_model(f.model, cam0, 1.0, black, {}, Colors::kCamera)),
            0.05)
      << "the correction moves the image";
  // A camera the model did not refine is drawn as the scene has it.
  request.camera = "cam01";
  EXPECT_EQ(scene_shot(request, f.scene, model).cameras[0].world_to_camera, cam1.world_to_camera);
  // Output size and correction together: the corrected camera at twice the size.
  request.camera = "cam00";
  request.size.scale = 2.0;
  const Camera big = scene_shot(request, f.scene, model).cameras[0];
  EXPECT_EQ(big.world_to_camera, seen0.world_to_camera);
  EXPECT_EQ(big.width, 2 * cam0.width);
}

TEST(SceneShot, APathMovesBetweenTheCorrectedCameras) {
  const test::TwoCameraCloud f;
  const model::Model model = refined(f);
  const Camera seen0 = model::corrected(f.scene.cameras[0], kPose);
  const Camera& cam1 = f.scene.cameras[1];
  SceneShotRequest request;
  request.path = {"cam00", "cam01"};
  request.time = 1.0;
  request.path_frames = 3;
  const Shot shot = scene_shot(request, f.scene, model);
  EXPECT_LT((shot_camera(shot, 0).world_to_camera - seen0.world_to_camera).norm(), 1e-12);
  EXPECT_LT((shot_camera(shot, 2).world_to_camera - cam1.world_to_camera).norm(), 1e-12);
  EXPECT_LT((shot_camera(shot, 1).center() - interpolate_camera(seen0, cam1, 0.5).center()).norm(),
            1e-12);
  EXPECT_GT((seen0.center() - f.scene.cameras[0].center()).norm(), 0.05);
}

// A camera path file is the user's: its cameras are drawn as given, whatever their names.
TEST(CameraPathShot, PathFileCamerasTakeNoCorrection) {
  const test::TwoCameraCloud f;
  io::CameraPathFile file;
  file.source = "camera_path.json";
  file.fps = 24;
  io::CameraPathFrame frame;
  frame.camera = f.scene.cameras[0];  // named cam00, as the refined camera is
  file.frames = {frame};
  const Shot shot = camera_path_shot(file, 1.0, refined(f), {});
  EXPECT_EQ(shot_camera(shot, 0).world_to_camera, f.scene.cameras[0].world_to_camera);
}

}  // namespace
}  // namespace retimegs::playback
