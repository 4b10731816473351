#include "retimegs/playback/render_model.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/slice.hpp"
#include "retimegs/model/static_splats.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::playback {

Image render_model(const model::Model& model, const Camera& camera, double t,
                   const float* background, const render::RenderOptions& options, Colors colors) {
  const model::TimeSlice sliced =
      model::slice(model.primitives, model.config, model.grid, t, camera, {});
  Image image =
      render::rasterize_forward(sliced.gaussians, camera, background, options).blend.image;
  if (colors == Colors::kCamera)
    if (const model::CameraColor* color = model::find_camera_color(model, camera.name))
      model::apply_camera_color(image, *color, image);
  return image;
}

Image render_splats(const Splats& splats, const Camera& camera, const float* background,
                    const render::RenderOptions& options) {
  return render::rasterize_forward(model::splats_to_gaussians(splats, camera), camera, background,
                                   options)
      .blend.image;
}

model::Model read_4d_model(const std::filesystem::path& path) {
  return model::window_view(model::read_model(path));
}

LoadedModel load_model(const std::filesystem::path& path) {
  check_input_file(path, "a model");
  if (path.extension() == ".ply") return io::read_splat_ply(path);
  return read_4d_model(path);
}

Image render_loaded(const LoadedModel& model, const Camera& camera, double t,
                    const float* background, const render::RenderOptions& options, Colors colors) {
  if (const auto* splats = std::get_if<Splats>(&model))
    return render_splats(*splats, camera, background, options);
  return render_model(std::get<model::Model>(model), camera, t, background, options, colors);
}

Image render_loaded_rgba(const LoadedModel& model, const Camera& camera, double t,
                         const render::RenderOptions& options, Colors colors) {
  const float black[3] = {0, 0, 0};
  render::RenderOutput out;
  const model::CameraColor* color = nullptr;
  if (const auto* splats = std::get_if<Splats>(&model)) {
    render::rasterize_forward(model::splats_to_gaussians(*splats, camera), camera, black, options,
                              out);
  } else {
    const model::Model& m = std::get<model::Model>(model);
    const model::TimeSlice sliced = model::slice(m.primitives, m.config, m.grid, t, camera, {});
    render::rasterize_forward(sliced.gaussians, camera, black, options, out);
    if (colors == Colors::kCamera) color = model::find_camera_color(m, camera.name);
  }
  // Over black the image is the premultiplied colour sum_i c_i alpha_i T_i: divided by alpha it
  // is the straight colour. The colour map is affine per channel, so it maps a composite as
  // map(C + T b) = alpha map(C / alpha) + T map(b): it applies to the straight colour.
  Image rgb = std::move(out.blend.image);
  const std::size_t n = rgb.pixels();
  for (std::size_t i = 0; i < n; ++i) {
    const float a = out.blend.alpha[i];
    for (int c = 0; c < 3; ++c) rgb.data[3 * i + c] = a > 0 ? rgb.data[3 * i + c] / a : 0.0f;
  }
  if (color) model::apply_camera_color(rgb, *color, rgb);
  Image rgba(rgb.width, rgb.height, 4);
  for (std::size_t i = 0; i < n; ++i) {
    const float a = out.blend.alpha[i];
    for (int c = 0; c < 3; ++c) rgba.data[4 * i + c] = a > 0 ? rgb.data[3 * i + c] : 0.0f;
    rgba.data[4 * i + 3] = a;
  }
  return rgba;
}

double near_plane(const std::optional<double>& near, const io::Scene& scene) {
  if (!near) return io::scene_near_plane(scene);
  if (!(std::isfinite(*near) && *near > 0))
    fail("--near: must be a finite number > 0, got {}", *near);
  return *near;
}

render::RenderOptions near_render_options(double near) {
  render::RenderOptions options;
  options.near_plane = float(near);
  return options;
}

}  // namespace retimegs::playback
