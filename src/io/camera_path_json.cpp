#include "retimegs/io/camera_path_json.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/io/json_file.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// v as a finite double; the message names the file and the field.
double finite_number(const json& v, const std::string& file, const std::string& field) {
  if (!v.is_number()) fail("{}: {} must be a number, got {}", file, field, v.dump());
  const double x = v.get<double>();
  if (!std::isfinite(x)) fail("{}: {} must be finite, got {}", file, field, x);
  return x;
}

const json& required(const json& object, const char* key, const std::string& file,
                     const std::string& where) {
  if (!object.contains(key)) fail("{}: {} is missing required key '{}'", file, where, key);
  return object[key];
}

int image_size(const json& root, const char* key, const std::string& file) {
  const double x = finite_number(required(root, key, file, "the top level"), file, key);
  if (!(x >= 1) || x != std::floor(x))
    fail("{}: {} must be a positive integer, got {}", file, key, x);
  check_image_side(x, fmt::format("{}: {}", file, key));
  return int(x);
}

// The camera types of nerfstudio's CameraType that a path file names, all but perspective
// refused: the rasterizer projects through a pinhole only.
void check_camera_type(const json& root, const std::string& file) {
  if (!root.contains("camera_type")) return;  // ns-render's default: perspective
  const json& v = root["camera_type"];
  if (!v.is_string()) fail("{}: camera_type must be a string, got {}", file, v.dump());
  std::string type = v.get<std::string>();
  std::transform(type.begin(), type.end(), type.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  if (type == "perspective") return;
  if (type == "fisheye" || type == "equirectangular" || type == "omnidirectional" ||
      type == "vr180")
    fail("{}: camera_type '{}' is not supported: retimegs renders perspective cameras only", file,
         v.get<std::string>());
  fail("{}: unknown camera_type '{}' (perspective is supported)", file, v.get<std::string>());
}

// camera_to_world as 16 numbers (row-major, as nerfstudio writes it) or 4 rows of 4.
Eigen::Matrix4d matrix(const json& v, const std::string& file, const std::string& field) {
  Eigen::Matrix4d m;
  if (v.is_array() && v.size() == 16) {
    for (int k = 0; k < 16; ++k)
      m(k / 4, k % 4) = finite_number(v[k], file, fmt::format("{}[{}]", field, k));
    return m;
  }
  const bool rows =
      v.is_array() && v.size() == 4 &&
      std::all_of(v.begin(), v.end(), [](const json& r) { return r.is_array() && r.size() == 4; });
  if (!rows) fail("{}: {} must be 16 numbers (a row-major 4x4 matrix)", file, field);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      m(r, c) = finite_number(v[r][c], file, fmt::format("{}[{}][{}]", field, r, c));
  return m;
}

}  // namespace

CameraPathFile read_camera_path_json(const fs::path& path) {
  const std::string file = path.string();
  const json root = read_json_file(path, "camera path");
  if (!root.is_object()) fail("{}: a camera path must be a JSON object", file);
  check_camera_type(root, file);
  const int width = image_size(root, "render_width", file);
  const int height = image_size(root, "render_height", file);
  const json& entries = required(root, "camera_path", file, "the top level");
  if (!entries.is_array() || entries.empty())
    fail("{}: camera_path must be a non-empty array (one camera per output frame)", file);
  check_frame_count(long(entries.size()), fmt::format("{}: camera_path", file));

  CameraPathFile out;
  out.source = path;
  if (root.contains("fps")) {
    out.fps = finite_number(root["fps"], file, "fps");
    check_fps(out.fps, fmt::format("{}: fps", file));
  } else if (root.contains("seconds")) {
    const double seconds = finite_number(root["seconds"], file, "seconds");
    if (!(seconds > 0)) fail("{}: seconds must be positive, got {}", file, seconds);
    out.fps = double(entries.size()) / seconds;
    check_fps(out.fps,
              fmt::format("{}: {} frames in {} seconds: fps", file, entries.size(), seconds));
  } else {
    fail("{}: has neither 'fps' nor 'seconds' (the output frame rate)", file);
  }

  for (std::size_t i = 0; i < entries.size(); ++i) {
    const json& e = entries[i];
    const std::string where = fmt::format("camera_path[{}]", i);
    if (!e.is_object()) fail("{}: {} must be an object", file, where);
    const std::string c2w_field = where + ".camera_to_world";
    const Eigen::Matrix4d c2w =
        matrix(required(e, "camera_to_world", file, where), file, c2w_field);
    check_rigid(c2w, fmt::format("{}: {}", file, c2w_field));
    for (int r = 0; r < 3; ++r)  // the camera centre
      check_coordinate(c2w(r, 3), fmt::format("{}: {}[{}][3]", file, c2w_field, r));
    const double fov = finite_number(required(e, "fov", file, where), file, where + ".fov");
    if (!(fov > 0 && fov < 180))
      fail("{}: {}.fov must be in (0, 180) degrees (vertical field of view), got {}", file, where,
           fov);
    if (e.contains("aspect")) {
      const double aspect = finite_number(e["aspect"], file, where + ".aspect");
      if (!(aspect > 0)) fail("{}: {}.aspect must be positive, got {}", file, where, aspect);
    }
    CameraPathFrame frame;
    Camera& cam = frame.camera;
    cam.name = where;
    cam.split = Split::kTest;  // not a training camera: no colour correction of its own
    cam.width = width, cam.height = height;
    cam.fy = 0.5 * height / std::tan(0.5 * fov * std::numbers::pi / 180.0);
    cam.fx = cam.fy;
    cam.cx = 0.5 * width, cam.cy = 0.5 * height;
    cam.world_to_camera = world_to_camera_from_opengl(c2w);
    if (e.contains("render_time")) {
      const double t = finite_number(e["render_time"], file, where + ".render_time");
      if (!(t >= 0 && t <= 1))
        fail("{}: {}.render_time must be in [0, 1] (normalised over the clip), got {}", file, where,
             t);
      frame.render_time = t;
    }
    if (i > 0 && frame.render_time.has_value() != out.frames[0].render_time.has_value())
      fail("{}: {} {} 'render_time' but camera_path[0] {}; give every entry one or none", file,
           where, frame.render_time ? "has" : "has no",
           out.frames[0].render_time ? "has one" : "has none");
    out.frames.push_back(std::move(frame));
  }
  out.timed = out.frames[0].render_time.has_value();
  return out;
}

std::vector<double> camera_path_times(const CameraPathFile& file, double first, double last) {
  if (!file.timed) fail("{}: camera_path entries have no 'render_time'", file.source.string());
  std::vector<double> times;
  times.reserve(file.frames.size());
  for (const auto& f : file.frames) times.push_back(first + *f.render_time * (last - first));
  return times;
}

}  // namespace retimegs::io
