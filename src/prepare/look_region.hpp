#pragma once
// The cameras' common look-at region, shared by the visual hull (its grid's bounds) and pair
// stereo (the scene depth that decides which pairs are usable and the disparities searched).
#include <vector>

#include <Eigen/Core>

#include "retimegs/io/scene.hpp"

namespace retimegs::prepare::detail {

// A cube about the least-squares nearest point to every optical axis of `cameras`, with half side
// the largest camera distance to it; io::cameras_look_box() when the axes are near-parallel
// (forward-facing rigs) or the point lies behind most cameras.
void common_region(const io::Scene& scene, const std::vector<int>& cameras, Eigen::Vector3d& lo,
                   Eigen::Vector3d& hi);

}  // namespace retimegs::prepare::detail
