#pragma once
// The calibration of `import videos` (--calib): a COLMAP sparse model or an OpenCV-style rig file
// (YAML / JSON, docs/cli.md "retimegs import videos"). Both become COLMAP cameras, so that
// detail::Undistorter resamples distorted footage exactly as `import colmap` does.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

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

}  // namespace retimegs::ingest::detail
