// eval's renderer of a model: each scene camera as it recorded (a training camera through its
// colour correction), at any time.
#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/eval/protocol.hpp"

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
