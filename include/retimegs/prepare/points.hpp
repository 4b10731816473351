#pragma once
// Per-frame point clouds for `retimegs prepare` (scene/points/<frame:05d>.ply): a visual hull
// carved from the masks, a random last resort, and import of per-frame PLY files. (COLMAP
// triangulation with the known poses lives in prepare/colmap_triangulate.hpp.)
#include <cstdint>
#include <filesystem>
#include <vector>

#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"

namespace retimegs::prepare {

struct HullOptions {
  // Voxels along the longest side of the grid, in the coarse pass over the cameras' common
  // region and in the fine pass over the coarse hull's bounding box.
  int resolution = 128;
  // k of k-of-n carving: how many of the cameras that see a voxel may have it outside their
  // silhouette (while at least 2 have it inside), where 10 or more see it or the frame's masks
  // disagree: tolerates a missing or bad mask in one view.
  int slack = 1;
  std::size_t max_points = 50000;  // visible surface points per frame, subsampled above this
  std::uint64_t seed = 0;          // of the in-voxel jitter and the subsampling
};

// Visual hull of the foreground at `frame` from the masks of `cameras` (scene camera indices):
//  1. bounds: a cube around the point nearest to every optical axis (least squares), with half
//     side the largest camera distance to it (the cameras' common look-at region); falls back to
//     io::cameras_look_box() when the axes are near-parallel (forward-facing rigs);
//  2. carve a coarse voxel grid over it, then a fine one over the kept voxels' bounding box. A
//     voxel is kept when at least half of the cameras (and 2) see it (its centre projects into
//     the image) and it lies inside the silhouette of every camera that sees it, or of all but
//     `slack` (and at least 2: k-of-n carving) where 10 or more see it or where the frame's masks
//     disagree (one blank, missing or partial mask carves away most of what the others keep).
//     Inside: within half the voxel's projected size of a
//     foreground pixel (half its diagonal in the coarse pass, which must not lose thin parts).
//     Cameras that do not see the voxel abstain, so that people cut by the image border of some
//     views survive;
//  3. the surface voxels (kept, with a carved 6-neighbour) give one point each, jittered inside
//     the voxel; the normal is the negated occupancy gradient over the 3x3x3 neighbourhood;
//  4. colour: the mean of the image colours of the cameras that see the point unoccluded
//     (z-test against a depth map of the surface points themselves), weighted by the cosine
//     between the normal and the direction to the camera. Points no camera sees are dropped.
// Throws Error naming a mask file when a camera has no mask at `frame`, and when the hull is
// empty (no foreground seen by all cameras).
io::PointCloud visual_hull(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                           const HullOptions& options = {});

// Last resort: `count` points uniform in io::cameras_look_box, uniform random colours; the same
// distribution as training's fallback when a scene has no points (which seeds 20 000 in total),
// written per frame so that a prepared scene is complete. Deterministic in (seed, frame).
io::PointCloud random_points(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                             std::size_t count, std::uint64_t seed = 0);

// A per-frame PLY to import (`--points ply DIR`: DIR/<frame:05d>.ply): x, y, z finite (checked by
// read_points_ply), at least one point. Throws Error naming the file.
io::PointCloud read_frame_points(const std::filesystem::path& path);

}  // namespace retimegs::prepare
