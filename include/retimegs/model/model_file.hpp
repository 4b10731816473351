#pragma once
// The `.rgs` 4D model file: a versioned little-endian binary with a checksum.
//
//   bytes 0..7    magic "RETIMEGS"
//   u32           format version (1)
//   u32           header length H
//   H bytes       JSON header: primitive count, time grid, model config, field table
//                 ([{name, width, dtype "<f4", offset, bytes}], offsets from the data start),
//                 the training config (free-form JSON, for provenance) and, when training
//                 learned them, "camera_colors": {camera name: {"m": [3], "c": [3]}} (files
//                 without the key, as earlier builds wrote them, load with none) and, when
//                 training refined them, "camera_poses": {camera name: {"rotation": [3],
//                 "translation": [3]}} (model::CameraPose: ω in radians, |ω| < π, and τ in world
//                 units, both in camera axes; files without the key load with none) and, when
//                 training refined them, "camera_clocks": {camera name: δ}, the correction in
//                 frames added to the camera's clock (files without the key load with none) and,
//                 for a window model (train --window), "window": {"first", "last"}, its first and
//                 last training times (files without it hold the whole clip), and, for a merged
//                 model (merge), "seams": [times], the training times where two of its windows met,
//                 and "seam_fade": the edge scale there in training intervals (files without it
//                 use γ there, as at every other edge)
//   ...           the fields' raw float32 arrays, row-major, in table order
//   u64           FNV-1a 64 checksum of every preceding byte
//
// Written atomically; a truncated or corrupted file is refused, never half-loaded.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/model/camera_color.hpp"
#include "retimegs/model/camera_pose.hpp"
#include "retimegs/model/primitives.hpp"

namespace retimegs::model {

struct Model {
  Primitives primitives;
  TimeGrid grid;
  ModelConfig config;
  std::string training_config = "{}";  // JSON text, stored verbatim
  // Per training camera, by name: the colour correction learned for its images (empty when
  // training learned none). Other cameras render the model's colours.
  std::map<std::string, CameraColor> camera_colors;
  // Per training camera, by name: the pose correction training learned for it (empty when training
  // refined none). Scene cameras are drawn through it (seen_camera); other cameras as they are.
  std::map<std::string, CameraPose> camera_poses;
  // Per training camera whose clock training refined, by name: the correction δ in frames it
  // learned, added to the time of each of the camera's frames (the scene's clock gives the rest:
  // seen_time in playback/render_model.hpp).
  std::map<std::string, double> camera_clocks;
  // A window model (train --window): the training frames of `grid` it was trained on. `grid` stays
  // the whole clip's, so that windows share one grid; model/window.hpp draws such a model alone.
  std::optional<TimeWindow> window;
  // A merged model's seams and their fade are in `config` (ModelConfig::seams, seam_fade).
};

// The stored correction of the camera named `camera`, or nullptr when the model has none for it.
const CameraColor* find_camera_color(const Model& model, const std::string& camera);

// The stored pose correction of the camera named `camera`, or nullptr when the model has none.
const CameraPose* find_camera_pose(const Model& model, const std::string& camera);

// A scene camera as the model saw it in training, the one rule of every command that draws a scene
// camera through a model (render --camera and --path, eval, the viewer's cameras, export
// --calibration): through its stored pose correction, corrected(camera, pose), when the model
// refined the camera of that name; as it is otherwise (test cameras, a model that refined none).
// Cameras that are no scene camera (a camera path file's, those between a path's cameras) are not
// passed through it.
Camera seen_camera(const Model& model, const Camera& camera);

// The stored clock correction of the camera named `camera` in frames: 0 when the model has none.
double clock_correction(const Model& model, const std::string& camera);

// Throws Error "<what> is not finite: ..." or "<what> turns by ... not less than pi" unless the
// correction's six numbers are finite and its rotation angle |ω| is below π (beyond it the same
// rotation has a shorter axis-angle, which merge's mean and a regulariser would not see).
void check_camera_pose(const CameraPose& pose, const std::string& what);

// Throws Error, naming `what` and the first offending time, unless every time lies in the model's
// time range, its first to its last training frame: a trajectory is defined between its control
// points only, and beyond the range the last ones fly apart.
void check_times(const Model& model, const std::vector<double>& times, std::string_view what);

// Model files end in .rgs: a model written under another name (merge --out x.png) is a slip that
// leaves a model where an image is expected. Throws Error "<what> <path>: ..." otherwise.
void check_model_file_name(const std::filesystem::path& path, const std::string& what);

// Writes `path` atomically (check_model_file_name first); an existing `path` is replaced only with
// `replace` (core/atomic_file.hpp).
void write_model(const std::filesystem::path& path, const Model& model, bool replace = true);

// Throws Error naming the file and the problem (bad magic, unsupported version, malformed header,
// truncated data, checksum mismatch, non-finite values, an unknown field, a malformed camera
// colour or camera pose).
Model read_model(const std::filesystem::path& path);

}  // namespace retimegs::model
