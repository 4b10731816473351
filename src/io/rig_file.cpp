#include "retimegs/io/rig_file.hpp"

#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"

namespace retimegs::io {

namespace {
// The scene format puts the centre of the top-left pixel at (0.5, 0.5), OpenCV at (0, 0).
constexpr double kSceneToOpenCv = -0.5;
}  // namespace

std::string rig_json(const std::vector<Camera>& cameras) {
  using json = nlohmann::json;
  json list = json::array();
  for (const Camera& cam : cameras) {
    const Eigen::Matrix3d r = cam.rotation();
    const Eigen::Vector3d t = cam.translation();
    list.push_back(
        {{"name", cam.name},
         {"K",
          {{cam.fx, 0.0, cam.cx + kSceneToOpenCv},
           {0.0, cam.fy, cam.cy + kSceneToOpenCv},
           {0.0, 0.0, 1.0}}},
         {"R",
          {{r(0, 0), r(0, 1), r(0, 2)}, {r(1, 0), r(1, 1), r(1, 2)}, {r(2, 0), r(2, 1), r(2, 2)}}},
         {"t", {t.x(), t.y(), t.z()}},
         {"width", cam.width},
         {"height", cam.height}});
  }
  return json{{"cameras", list}}.dump(2) + "\n";
}

void write_rig_file(const std::filesystem::path& file, const std::vector<Camera>& cameras) {
  write_text_file(file, rig_json(cameras));
}

}  // namespace retimegs::io
