#pragma once
// A similarity of the world (scale, rotation, translation): what a calibration is known up to
// when nothing fixes its frame and scale (structure from motion; the cameras of a training run
// that refines them all). Errors of a calibration are measured after removing the best one.
#include <vector>

#include <Eigen/Core>

#include "retimegs/core/camera.hpp"

namespace retimegs {

// x -> scale * rotation * x + translation.
struct Similarity {
  double scale = 1;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d apply(const Eigen::Vector3d& x) const {
    return scale * rotation * x + translation;
  }
  Similarity inverse() const;
};

// The similarity that maps `from[i]` onto `to[i]` best in the least-squares sense (Umeyama 1991,
// Eigen::umeyama with scaling). Throws Error unless both hold the same number of points, three or
// more, and `from` spans more than a line (a similarity from fewer is not determined).
Similarity fit_similarity(const std::vector<Eigen::Vector3d>& from,
                          const std::vector<Eigen::Vector3d>& to);

// The same camera in the world that `s` maps to: centre s.apply(centre), world-to-camera rotation
// R s.rotation^T, intrinsics unchanged (the image is the same).
Camera transformed(const Camera& camera, const Similarity& s);

// The angle in degrees of the rotation between two cameras' orientations, R_a R_b^T.
double rotation_angle_degrees(const Camera& a, const Camera& b);

}  // namespace retimegs
