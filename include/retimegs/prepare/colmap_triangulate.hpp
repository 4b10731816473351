#pragma once
// `prepare --points colmap`: point triangulation with the scene's known poses through the COLMAP
// command-line tools (colmap/run.hpp runs them; the model files it reads and writes are
// io/colmap.hpp).
#include <filesystem>
#include <string>

#include "retimegs/colmap/run.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::prepare {

// The COLMAP command line and its options are the colmap library's (retimegs/colmap/run.hpp).
using colmap::colmap_available;
using colmap::ColmapOptions;
using colmap::find_colmap;

// `prepare --points colmap`: triangulates a point cloud of scene frame `frame` from the images of
// the training cameras with their known poses and intrinsics. Writes into work_dir (created if
// needed; previous contents are replaced): images/<camera>.png, database.db, known/ (text model
// of the known cameras), sparse/ (COLMAP's output); each command's output goes to
// log_dir/<command>.log. Runs `colmap feature_extractor` (CPU SIFT, one PINHOLE camera per
// distinct intrinsics), `colmap exhaustive_matcher` (CPU) and `colmap point_triangulator`, then
// returns the points3D seen by at least options.min_track_length cameras, with their colours.
// Throws Error when COLMAP is not installed, when a command fails (what failed, in words where
// its log says why, its last error line and the log's path), or when no point results.
io::PointCloud triangulate_with_colmap(const io::Scene& scene, int frame,
                                       const std::filesystem::path& work_dir,
                                       const std::filesystem::path& log_dir,
                                       const ColmapOptions& options);

}  // namespace retimegs::prepare
