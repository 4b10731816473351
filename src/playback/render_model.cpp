#include "retimegs/playback/render_model.hpp"

#include <cmath>

#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/io/splat_ply.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/model/static_splats.hpp"
#include "retimegs/model/window.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/render/rasterize.hpp"

namespace retimegs::playback {

Image render_model(const model::Model& model, const Camera& camera, double t,
                   const float* background, const render::RenderOptions& options, Colors colors) {
  return ModelRenderer(model).render(camera, t, background, options, colors);
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

Camera seen_camera(const LoadedModel& model, const Camera& camera) {
  const auto* m = std::get_if<model::Model>(&model);
  return m ? model::seen_camera(*m, camera) : camera;
}

double seen_time(const LoadedModel& model, const io::Scene& scene, int camera, double position) {
  const auto* m = std::get_if<model::Model>(&model);
  const double t = io::frame_time(scene, camera, position);
  return m ? t + model::clock_correction(*m, scene.cameras.at(std::size_t(camera)).name) : t;
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
