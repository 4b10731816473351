#pragma once
// One image of a model from a camera on the CPU: a 4D model (.rgs) at any real time, or a static
// 3DGS model; reading either from its file. playback::ModelRenderer (model_renderer.hpp) draws
// many images of one model, on the CPU with these functions or on the GPU.
#include <filesystem>
#include <optional>
#include <variant>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/core/splats.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"
#include "retimegs/render/options.hpp"

namespace retimegs::playback {

// The colours of a render. kModel: the model's own, those of the average training camera (no
// correction; test cameras, camera paths, export). kCamera: as the scene camera of that name
// recorded them, through its stored correction (model::Model::camera_colors) when it is a
// training camera, the model's own otherwise. The correction applies to the whole image,
// background included, as training compared it.
enum class Colors { kModel, kCamera };

// background: 3 values (RGB). One image on the CPU, as ModelRenderer draws it (from a copy of the
// model: ModelRenderer draws many).
Image render_model(const model::Model& model, const Camera& camera, double t,
                   const float* background, const render::RenderOptions& options = {},
                   Colors colors = Colors::kModel);

Image render_splats(const Splats& splats, const Camera& camera, const float* background,
                    const render::RenderOptions& options = {});

// A 4D model (.rgs) as render, export and the viewer draw it: a window model (train --window)
// over its own frames, as it was trained (model::window_view). Throws Error naming the file on a
// bad model.
model::Model read_4d_model(const std::filesystem::path& path);

// A model read from a file, by its extension: `.ply` is a static 3DGS model (Inria layout),
// anything else a 4D model (read_4d_model). Throws Error naming the file on a bad model.
using LoadedModel = std::variant<model::Model, Splats>;
LoadedModel load_model(const std::filesystem::path& path);

// A scene camera as `model` draws it: a 4D model's model::seen_camera (through the pose correction
// training learned for it, if any); a static model's as it is. render, eval and the viewer pass
// every scene camera they draw through a model through it, and no other camera.
Camera seen_camera(const LoadedModel& model, const Camera& camera);
// The scene time at which `model` draws scene camera `camera`'s frame position `position`: its
// clock's time (io::frame_time) plus the clock correction training learned for it
// (model::clock_correction; none for a static model). The one rule of every command that
// reproduces a camera's frames (eval, render --own-clock).
double seen_time(const LoadedModel& model, const io::Scene& scene, int camera, double position);

// The near plane of a command's model renders, in scene units: `near` (--near) when given, else
// the scene's (io::scene_near_plane). Throws Error naming --near unless it is finite and > 0.
double near_plane(const std::optional<double>& near, const io::Scene& scene);

// Render options with near plane `near`.
render::RenderOptions near_render_options(double near);

}  // namespace retimegs::playback
