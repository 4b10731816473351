// eval's renderer of a model: each scene camera as it recorded (a training camera through its
// colour correction), at any time.
#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/eval/protocol.hpp"

namespace retimegs::eval {
namespace {

TEST(ModelRenderer, ShowsEachSceneCameraAsItRecorded) {
  const test::TwoCameraCloud f;
  const float black[3] = {0, 0, 0};
  const Camera& cam0 = f.scene.cameras[0];
  const Camera& cam1 = f.scene.cameras[1];
  const FrameRenderer renderer = model_renderer(f.scene, f.model);
  const Image own = playback::render_model(f.model, cam0, 1.0, black);
  EXPECT_GT(test::max_abs_diff(renderer(0, 1.0), own), 0.05) << "cam00 through its correction";
  EXPECT_EQ(renderer(0, 1.0).data,
            playback::render_model(f.model, cam0, 1.0, black, {}, playback::Colors::kCamera).data);
  EXPECT_EQ(renderer(1, 1.0).data, playback::render_model(f.model, cam1, 1.0, black).data);
  // Between frames too: stability renders at fractional times.
  const Image between = playback::render_model(f.model, cam1, 0.5, black);
  EXPECT_GT(test::max_abs_diff(between, renderer(1, 1.0)), 0.01) << "the model changes in time";
  EXPECT_EQ(renderer(1, 0.5).data, between.data);
}

}  // namespace
}  // namespace retimegs::eval
