#pragma once
// The scene format of docs/formats.md, the contract every command and test uses:
//   scene/scene.json
//   scene/images/<camera>/<frame:05d>.png
//   scene/masks/<camera>/<frame:05d>.png                 optional, foreground > 127
//   scene/flow/<camera>/<from:05d>_<to:05d>.flo          optional
//   scene/points/<frame:05d>.ply                         optional
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "retimegs/core/camera.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/io/ply.hpp"

namespace retimegs::io {

// Where a camera's frames came from (`import videos`): scene frame k is source frame
// first_frame + k of `file`. Written to scene.json as the camera's "source" for the user's records;
// nothing reads it back.
struct CameraSource {
  std::string file;     // the video or image folder, its name in the footage folder
  int first_frame = 0;  // source frame of scene frame 0 (0-based, decoding order)
  int last_frame = 0;   // source frame of the last scene frame
  int offset = 0;       // the camera's --offsets value
  double fps = 0;       // the video's own frame rate; 0 for an image folder, which has none
};

// A camera's clock (docs/formats.md, "time_offset" and "frame_times"): when its frames show the
// scene. Frame k is at scene time (frame_times[k] when given, else k) + time_offset, in scene
// frame units. The default, frame k at t = k, is a genlocked rig's.
struct CameraClock {
  double time_offset = 0;           // any finite real, usually a fraction of a frame
  std::vector<double> frame_times;  // empty, or one per scene frame, finite, strictly increasing
  bool is_default() const { return time_offset == 0 && frame_times.empty(); }
};

// Where the cameras' calibration came from (scene.json "calibration"): a dataset's lab calibration,
// taken as exact, or one the user made (a rig file, a COLMAP model, COLMAP from scratch), a few
// pixels off, which training refines by default (train config refine_cameras).
enum class CalibrationSource { kLab, kUser };

// "lab" or "user", as scene.json writes it.
const char* calibration_source_name(CalibrationSource source);

// Where the cameras' clocks came from (scene.json "clocks"): given (genlocked footage, offsets or
// timestamps the user gave), taken as exact, or estimated from the footage (`import videos --sync
// auto`), which training refines by default (train config refine_clocks).
enum class ClockSource { kGiven, kEstimated };

// "given" or "estimated", as scene.json writes it.
const char* clock_source_name(ClockSource source);

struct Scene {
  std::filesystem::path root;
  int num_frames = 0;
  double fps = 0;
  std::vector<Camera> cameras;
  Eigen::Vector3d up{0, -1, 0};
  std::vector<CameraSource> sources;  // [C] as `cameras`, or empty when unknown
  // [C] as `cameras`, or empty: every camera's frame k at t = k. Read its times through
  // frame_time() only.
  std::vector<CameraClock> clocks;
  CalibrationSource calibration = CalibrationSource::kLab;  // scene.json without the key: lab
  ClockSource clock_source = ClockSource::kGiven;           // scene.json without the key: given

  // Index of the camera called `name`; throws Error naming it when absent.
  int camera_index(const std::string& name) const;

  std::filesystem::path json_path() const { return root / "scene.json"; }
  // These paths name the camera's folder by its name, checked by check_camera_name (so that no
  // name reaches outside the scene).
  std::filesystem::path image_path(int camera, int frame) const;
  std::filesystem::path mask_path(int camera, int frame) const;
  std::filesystem::path flow_path(int camera, int from, int to) const;
  std::filesystem::path points_path(int frame) const;
  // masks/estimated.json, written by `prepare --masks` beside the masks it writes: they are
  // approximate (they mark what moves, not all that is foreground), and the default points and
  // training treat a scene holding it as one without masks.
  std::filesystem::path estimated_masks_marker() const { return root / "masks" / "estimated.json"; }
};

// The scene time of camera `camera`'s frame `position` (scene index; frame k at position k), by
// its clock (CameraClock): the one place a frame's time is computed; training, eval, synth and
// render call it. A position between two frames lies on the straight line between their times,
// one outside the clip on the line through its two end frames (frame_times) or at position +
// time_offset. Equals `position` for a camera with the default clock.
double frame_time(const Scene& scene, int camera, double position);

// Whether any camera's clock is not the default one.
bool has_own_clocks(const Scene& scene);

// Throws Error naming `where` and the camera unless the clock is valid for `num_frames` frames:
// a finite time_offset, and frame_times empty or num_frames finite, strictly increasing values.
// read_scene_json and write_scene_json check each camera's with it.
void check_clock(const CameraClock& clock, int num_frames, const std::string& where);

// A camera name becomes a folder name: it must be one path component of at most 255 bytes, not
// empty, "." or "..", without '/', '\\' or control characters. Throws Error naming `where` and
// the name.
void check_camera_name(const std::string& name, const std::string& where);

// Reads and validates scene.json (required keys, types, finite numbers, positive sizes and
// intrinsics, rigid world_to_camera, unique camera names, fps > 0, num_frames >= 1). Throws
// Error naming the file and the field at fault. The image files are not looked at:
// media::read_scene reads this and checks them too.
Scene read_scene_json(const std::filesystem::path& root);

// Writes root/scene.json atomically (the images are the caller's business).
void write_scene_json(const Scene& scene);

// Throws Error naming `file` when its size (width x height) is not the camera's.
void check_file_size(const std::filesystem::path& file, const Camera& camera, int width,
                     int height);

// Loaders that check the size against the camera; errors name the file. The images and masks are
// media's (media/scene_images.hpp).
std::optional<Flow> load_flow(const Scene& scene, int camera, int from, int to);
std::optional<PointCloud> load_points(const Scene& scene, int frame);

}  // namespace retimegs::io
