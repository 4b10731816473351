// Per-frame point clouds imported from PLY files (`prepare --points ply DIR`).
#include "retimegs/core/error.hpp"
#include "retimegs/prepare/points.hpp"

namespace retimegs::prepare {

io::PointCloud read_frame_points(const std::filesystem::path& path) {
  if (!std::filesystem::is_regular_file(path)) fail("{}: no such file", path.string());
  io::PointCloud cloud = io::read_points_ply(path);  // rejects non-finite coordinates
  if (cloud.size() == 0)
    fail("{}: the point cloud is empty (at least 1 point needed)", path.string());
  return cloud;
}

}  // namespace retimegs::prepare
