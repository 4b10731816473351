#pragma once
// Camera paths for fly-throughs and bullet time: poses interpolated between named cameras
// (rotation by quaternion slerp, centre and intrinsics linearly).
#include <vector>

#include "retimegs/core/camera.hpp"

namespace retimegs {

// s = 0 gives a, s = 1 gives b. Both must have the same image size (throws Error otherwise).
Camera interpolate_camera(const Camera& a, const Camera& b, double s);

// Position s in [0, 1] along the polyline of cameras (s = 0: first, s = 1: last), each segment
// taking an equal share. One camera: that camera.
Camera camera_along_path(const std::vector<Camera>& path, double s);

}  // namespace retimegs
