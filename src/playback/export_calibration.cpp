#include "retimegs/playback/export_calibration.hpp"

#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"

namespace retimegs::playback {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {
// The scene format and COLMAP put the centre of the top-left pixel at (0.5, 0.5), OpenCV's K at
// (0, 0): the rig's principal point is half a pixel less (ingest's rig reader adds it back).
constexpr double kColmapToOpenCv = 0.5;
}  // namespace

CalibrationFormat parse_calibration_format(const std::string& text, const std::string& flag) {
  if (text == "rig") return CalibrationFormat::kRig;
  if (text == "colmap") return CalibrationFormat::kColmap;
  fail("{}: '{}' is not rig or colmap", flag, text);
}

std::string rig_json(const std::vector<Camera>& cameras) {
  json list = json::array();
  for (const Camera& c : cameras) {
    const Eigen::Matrix3d r = c.rotation();
    const Eigen::Vector3d t = c.translation();
    json rotation = json::array();
    for (int i = 0; i < 3; ++i) rotation.push_back({r(i, 0), r(i, 1), r(i, 2)});
    list.push_back({{"name", c.name},
                    {"K",
                     {{c.fx, 0.0, c.cx - kColmapToOpenCv},
                      {0.0, c.fy, c.cy - kColmapToOpenCv},
                      {0.0, 0.0, 1.0}}},
                    {"R", rotation},
                    {"t", {t.x(), t.y(), t.z()}},
                    {"width", c.width},
                    {"height", c.height}});
  }
  return json{{"cameras", list}}.dump(2) + "\n";
}

io::ColmapModel colmap_cameras(const std::vector<Camera>& cameras) {
  io::ColmapModel model;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    const Camera& c = cameras[k];
    // images.txt's NAME is the rest of the line after white space: a leading space would be lost.
    if (!c.name.empty() && c.name.front() == ' ')
      fail("camera '{}': a COLMAP model cannot hold a name that starts with a space", c.name);
    const auto id = std::uint32_t(k + 1);
    model.cameras.push_back({id, "PINHOLE", c.width, c.height, {c.fx, c.fy, c.cx, c.cy}});
    model.images.push_back(
        io::ColmapImage::from_world_to_camera(id, id, c.name + ".png", c.world_to_camera));
  }
  return model;
}

ExportedCalibration export_calibration(const model::Model& model, const io::Scene& scene,
                                       CalibrationFormat format, const fs::path& out, bool force) {
  if (format == CalibrationFormat::kRig && out.extension() != ".json")
    fail("--out: a rig file is written as JSON, its name ending in .json, got '{}'", out.string());
  check_output_free(out, force);
  ExportedCalibration result;
  std::vector<Camera> cameras;
  for (const Camera& c : scene.cameras) {
    cameras.push_back(model::seen_camera(model, c));
    if (model::find_camera_pose(model, c.name)) ++result.corrected;
  }
  result.cameras = int(cameras.size());
  for (const auto& entry : model.camera_poses) {
    const std::string& name = entry.first;
    bool found = false;
    for (const Camera& c : scene.cameras) found = found || c.name == name;
    if (!found) result.unmatched.push_back(name);
  }
  if (format == CalibrationFormat::kRig) {
    write_text_file(out, rig_json(cameras), /*replace=*/force);
  } else {
    const io::ColmapModel colmap = colmap_cameras(cameras);
    AtomicDirectory dir(out, force);
    io::write_colmap_model_txt(colmap, dir.temp_path());
    dir.commit();
  }
  return result;
}

}  // namespace retimegs::playback
