#pragma once
// SIFT features of a static camera over several synchronised instants, split into what stands
// still and what moves, and their matches between two cameras (recover_calibration.cpp).
//
// Why: a rig's static background may repeat all round (a dome's panels, tiled walls, the other
// cameras), and its features then match between views that see different walls; COLMAP's
// verification accepts such pairs when the repeats are regular enough. What moves (people,
// objects) differs from one instant to the next, so the features on it, matched only between the
// same instant of two cameras, cannot pair the wrong places of a repeated background. They place
// the cameras roughly; the static features, kept only where they agree with that placement, make
// the calibration precise.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "retimegs/core/image.hpp"

namespace retimegs::ingest::detail {

constexpr int kStaticInstant = -1;  // Feature::instant of the static background's features

struct Feature {
  float x = 0, y = 0;  // pixels, COLMAP's convention: the top-left pixel's centre is (0.5, 0.5)
  float scale = 0, orientation = 0;  // pixels, radians (COLMAP's feature file)
  int instant = kStaticInstant;      // index into the camera's instants, or kStaticInstant
};

struct CameraFeatures {
  std::vector<Feature> features;          // [N]
  std::vector<std::uint8_t> descriptors;  // [N, 128] SIFT, as COLMAP stores them
  int moving = 0;                         // features with an instant
};

// The features of one camera from its frames frame(k), k < instants (at least 3, one size), taken
// at the same instants as every other camera's: static ones on the per-pixel median of the
// frames (what stands still over the instants), moving ones on each frame where it differs from
// that median. Each frame is kept as 8-bit grey only. At most max_features per image.
CameraFeatures camera_features(int instants, const std::function<Image(int)>& frame,
                               int max_features);

using Matches = std::vector<std::pair<int, int>>;  // feature indices (a, b)

// Mutual nearest neighbours that pass the ratio test, moving features matched only within the
// same instant, static ones only with static ones; `moving` and `still` choose which.
Matches match_features(const CameraFeatures& a, const CameraFeatures& b, bool moving, bool still);

// The camera's features as a COLMAP feature file (`colmap feature_importer`: <image>.txt).
void write_colmap_features(const CameraFeatures& features, const std::filesystem::path& file);

// The distance in pixels of b's point from the epipolar line of a's point, for pinhole cameras
// K = (f, cx, cy) in COLMAP's pixel convention and world-to-camera poses.
double epipolar_distance(const Eigen::Matrix3d& fundamental, const Feature& a, const Feature& b);
Eigen::Matrix3d fundamental_matrix(const Eigen::Matrix3d& k_a, const Eigen::Matrix4d& pose_a,
                                   const Eigen::Matrix3d& k_b, const Eigen::Matrix4d& pose_b);

// One camera's placement by a model: pinhole intrinsics (COLMAP's pixel convention) and pose.
struct Placement {
  Eigen::Matrix3d k;
  Eigen::Matrix4d world_to_camera;
  int larger_side = 0;  // pixels
};

// The matches a refinement maps: for each pair (a, b), a < b, of the cameras in pair order, those
// of candidates[pair] that lie within tolerance x the larger image side of the epipolar line of
// the two cameras' placements. A pair with a camera that has no placement gets none: such a
// camera had all its evidence (its moving matches) in the guide already, so a refinement could
// only register it from the same too-weak evidence, and when COLMAP did, it was wrong and pulled
// the cameras around it off (a Panoptic camera that sees the floor and one person: 26-150 % of
// the rig's extent off, its neighbours 20 %). It stays unregistered, and says so.
std::vector<Matches> agreeing_matches(const std::vector<std::optional<Placement>>& placed,
                                      const std::vector<CameraFeatures>& features,
                                      const std::vector<Matches>& candidates, double tolerance);

}  // namespace retimegs::ingest::detail
