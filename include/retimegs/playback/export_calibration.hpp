#pragma once
// `retimegs export --calibration`: a scene's cameras as a model saw them (model::seen_camera: each
// training camera through the pose correction training learned for it, test cameras as the scene
// has them), in the two forms `import videos --calib` reads, so that a capture can be imported
// again with the refined calibration, or the calibration taken to other tools (issue 65).
//
// - rig: an OpenCV-style rig file in JSON (docs/cli.md, "Rig file"): {"cameras": [{"name", "K",
//   "R", "t", "width", "height"}]}, K in OpenCV's pixel convention (the centre of the top-left
//   pixel at (0, 0): the principal point half a pixel less than the scene's), no distortion (a
//   scene's cameras are undistorted pinholes).
// - colmap: a COLMAP text model (cameras.txt, images.txt, an empty points3D.txt): camera k + 1 is
//   a PINHOLE camera (the scene's pixel convention, which COLMAP shares) and image k + 1,
//   `<name>.png`, its pose; `import videos --calib` names a camera after its image's file stem.
//
// Neither form has a split: import the test cameras again with `import videos --test-cameras`.
#include <filesystem>
#include <string>
#include <vector>

#include "retimegs/core/camera.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/model/model_file.hpp"

namespace retimegs::playback {

enum class CalibrationFormat { kRig, kColmap };

// "rig" | "colmap"; throws Error naming `flag` and the value otherwise.
CalibrationFormat parse_calibration_format(const std::string& text, const std::string& flag);

// The rig file's JSON text of `cameras` (in order), full double precision.
std::string rig_json(const std::vector<Camera>& cameras);

// The COLMAP model of `cameras` (in order): no points.
io::ColmapModel colmap_cameras(const std::vector<Camera>& cameras);

struct ExportedCalibration {
  int cameras = 0;    // written: every camera of the scene
  int corrected = 0;  // of them, drawn through a pose correction
  // Cameras the model holds a correction for that the scene has no camera of (a model trained on
  // another scene), sorted; their corrections are not written.
  std::vector<std::string> unmatched;
};

// Writes the cameras of `scene` as `model` saw them to `out` in `format`: a rig file (its name must
// end in .json) or a folder for COLMAP, whole or not at all, an existing one replaced only with
// `force`. Throws Error naming --out on a bad name or an existing output, and naming the camera
// whose name COLMAP's images.txt cannot hold (leading or trailing white space).
ExportedCalibration export_calibration(const model::Model& model, const io::Scene& scene,
                                       CalibrationFormat format, const std::filesystem::path& out,
                                       bool force);

}  // namespace retimegs::playback
