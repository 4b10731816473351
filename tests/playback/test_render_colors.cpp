// Which colours a render shows: a scene camera with a stored colour correction (a training
// camera) through it, any other camera and every camera path with the model's own.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "playback/two_camera_cloud.hpp"
#include "retimegs/core/camera.hpp"
#include "retimegs/io/frame_writer.hpp"
#include "retimegs/io/image_io.hpp"
#include "retimegs/playback/render_model.hpp"
#include "test_util.hpp"

namespace retimegs::playback {
namespace {
namespace fs = std::filesystem;

// The largest difference of a written frame from `image` as a PNG holds it: clamped to [0, 1],
// 8 bits (half a level).
void expect_written(const fs::path& png, Image image) {
  for (float& v : image.data) v = std::clamp(v, 0.0f, 1.0f);
  EXPECT_LT(test::max_abs_diff(io::read_image(png), image), 0.5 / 255 + 1e-6) << png;
}

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

TEST(RenderModel, OneCameraUsesItsColoursAPathTheModels) {
  test::TempDir dir;
  const test::TwoCameraCloud f;
  const float black[3] = {0, 0, 0};
  const Camera& cam0 = f.scene.cameras[0];
  {
    io::FrameWriter writer(dir / "one", 2, 24);
    render_frames(f.model, {cam0}, {0.5, 1.0}, black, writer);
  }
  {
    io::FrameWriter writer(dir / "path", 2, 24);
    render_frames(f.model, {cam0, f.scene.cameras[1]}, {1.0, 1.0}, black, writer);
  }
  expect_written(dir / "one" / "00001.png",
                 render_model(f.model, cam0, 1.0, black, {}, Colors::kCamera));
  // The path starts at cam00's pose, with the model's colours (no jump where it passes a camera).
  expect_written(dir / "path" / "00000.png", render_model(f.model, cam0, 1.0, black));
}

}  // namespace
}  // namespace retimegs::playback
