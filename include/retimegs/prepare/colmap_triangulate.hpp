#pragma once
// `prepare --points colmap`: point triangulation with the scene's known poses through the COLMAP
// command-line tools (colmap/run.hpp runs them; the model files it reads and writes are
// io/colmap.hpp).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "retimegs/colmap/run.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::prepare {

// The COLMAP command line and its options are the colmap library's (retimegs/colmap/run.hpp).
using colmap::colmap_available;
using colmap::ColmapOptions;
using colmap::find_colmap;

// Two-view tracks. A point matched in only two views has to agree with one epipolar line, so
// repeated texture makes wrong ones that a third view would reject: a rig with enough cameras
// keeps points seen by ColmapOptions::min_track_length (3) or more. A rig of fewer than
// kTwoViewTrackCameras training cameras round its subject has neighbours more than 30 degrees
// apart, about the viewpoint change SIFT still matches across, so hardly any point is matched in
// three views: there points seen by two cameras are kept too, where their geometry is sound:
//  - triangulation angle (between the rays from the point to its two cameras) of at least
//    kTwoViewMinAngleDegrees: a matching error of s pixels moves a point at depth d by about
//    d s / (f sin angle) along its ray. At COLMAP's 1.5 degrees (enough where a third view checks
//    the point) one pixel at f = 500 is 7.6 % of the depth, at 5 degrees 2.3 %;
//  - mean reprojection error at most half of ColmapOptions::max_reprojection_error: two
//    observations split the distance to the epipolar line between them, so the mean error of a
//    two-view point is half its match's distance from that line; three views would have shown
//    a bad observation in the residuals of the others.
constexpr std::size_t kTwoViewTrackCameras = 12;
constexpr double kTwoViewMinAngleDegrees = 5;

// Whether a rig of `training_cameras` keeps two-view tracks (the rule above).
bool keeps_two_view_tracks(std::size_t training_cameras);

// The largest angle, in degrees, between the rays from x to the camera centres (0 for fewer than
// two centres).
double triangulation_angle_degrees(const Eigen::Vector3d& x,
                                   const std::vector<Eigen::Vector3d>& centres);

// Whether a triangulated point is kept: its track (centres: the camera centre of each of its
// observations) is at least options.min_track_length long, or, with `two_view_tracks`, two long
// and passing the angle and reprojection checks above.
bool keep_triangulated_point(const io::ColmapPoint& point,
                             const std::vector<Eigen::Vector3d>& centres, bool two_view_tracks,
                             const ColmapOptions& options);

// `prepare --points colmap`: triangulates a point cloud of scene frame `frame` from the images of
// the training cameras with their known poses and intrinsics. Writes into work_dir (created if
// needed; previous contents are replaced): images/<camera>.png, database.db, known/ (text model
// of the known cameras), sparse/ (COLMAP's output); each command's output goes to
// log_dir/<command>.log. Runs `colmap feature_extractor` (CPU SIFT, one PINHOLE camera per
// distinct intrinsics), `colmap exhaustive_matcher` (CPU) and `colmap point_triangulator`, then
// returns the points3D that keep_triangulated_point() keeps (two-view tracks where
// keeps_two_view_tracks() of the training cameras), with their colours.
// Throws Error when COLMAP is not installed, when a command fails (what failed, in words where
// its log says why, its last error line and the log's path), or when no point results.
io::PointCloud triangulate_with_colmap(const io::Scene& scene, int frame,
                                       const std::filesystem::path& work_dir,
                                       const std::filesystem::path& log_dir,
                                       const ColmapOptions& options);

}  // namespace retimegs::prepare
