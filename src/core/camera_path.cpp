#include "retimegs/core/camera_path.hpp"

#include <algorithm>
#include <cmath>

#include "retimegs/core/error.hpp"

namespace retimegs {

Camera interpolate_camera(const Camera& a, const Camera& b, double s) {
  if (a.width != b.width || a.height != b.height)
    fail("camera path: '{}' is {}x{} but '{}' is {}x{}; a path needs one image size", a.name,
         a.width, a.height, b.name, b.width, b.height);
  Camera c = a;
  c.name = s <= 0 ? a.name : s >= 1 ? b.name : a.name + "~" + b.name;
  c.fx = a.fx + s * (b.fx - a.fx), c.fy = a.fy + s * (b.fy - a.fy);
  c.cx = a.cx + s * (b.cx - a.cx), c.cy = a.cy + s * (b.cy - a.cy);
  const Eigen::Quaterniond qa(a.rotation()), qb(b.rotation());
  const Eigen::Matrix3d r = qa.slerp(s, qb).toRotationMatrix();
  const Eigen::Vector3d centre = a.center() + s * (b.center() - a.center());
  c.world_to_camera.setIdentity();
  c.world_to_camera.topLeftCorner<3, 3>() = r;
  c.world_to_camera.topRightCorner<3, 1>() = -r * centre;
  return c;
}

Camera camera_along_path(const std::vector<Camera>& path, double s) {
  if (path.empty()) fail("camera path: no cameras");
  if (path.size() == 1) return path[0];
  const double x = std::clamp(s, 0.0, 1.0) * double(path.size() - 1);
  const std::size_t i = std::min(std::size_t(x), path.size() - 2);
  return interpolate_camera(path[i], path[i + 1], x - double(i));
}

}  // namespace retimegs
