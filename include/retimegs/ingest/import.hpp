#pragma once
// Importers from public dataset layouts and from your own capture into the scene format
// (docs/cli.md, `retimegs import`; docs/formats.md).
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace retimegs::ingest {

struct ImportOptions {
  int first_frame = 0;
  int last_frame = -1;     // inclusive; -1 = to the end of the source
  double downscale = 1.0;  // image size divided by this (intrinsics follow)
  bool force = false;      // replace an existing output folder
  bool progress = true;
};

// Dynamic3DGaussians layout of CMU Panoptic: train_meta.json / test_meta.json,
// ims/<cam>/<frame:06d>.jpg, seg/<cam>/<frame:06d>.png. Camera names are the Panoptic ids as
// decimal strings; cameras of test_meta.json get split "test". Masks are copied where present.
void import_panoptic(const std::filesystem::path& source, const std::filesystem::path& out,
                     const ImportOptions& options);

// Neural3DV / DyNeRF: poses_bounds.npy ([N, 17] float64: the 3x5 LLFF matrix [R | t | (h, w, f)]
// row-major, columns (down, right, back) camera-to-world, then near and far) and one video per
// camera, cam00.mp4, cam01.mp4, ... (sorted by name, one per row), decoded with OpenCV's FFmpeg
// backend. Cameras are named after the videos ("cam00", ...), the principal point is the image
// centre, fps is the first video's. DyNeRF holds cam00 out: it gets split "test" (when there is
// more than one camera). The intrinsics follow the video size when it differs from (w, h).
void import_n3dv(const std::filesystem::path& source, const std::filesystem::path& out,
                 const ImportOptions& options);

// COLMAP project: a sparse model (source itself, source/sparse/0 or source/sparse; .bin or .txt)
// and its images in source/images (or beside the model: ../images, ../../images). A static
// capture: one scene frame at 30 fps; cameras are named after the image file names without
// extension (folders joined with '_' where the stems alone collide). Distorted camera models
// are resampled into pinhole cameras of the same size (import_common.hpp: Undistorter); the
// model's points become points/00000.ply.
void import_colmap(const std::filesystem::path& source, const std::filesystem::path& out,
                   const ImportOptions& options);

// nerfstudio / instant-ngp transforms.json (see import_nerfstudio.cpp for the grouping rule of
// frames into scene frames and cameras).
void import_nerfstudio(const std::filesystem::path& source, const std::filesystem::path& out,
                       const ImportOptions& options);

// The COLMAP camera models a calibration is recovered with (VideosOptions::camera_model), one
// focal length each: SIMPLE_RADIAL with one radial distortion term (a lens as it comes),
// SIMPLE_PINHOLE without (footage undistorted already: a distortion term fitted there trades
// against the focal length and, with it, the camera's distance, and has the frames resampled).
inline constexpr std::array<std::string_view, 2> kRecoveredCameraModels = {"SIMPLE_RADIAL",
                                                                           "SIMPLE_PINHOLE"};

// A user's own capture (`retimegs import videos`; docs/cli.md gives the rig file format). Source:
// one video per camera (<camera>.mp4 / .mov / .mkv / .avi, decoded with OpenCV's FFmpeg backend)
// or one folder of images per camera (<camera>/, PNG / JPEG sorted by name); folders without
// images are skipped (a COLMAP model may sit beside the footage). Camera names are the stems /
// folder names, sorted. The calibration is a COLMAP sparse model (the COLMAP image whose file
// stem is the camera's name) or an OpenCV-style rig file (.yaml / .yml / .json: per camera K,
// dist, R, t, world-to-camera); intrinsics follow the footage size when it differs (same aspect
// ratio), distorted cameras are resampled into pinhole ones as `import colmap` does. Every
// camera needs a calibration; calibrated cameras without footage are left out (listed in the
// report). Without a calibration, COLMAP recovers one from synchronised frames of every camera
// (calibration.hpp: recover_calibration), fixed over the clip and written to SCENE/calibration/
// (a COLMAP text model, reusable as --calib); its logs go to SCENE/logs/colmap/calibration/ (also
// when it fails: the folder SCENE then holds them alone, and a later import may replace it
// without --force). Cameras it cannot place are left out (listed in the report). No masks are
// written.
struct VideosOptions {
  std::filesystem::path calibration;  // COLMAP model folder, or rig .yaml / .yml / .json; empty:
                                      // recovered from the footage by COLMAP
  // Without a calibration: the scene frame (after --frames and offsets) COLMAP calibrates from;
  // absent: the middle one, (frames - 1) / 2.
  std::optional<int> calibration_frame;
  // Without a calibration: how many frames of every camera, spread over the frames every camera
  // has (before --frames), COLMAP places the cameras by what moves in (at least 3 for that; fewer
  // or a static capture: the calibration frame alone); absent: 17.
  std::optional<int> calibration_instants;
  // Without a calibration: the camera model (one of kRecoveredCameraModels); absent: the first.
  std::optional<std::string> camera_model;
  std::vector<std::string> test_cameras;  // get split "test"
  // Synchronisation (--offsets CAM:X): camera c's source frame j shows the scene at time j - X,
  // so that scene frame k is its source frame k + X. X may be a fraction (split_offset): scene
  // frame k of c is its source frame k + N, N = X rounded, and its clock's time_offset is N - X.
  // Where a negative offset leaves no source frame at k = 0, the scene starts at the first k that
  // every camera has.
  std::map<std::string, double> offsets;
  // Synchronisation estimated from the footage (--sync auto; sync.hpp): every camera's --offsets
  // value is minus its lag against the first camera's motion energy, searched within
  // ±sync_max_lag frames (absent: default_max_lag of the frames every camera has); the scene's
  // clocks are then "estimated". Not with `offsets` (which it would replace) or `timestamps`.
  bool sync_auto = false;
  std::optional<int> sync_max_lag;
  // Per-frame timestamps (--timestamps FILE; timestamps.hpp): the cameras' frame_times, relative
  // to the first camera's scene frame 0. With whole-frame `offsets` only: they choose the source
  // frames, the timestamps say when those show the scene.
  std::filesystem::path timestamps;
  std::optional<double> fps;  // overrides the videos' rate; image folders alone: 30 when absent
};

// An --offsets value X split into whole frames and the camera's clock: scene frame k is source
// frame k + frames, which shows the scene at time k + time_offset. frames is X rounded to the
// nearest integer (halves away from zero), time_offset = frames - X, within [-0.5, 0.5]. Throws
// Error naming --offsets unless X is finite and within the frame limit (core/limits.hpp).
struct WholeOffset {
  int frames = 0;
  double time_offset = 0;
};
WholeOffset split_offset(double x);

struct VideosReport {
  int cameras = 0, test_cameras = 0, frames = 0;
  int first_frame = 0;  // k of scene frame 0 (source frame k + offset of each camera)
  double fps = 0;
  std::string fps_source;   // how fps was chosen, for the log
  std::string calibration;  // "COLMAP model <dir>", "rig file <file>" or how it was recovered
  // A recovered calibration: its cameras (registered), those left out, its points and mean
  // reprojection error in pixels.
  bool recovered = false;
  int registered = 0;
  std::vector<std::string> unregistered;
  std::size_t points = 0;
  double reprojection_error = 0;
  bool moving_features = false;  // placed by what moves (else from the calibration frame alone)
  // COLMAP's reconstructions combined into the calibration; the largest distance of one's centre
  // for a camera from the centre kept, as a fraction of the rig's extent (the largest distance of
  // a camera centre from their mean), and which camera.
  int reconstructions = 0;
  double spread = 0;
  std::string spread_camera;
  int undistorted = 0;  // cameras resampled from a distorted model into pinhole ones
  std::vector<std::string> without_footage;  // calibrated cameras without footage (left out)
  // --sync auto: every camera (footage order, the reference first) with its estimated --offsets
  // value, its peak correlation with the reference, and why it is not to be trusted (empty: it
  // is); the bound the lags were searched within.
  struct SyncedCamera {
    std::string name;
    double offset = 0, peak = 1;
    std::string weak;
  };
  std::vector<SyncedCamera> sync;
  int sync_max_lag = 0;
};

VideosReport import_videos(const std::filesystem::path& source, const std::filesystem::path& out,
                           const ImportOptions& options, const VideosOptions& videos);

}  // namespace retimegs::ingest
