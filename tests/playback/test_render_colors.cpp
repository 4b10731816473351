// Which colours a render shows: a scene camera with a stored colour correction (a training
// camera) through it, any other camera with the model's own (camera paths: test_shot.cpp).
#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/playback/render_model.hpp"

namespace retimegs::playback {
namespace {

TEST(RenderModel, ATrainingCameraRendersThroughItsCorrection) {
  const test::TwoCameraCloud f;
  const float black[3] = {0, 0, 0};
  const Camera& cam0 = f.scene.cameras[0];
  const Camera& cam1 = f.scene.cameras[1];
  const Image own = render_model(f.model, cam0, 1.0, black);
  Image corrected;
  model::apply_camera_color(own, f.model.camera_colors.at("cam00"), corrected);
  EXPECT_GT(test::max_abs_diff(own, corrected), 0.05) << "the correction changes the render";
  EXPECT_EQ(render_model(f.model, cam0, 1.0, black, {}, Colors::kCamera).data, corrected.data);
  // A camera without a correction renders the model's colours either way.
  EXPECT_EQ(render_model(f.model, cam1, 1.0, black, {}, Colors::kCamera).data,
            render_model(f.model, cam1, 1.0, black).data);
}

}  // namespace
}  // namespace retimegs::playback
