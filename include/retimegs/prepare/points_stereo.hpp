#pragma once
// Dense points from pairs of cameras (`retimegs prepare --points stereo`): for the few-camera rigs
// where COLMAP's multi-view triangulation finds few points (DESIGN.md §4 "Few cameras").
#include <cstddef>
#include <vector>

#include "retimegs/io/ply.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::prepare {

// Two cameras (scene indices) matched as a rectified pair; `left` has `right` on its +x side
// after rectification (rows are epipolar lines, disparity left minus right is > 0).
struct StereoPair {
  int left = 0, right = 0;
  double axis_angle = 0;           // degrees between the optical axes
  double triangulation_angle = 0;  // degrees between the rays from the scene centre to each
};

// A pair is usable when its optical axes are within kMaxStereoAxisAngle of each other (beyond,
// foreshortening and occlusions make a surface patch look too different in the two views for
// window matching, and rectification stretches the images) and the cameras' rays meet at the
// scene centre (the cameras' common look-at point, as the visual hull bounds it) at
// kMinStereoTriangulationAngle or more (below, one pixel of disparity is several per cent of the
// depth at the resolutions matched: the baseline is too short for the scene's depth).
constexpr double kMaxStereoAxisAngle = 40;          // degrees
constexpr double kMinStereoTriangulationAngle = 4;  // degrees
// Each camera is matched with at most this many partners (the usable ones with the smallest axis
// angle): a dense rig gives every surface from several pairs anyway, and the time grows with the
// pairs.
constexpr int kMaxStereoPartners = 2;

// The usable pairs among `cameras` by the rule above, each unordered pair once, in ascending
// (min, max) camera order. Empty when none is usable.
std::vector<StereoPair> stereo_pairs(const io::Scene& scene, const std::vector<int>& cameras);

struct StereoOptions {
  std::size_t max_points = 50000;  // per frame, after fusion (voxel grid coarsened until below)
  // Disparity search range at the matching resolution: the images are downscaled until the depth
  // range [kStereoNearFraction, kStereoFarFraction] x (distance to the scene centre) spans at most
  // this many pixels of disparity (a multiple of 16, OpenCV's StereoSGBM).
  int max_disparities = 256;
};

// Depths searched, as fractions of the left camera's distance to the scene centre: a subject
// within half that distance of the centre.
constexpr double kStereoNearFraction = 0.5;
constexpr double kStereoFarFraction = 1.5;

// Dense points of `frame` from the pairs of stereo_pairs(scene, cameras). Per pair: both images
// (area-downscaled to the matching resolution) rectified to a common rotation whose x axis is the
// baseline; OpenCV's StereoSGBM (3-way) with a uniqueness ratio and a speckle filter, left to right
// and right to left (the mirrored images); a pixel is kept when both disparities agree within one
// pixel, it lies inside the left camera's mask when that view has one at `frame`, and its depth in
// the searched range. Back-projected to world points with the left image's colour. Fusion: the
// points of every pair, less those that a camera with a mask at `frame` sees off its foreground
// (beyond half a per cent of the image width), averaged per voxel (position and colour), the voxel
// grid made coarser until at most `max_points` remain; deterministic. Throws Error when no pair is
// usable (naming the cameras' count and the rule) and when the pairs give no point at `frame`.
io::PointCloud stereo_points(const io::Scene& scene, const std::vector<int>& cameras, int frame,
                             const StereoOptions& options = {});

}  // namespace retimegs::prepare
