#pragma once
// What pair selection and pair matching share (points_stereo.hpp).
#include <vector>

#include <Eigen/Core>

#include "retimegs/io/scene.hpp"

namespace retimegs::prepare::detail {

// The centre of the cameras' common look-at region (look_region.hpp): the scene depth of a pair.
Eigen::Vector3d scene_centre(const io::Scene& scene, const std::vector<int>& cameras);

// Angle between two vectors, degrees.
double angle_degrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

}  // namespace retimegs::prepare::detail
