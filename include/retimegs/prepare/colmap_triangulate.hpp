#pragma once
// `prepare --points colmap`: point triangulation with the scene's known poses through the COLMAP
// command-line tools (the model files it reads and writes are io/colmap.hpp).
#include <filesystem>
#include <string>

#include "retimegs/io/colmap.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::prepare {

struct ColmapOptions {
  std::string executable = "colmap";  // looked up on PATH unless it contains a '/'
  int max_image_size = 3200;          // --SiftExtraction.max_image_size
  int max_num_features = 8192;        // --SiftExtraction.max_num_features
  // --SiftExtraction.peak_threshold: below COLMAP's 0.0067, the faint texture of walls, floor
  // and dome (the background the hull leaves empty) gives features too, not only the people.
  double peak_threshold = 0.002;
  // --SiftMatching.guided_matching: once a pair's geometry is verified, match again along it,
  // recovering matches of repeated or faint texture that the ratio test alone rejects.
  bool guided_matching = true;
  int threads = -1;                   // COLMAP's num_threads (-1 = all cores)
  double max_reprojection_error = 4;  // --Mapper.filter_max_reproj_error, pixels
  // Points seen by fewer cameras are dropped: a two-view point only has to agree with one
  // epipolar line, so repeated texture makes many wrong ones; a third view rejects them.
  int min_track_length = 3;
  bool verbose = false;  // pass COLMAP's output through to stderr
};

// The COLMAP executable of options (PATH lookup); throws Error when it is not installed.
std::filesystem::path find_colmap(const ColmapOptions& options);
// Whether find_colmap() finds it.
bool colmap_available(const ColmapOptions& options);

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
