#pragma once
// nerfstudio's camera path file (`camera_path.json`, written by its viewer's render panel and by
// Blender add-ons for `ns-render camera-path`): one camera per output frame.
//
//   render_width, render_height   image size in pixels (positive integers)
//   fps                           output frame rate (else len(camera_path) / seconds, as ns-render)
//   seconds                       clip length, used only when fps is absent
//   camera_type                   "perspective" (the default when absent); fisheye,
//                                 equirectangular, omnidirectional and vr180 are refused
//   camera_path[]                 the frames, already interpolated by the editor:
//     camera_to_world             16 numbers, a row-major 4x4 (or 4 rows of 4), OpenGL / Blender
//                                 camera axes (x right, y up, z backward)
//     fov                         vertical field of view in degrees, in (0, 180)
//     aspect                      optional, ignored: the image size decides (as in ns-render)
//     render_time                 optional, in [0, 1] over the clip; every entry or none
//   keyframes, crop, ...          ignored (the editor's state)
//
// Intrinsics: fy = fx = render_height / 2 / tan(fov / 2) (square pixels), principal point at the
// image centre. Poses are taken in the scene's world as they are: a path made in nerfstudio's
// viewer is in its dataparser's transformed world (auto-orient, centre, scale), which is the
// scene's world only when the scene was imported from that same frame.
#include <filesystem>
#include <optional>
#include <vector>

#include "retimegs/core/camera.hpp"

namespace retimegs::io {

struct CameraPathFrame {
  Camera camera;                      // OpenCV axes; named "camera_path[i]"
  std::optional<double> render_time;  // in [0, 1], when the file gives one
};

struct CameraPathFile {
  std::filesystem::path source;         // the file read, for messages
  std::vector<CameraPathFrame> frames;  // one per output frame, never empty
  double fps = 0;                       // > 0
  bool timed = false;                   // every frame has a render_time (else none has)
};

// Throws Error naming the file and the entry (camera_path[i].field) on a missing or malformed
// value: non-finite numbers, a camera_to_world that is not rigid, fov outside (0, 180), a
// render_time outside [0, 1] or on only some entries, a non-positive size or fps, an empty path,
// a camera_type other than perspective.
CameraPathFile read_camera_path_json(const std::filesystem::path& path);

// The scene times of a timed path: render_time 0 is `first`, 1 is `last` (linear in between).
// Throws Error naming the file when it has no render_time.
std::vector<double> camera_path_times(const CameraPathFile& file, double first, double last);

}  // namespace retimegs::io
