// ModelRenderer::render_rgba: alpha is the rasteriser's accumulated opacity and RGB the straight
// colour, so compositing over any background gives the render over that background, through a
// training camera's colour map too.
#include <cmath>

#include <gtest/gtest.h>

#include "retimegs/core/camera.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/render/rasterize.hpp"
#include "soft_cloud.hpp"

namespace retimegs::playback {
namespace {

// A few soft primitives in the middle of a 40x30 view (the border stays empty); camera cam00 has
// a stored colour correction.
model::Model cloud() {
  model::Model model = test::soft_cloud(
      {.count = 12, .seed = 5, .spread = 0.4f, .scale = 0.12f, .opacity_logit = {}});
  model.camera_colors["cam00"] = {{0.3f, -0.2f, 0.1f}, {0.05f, -0.02f, 0.03f}};
  return model;
}

Camera view(const std::string& name) {
  Camera cam;
  cam.name = name;
  cam.width = 40, cam.height = 30;
  cam.fx = cam.fy = 40, cam.cx = 20, cam.cy = 15;
  cam.world_to_camera = look_at({0.3, 0, -4.0}, {0, 0, 0}, {0, -1, 0});
  return cam;
}

TEST(RenderAlpha, CompositingTheStraightRgbaGivesTheRender) {
  const ModelRenderer renderer(cloud());
  const model::Model& m = std::get<model::Model>(renderer.model());
  const float bg[3] = {0.9f, 0.4f, 0.1f};
  for (const char* name : {"cam00", "cam01"}) {  // with and without a colour map
    const Camera cam = view(name);
    const Image rgba = renderer.render_rgba(cam, 1.0, {}, Colors::kCamera);
    const Image over_bg = renderer.render(cam, 1.0, bg, {}, Colors::kCamera);
    ASSERT_EQ(rgba.channels, 4);
    // The alpha channel is the rasteriser's.
    const auto raster = render::rasterize_forward(
        model::slice(m.primitives, m.config, m.grid, 1.0, cam, {}).gaussians, cam, bg);
    // The background as the camera's map shows it.
    float mapped[3];
    for (int c = 0; c < 3; ++c) {
      const model::CameraColor* color = model::find_camera_color(m, name);
      mapped[c] = color ? std::exp(color->m[c]) * bg[c] + color->c[c] : bg[c];
    }
    int empty = 0, partial = 0;
    for (std::size_t i = 0; i < rgba.pixels(); ++i) {
      const float a = rgba.data[4 * i + 3];
      EXPECT_EQ(a, raster.blend.alpha[i]);
      empty += a == 0;
      partial += a > 0.05f && a < 0.95f;
      for (int c = 0; c < 3; ++c) {
        const float straight = rgba.data[4 * i + c];
        if (a == 0) {
          EXPECT_EQ(straight, 0.0f);
        }
        EXPECT_NEAR(a * straight + (1 - a) * mapped[c], over_bg.data[3 * i + c], 1e-5)
            << name << " pixel " << i << " channel " << c;
      }
    }
    EXPECT_GT(empty, 0) << name;  // the test sees transparent and partly covered pixels
    EXPECT_GT(partial, 20) << name;
  }
}

}  // namespace
}  // namespace retimegs::playback
