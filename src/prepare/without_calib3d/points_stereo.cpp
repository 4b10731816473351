// The lean GPU build (RETIMEGS_GPU_ONLY) has no OpenCV calib3d (StereoSGBM, rectification maps):
// pair stereo names what is missing and the point sources this build has.
#include "retimegs/prepare/points_stereo.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::prepare {

io::PointCloud stereo_points(const io::Scene&, const std::vector<int>&, int, const StereoOptions&) {
  fail(
      "--points stereo: needs OpenCV's calib3d, which the lean GPU build has not; --points hull, "
      "ply or random are built in");
}

}  // namespace retimegs::prepare
