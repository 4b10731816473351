#pragma once
// What `retimegs render` draws in each output frame, a camera and a time, as its flags ask
// (docs/cli.md, `retimegs render`): one scene camera or a path through scene cameras (bullet time
// at one time) at the times of --time, --times, --slowmo or --retime, or a nerfstudio camera path
// file's camera per frame; then the render loop over those frames.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/io/camera_path_json.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/frame_writer.hpp"
#include "retimegs/playback/model_renderer.hpp"
#include "retimegs/playback/output_size.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/playback/times.hpp"
#include "retimegs/render/options.hpp"

namespace retimegs::playback {

// The frames of a render: frame f shows time times[f] from shot_camera(shot, f).
struct Shot {
  std::vector<double> times;  // [F] scene times
  // per_frame: [F], frame f's camera. Otherwise the cameras a path moves through, frame f at
  // s = f / (F - 1) along it (camera_along_path); one camera stays put.
  std::vector<Camera> cameras;
  bool per_frame = false;
  double fps = 0;  // the source's frame rate (the scene's, a camera path file's): a video's default
};

Camera shot_camera(const Shot& shot, int frame);

// One camera that stays put renders with its colours (Colors::kCamera: a training camera through
// its colour map); a path and per-frame cameras with the model's (the cameras between the named
// ones, and a camera path file's, have none).
Colors shot_colors(const Shot& shot);

// `retimegs render --camera | --path`, its flags parsed: exactly one of the times given.
struct SceneShotRequest {
  std::string camera;              // --camera NAME, unless a path is given
  std::vector<std::string> path;   // --path CAM,CAM,...: the scene cameras to move through
  int path_frames = 60;            // --path-frames: frames of a path at one time (bullet time)
  std::optional<double> time;      // --time T
  std::optional<TimeRange> times;  // --times A:B:STEP
  std::optional<int> slowmo;       // --slowmo F
  std::filesystem::path retime;    // --retime FILE (empty: none), read by media::read_retime_csv
  OutputSize size;                 // --size / --scale
  // --own-clock: with --camera, the times are positions among that camera's frames (frame k at
  // k), each drawn at its scene time on the camera's clock (io::frame_time), to reproduce its
  // frames; not with --slowmo or --path.
  bool own_clock = false;
};

// The frames of a scene request, at the scene's fps. --slowmo covers the model's time range, its
// first to last training frame (a static model's: the scene's frames 0 to num_frames - 1). A path
// at one time is held for path_frames frames (>= 1, at most kMaxOutputFrames). Every time must lie
// in a 4D model's time range (model::check_times); cameras are the scene's as the model saw them
// (seen_camera: a training camera through its pose correction), at the output size. A static model
// without a time gives one frame (time is ignored). Throws Error naming the flag, the camera or the
// time otherwise, and when no time is given for a 4D model.
Shot scene_shot(const SceneShotRequest& request, const io::Scene& scene, const LoadedModel& model);

// The frames of a nerfstudio camera path file (`render --camera-path`), at the file's fps: its
// cameras (the user's, drawn as the file gives them: no scene camera's correction) at the output
// size, each at `time` when given (a static model ignores time) or at its
// render_time over the model's time range (io::camera_path_times). Throws Error naming the file
// when a 4D model needs render_times the file lacks, and as scene_shot on a time out of range.
Shot camera_path_shot(const io::CameraPathFile& file, const std::optional<double>& time,
                      const LoadedModel& model, const OutputSize& size);

// Renders the frames of `shot` with `renderer` and shot_colors(shot) to `writer`, which is then
// finished; a writer that writes alpha gets ModelRenderer::render_rgba, any other
// ModelRenderer::render over `background` (3 values, RGB), and a writer that takes a depth pass
// each frame's too. Every frame renders with `options`; a progress bar is shown when there is more
// than one frame.
void render_shot(const ModelRenderer& renderer, const Shot& shot, const float* background,
                 media::FrameWriter& writer, const render::RenderOptions& options = {});

}  // namespace retimegs::playback
