#pragma once
// The calibration of `import videos` (--calib): a COLMAP sparse model or an OpenCV-style rig file
// (YAML / JSON, docs/cli.md "retimegs import videos"), or, without either, one recovered by
// COLMAP's mapper from synchronised frames of every camera. All become COLMAP cameras, so that
// detail::Undistorter resamples distorted footage exactly as `import colmap` does.
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "retimegs/colmap/run.hpp"
#include "retimegs/core/image.hpp"
#include "retimegs/io/colmap.hpp"

namespace retimegs::ingest::detail {

struct CalibratedCamera {
  std::string name;
  // Intrinsics and distortion as the equivalent COLMAP camera (PINHOLE, OPENCV, FULL_OPENCV,
  // OPENCV_FISHEYE for a rig; any model for a COLMAP model). Width and height 0: the rig gives no
  // size, the footage's is used.
  io::ColmapCamera intrinsics;
  Eigen::Matrix4d world_to_camera = Eigen::Matrix4d::Identity();  // rigid, OpenCV convention
  std::string where;  // names the source in errors: "<file>: camera '<name>'"
};

// A folder is a COLMAP model (the folder, its sparse/0 or sparse); a .yaml / .yml / .json file is
// a rig. Throws Error naming the path otherwise.
std::vector<CalibratedCamera> read_calibration(const std::filesystem::path& path);

// One camera per COLMAP image, named after the image file's stem (two images may share a stem:
// the caller refuses a camera that matches more than one).
std::vector<CalibratedCamera> read_colmap_calibration(const std::filesystem::path& dir);

// The rig file's cameras, in file order (checked: names unique, K / dist / R / t well formed,
// finite, R a rotation).
std::vector<CalibratedCamera> read_rig(const std::filesystem::path& file);

// The same from the file's text (`json`: JSON, else YAML); `file` names it in errors. The one
// parser behind read_rig, and the entry point of the fuzzing harness (fuzz/calibration_fuzz.cpp).
std::vector<CalibratedCamera> read_rig_text(std::string_view text, bool json,
                                            const std::string& file);

// `camera` resized to width x height: focal lengths and principal point scaled, distortion kept
// (it acts on normalised coordinates). Size 0 (a rig without size) takes the footage's; a
// different aspect ratio is an error naming `footage`.
io::ColmapCamera fit_to_footage(io::ColmapCamera camera, int width, int height,
                                const std::string& where, const std::string& footage);

// A calibration recovered from the images (recover_calibration).
struct RecoveredCalibration {
  std::vector<CalibratedCamera> cameras;  // the registered cameras, sorted by name
  std::vector<std::string> unregistered;  // cameras COLMAP could not place, sorted
  std::size_t points = 0;                 // 3-D points of the model
  double reprojection_error = 0;          // pixels, mean over every observation of those points
  bool moving = false;  // placed by moving features (else from the reference frame alone)
  // The reconstructions combined (combine_reconstructions), the largest spread of a camera there,
  // and which camera.
  int reconstructions = 0;
  double spread = 0;
  std::string spread_camera;
};

// A per-pixel median needs three frames to tell what stands still from what passes.
constexpr int kMinInstants = 3;

// The synchronised frames of the calibration: frame(c, k) is camera c's frame at instant k <
// instants, the same instant for every camera; called from several threads at once.
struct CalibrationFrames {
  int instants = 0;
  std::function<Image(std::size_t camera, int instant)> frame;
};

// Structure from motion on a rig of static cameras; work_dir/images/<camera>.png holds each of
// `cameras`' reference frame (written by the caller), the size of every frame. With
// kMinInstants or more instants, the cameras are first placed by the features on what moves
// (calibration_features.hpp: a repeated static background cannot mislead them), matched within
// each instant, then refined with every feature, static ones included, that agrees with that
// placement; each step imports the features and matches into COLMAP (feature_importer,
// matches_importer: COLMAP verifies each pair's geometry) and runs its mapper, each refinement's
// model then tightened (tighten, below), logs in log_dir/<step>/. Where the footage moves too
// little to place three cameras so (both of a rig of two), or with fewer instants, COLMAP's own
// features of the reference frames are matched and mapped instead (feature_extractor,
// exhaustive_matcher, mapper; logs in log_dir). Every camera is one of its own (the cameras of a
// rig differ), of options.camera_model (one of kRecoveredCameraModels). The placement from the
// mapping on (the mapper's models keep the one that registers the most cameras) runs
// kReconstructions times (recover_calibration.cpp says why; once for a rig of two cameras, which a
// combination cannot align), the second's and third's logs in log_dir/run2, run3; the runs are
// combined (combine_reconstructions, in the frame of the one that registers the most cameras), the
// points triangulated anew with those cameras held (point_triangulator), and the model written to
// model_dir as a COLMAP text model (a later `import videos --calib model_dir` reads it back). Poses
// are up to a similarity (COLMAP's frame and scale). Rigs of few cameras keep the tracks seen by
// two cameras only, which COLMAP ignores by default (recover_calibration.cpp:
// keep_two_view_tracks). Throws Error when a command fails (colmap/run.hpp), when fewer than two
// cameras register, naming the mapper's log, or when no point can be triangulated from the
// cameras placed, naming the triangulator's log; each says what to try.
RecoveredCalibration recover_calibration(const std::vector<std::string>& cameras,
                                         const CalibrationFrames& frames,
                                         const std::filesystem::path& work_dir,
                                         const std::filesystem::path& model_dir,
                                         const std::filesystem::path& log_dir,
                                         const colmap::ColmapOptions& options, bool progress);

// Reconstructions of one rig (COLMAP models whose images are the rig's cameras, each image with a
// camera of its own) combined into one in the first's frame: each of the others aligned to the
// first by the similarity (Eigen::umeyama, with scale) between the centres of the cameras both
// placed (three or more; one sharing fewer is left out), then every camera of the first takes the
// placement, pose and intrinsics from one reconstruction, whose centre lies nearest the others'
// (the smallest sum of distances; the earlier on ties): a camera one run places apart does not
// move it. The first's images and cameras, no points.
struct CombinedReconstructions {
  io::ColmapModel model;
  // Per image of the first, in its order: the largest distance of a reconstruction's (aligned)
  // centre from the chosen one, over the largest distance of the first's centres from their mean.
  std::vector<double> spread;
};
CombinedReconstructions combine_reconstructions(const std::vector<io::ColmapModel>& models);

// A refinement's COLMAP model (model_dir, with its tracks, as the mapper writes them) with its
// observations trimmed: those farther than a step's reprojection error from their point's
// projection removed (point_filtering) and the model adjusted again (bundle_adjuster, principal
// points included in a model of four cameras or more, the distortion in one of three or more), one
// round per step (recover_calibration.cpp says which and why), each into
// work_dir/{filtered,adjusted}<round>, logs in log_dir/tighten<round>/. Returns the last adjusted
// model's folder.
std::filesystem::path tighten(const std::filesystem::path& exe,
                              const std::filesystem::path& model_dir,
                              const std::filesystem::path& work_dir,
                              const std::filesystem::path& log_dir,
                              const colmap::ColmapOptions& options);

}  // namespace retimegs::ingest::detail
