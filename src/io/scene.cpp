#include "retimegs/io/scene.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/json_file.hpp"

namespace retimegs::io {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr const char* kFormat = "retimegs-scene";
constexpr int kVersion = 1;

// Field access with errors that name the file and the JSON path of the field.
class Fields {
 public:
  explicit Fields(std::string file) : file_(std::move(file)) {}

  const json& require(const json& object, const std::string& key, const std::string& path) const {
    if (!object.is_object()) fail("{}: '{}' must be an object", file_, path);
    const auto it = object.find(key);
    if (it == object.end()) fail("{}: missing required key '{}'", file_, join(path, key));
    return *it;
  }
  double number(const json& value, const std::string& path) const {
    if (!value.is_number()) fail("{}: '{}' must be a number, got {}", file_, path, value.dump());
    const double x = value.get<double>();
    if (!std::isfinite(x)) fail("{}: '{}' is not finite", file_, path);
    return x;
  }
  double positive(const json& value, const std::string& path) const {
    const double x = number(value, path);
    if (!(x > 0)) fail("{}: '{}' must be > 0, got {}", file_, path, x);
    return x;
  }
  int positive_int(const json& value, const std::string& path) const {
    if (!value.is_number_integer() || value.get<long long>() < 1 ||
        value.get<long long>() > 1'000'000)
      fail("{}: '{}' must be a positive integer, got {}", file_, path, value.dump());
    return value.get<int>();
  }
  std::string string(const json& value, const std::string& path) const {
    if (!value.is_string()) fail("{}: '{}' must be a string, got {}", file_, path, value.dump());
    return value.get<std::string>();
  }
  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }
  const std::string& file() const { return file_; }
  // "<file>: '<path>'", a field as the core/limits.hpp checks name it.
  std::string field(const std::string& path) const { return fmt::format("{}: '{}'", file_, path); }

 private:
  std::string file_;
};

Camera parse_camera(const json& j, const std::string& path, const Fields& f) {
  Camera cam;
  cam.name = f.string(f.require(j, "name", path), path + ".name");
  check_camera_name(cam.name, fmt::format("{}: '{}.name'", f.file(), path));
  cam.width = f.positive_int(f.require(j, "width", path), path + ".width");
  check_image_side(cam.width, f.field(path + ".width"));
  cam.height = f.positive_int(f.require(j, "height", path), path + ".height");
  check_image_side(cam.height, f.field(path + ".height"));
  cam.fx = f.positive(f.require(j, "fx", path), path + ".fx");
  check_focal(cam.fx, cam.width, f.field(path + ".fx"));
  cam.fy = f.positive(f.require(j, "fy", path), path + ".fy");
  check_focal(cam.fy, cam.height, f.field(path + ".fy"));
  cam.cx = f.number(f.require(j, "cx", path), path + ".cx");
  cam.cy = f.number(f.require(j, "cy", path), path + ".cy");
  const std::string mpath = path + ".world_to_camera";
  const json& m = f.require(j, "world_to_camera", path);
  if (!m.is_array() || m.size() != 4) fail("{}: '{}' must be a 4x4 array", f.file(), mpath);
  for (int r = 0; r < 4; ++r) {
    if (!m[r].is_array() || m[r].size() != 4)
      fail("{}: '{}' must be a 4x4 array (row {})", f.file(), mpath, r);
    for (int c = 0; c < 4; ++c)
      cam.world_to_camera(r, c) = f.number(m[r][c], fmt::format("{}[{}][{}]", mpath, r, c));
  }
  check_rigid(cam.world_to_camera, fmt::format("{}: '{}'", f.file(), mpath));
  // Rigid: the translation's length is the camera centre's distance from the origin.
  for (int r = 0; r < 3; ++r)
    check_coordinate(cam.world_to_camera(r, 3), f.field(fmt::format("{}[{}][3]", mpath, r)));
  if (j.contains("split")) {
    const std::string split = f.string(j["split"], path + ".split");
    if (split == "train")
      cam.split = Split::kTrain;
    else if (split == "test")
      cam.split = Split::kTest;
    else
      fail("{}: '{}.split' must be \"train\" or \"test\", got \"{}\"", f.file(), path, split);
  }
  return cam;
}

// The clock keys of camera entry `j` (both optional); errors name the file, the camera and the
// field.
CameraClock parse_clock(const json& j, const std::string& path, const std::string& name,
                        int num_frames, const Fields& f) {
  CameraClock clock;
  const std::string where = fmt::format("{}: camera '{}' ({})", f.file(), name, path);
  const auto number = [&](const json& value, const std::string& field) {
    if (!value.is_number()) fail("{}: '{}' must be a number, got {}", where, field, value.dump());
    return value.get<double>();  // finiteness: check_clock
  };
  if (j.contains("time_offset")) clock.time_offset = number(j["time_offset"], "time_offset");
  if (j.contains("frame_times")) {
    const json& times = j["frame_times"];
    if (!times.is_array())
      fail("{}: 'frame_times' must be an array of {} numbers (num_frames)", where, num_frames);
    for (std::size_t k = 0; k < times.size(); ++k)
      clock.frame_times.push_back(number(times[k], fmt::format("frame_times[{}]", k)));
  }
  check_clock(clock, num_frames, where);
  return clock;
}

}  // namespace

void check_clock(const CameraClock& clock, int num_frames, const std::string& where) {
  if (!std::isfinite(clock.time_offset))
    fail("{}: 'time_offset' is not finite ({})", where, clock.time_offset);
  const std::vector<double>& t = clock.frame_times;
  if (t.empty()) return;
  if (int(t.size()) != num_frames)
    fail("{}: 'frame_times' holds {} values for {} frames (num_frames)", where, t.size(),
         num_frames);
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k])) fail("{}: 'frame_times[{}]' is not finite ({})", where, k, t[k]);
    if (k > 0 && !(t[k] > t[k - 1]))
      fail("{}: 'frame_times' must increase strictly, but [{}] = {} follows [{}] = {}", where, k,
           t[k], k - 1, t[k - 1]);
  }
}

double frame_time(const Scene& scene, int camera, double position) {
  if (scene.clocks.empty()) return position;
  const CameraClock& clock = scene.clocks.at(std::size_t(camera));
  const std::vector<double>& t = clock.frame_times;
  if (t.empty()) return position + clock.time_offset;
  if (t.size() == 1) return t[0] + position + clock.time_offset;  // one frame: no rate
  // The segment holding the position, the end ones extended.
  const double last = double(t.size() - 1);
  const std::size_t k = std::size_t(std::clamp(std::floor(position), 0.0, last - 1));
  const double s = position - double(k);
  return t[k] + s * (t[k + 1] - t[k]) + clock.time_offset;
}

const char* calibration_source_name(CalibrationSource source) {
  return source == CalibrationSource::kUser ? "user" : "lab";
}

const char* clock_source_name(ClockSource source) {
  return source == ClockSource::kEstimated ? "estimated" : "given";
}

bool has_own_clocks(const Scene& scene) {
  return std::any_of(scene.clocks.begin(), scene.clocks.end(),
                     [](const CameraClock& c) { return !c.is_default(); });
}

int Scene::camera_index(const std::string& name) const {
  for (int i = 0; i < int(cameras.size()); ++i)
    if (cameras[i].name == name) return i;
  std::string known;
  for (const auto& c : cameras) known += (known.empty() ? "" : ", ") + c.name;
  fail("{}: no camera named '{}' (cameras: {})", json_path().string(), name, known);
}

void check_file_size(const fs::path& file, const Camera& cam, int width, int height) {
  if (width != cam.width || height != cam.height)
    fail("{}: camera '{}' is {}x{} but the file is {}x{}", file.string(), cam.name, cam.width,
         cam.height, width, height);
}

void check_camera_name(const std::string& name, const std::string& where) {
  // A folder name holds at most 255 bytes on the common file systems (NAME_MAX).
  constexpr std::size_t kMaxName = 255;
  const bool control = std::any_of(name.begin(), name.end(),
                                   [](unsigned char ch) { return ch < 0x20 || ch == 0x7f; });
  if (name.empty() || name == "." || name == ".." || control || name.size() > kMaxName ||
      name.find_first_of("/\\") != std::string::npos)
    fail(
        "{}: camera name '{}' cannot be a folder name (one path component of at most {} bytes, "
        "no '/', '\\', control characters, '.' or '..')",
        where, name, kMaxName);
}

namespace {
fs::path camera_folder(const Scene& scene, const char* kind, int camera) {
  const std::string& name = scene.cameras.at(camera).name;
  check_camera_name(name, scene.json_path().string());
  return scene.root / kind / name;
}
}  // namespace

fs::path Scene::image_path(int camera, int frame) const {
  return camera_folder(*this, "images", camera) / fmt::format("{:05d}.png", frame);
}
fs::path Scene::mask_path(int camera, int frame) const {
  return camera_folder(*this, "masks", camera) / fmt::format("{:05d}.png", frame);
}
fs::path Scene::flow_path(int camera, int from, int to) const {
  return camera_folder(*this, "flow", camera) / fmt::format("{:05d}_{:05d}.flo", from, to);
}
fs::path Scene::points_path(int frame) const {
  return root / "points" / fmt::format("{:05d}.ply", frame);
}

Scene read_scene_json(const fs::path& root) {
  Scene scene;
  scene.root = root;
  const fs::path file = scene.json_path();
  if (!fs::is_directory(root)) fail("{}: scene folder does not exist", root.string());
  const json j = read_json_file(file, "scene file");
  const Fields f(file.string());
  if (const std::string format = f.string(f.require(j, "format", ""), "format"); format != kFormat)
    fail("{}: 'format' must be \"{}\", got \"{}\"", file.string(), kFormat, format);
  if (const int version = f.positive_int(f.require(j, "version", ""), "version");
      version != kVersion)
    fail("{}: unsupported scene version {} (this build reads version {})", file.string(), version,
         kVersion);
  scene.num_frames = f.positive_int(f.require(j, "num_frames", ""), "num_frames");
  check_frame_count(scene.num_frames, f.field("num_frames"));
  scene.fps = f.positive(f.require(j, "fps", ""), "fps");
  check_fps(scene.fps, f.field("fps"));
  if (j.contains("up")) {
    const json& up = j["up"];
    if (!up.is_array() || up.size() != 3)
      fail("{}: 'up' must be an array of 3 numbers", file.string());
    for (int i = 0; i < 3; ++i) scene.up[i] = f.number(up[i], fmt::format("up[{}]", i));
    if (scene.up.norm() < 1e-9) fail("{}: 'up' must not be the zero vector", file.string());
    scene.up.normalize();
  }
  if (j.contains("calibration")) {
    const std::string source = f.string(j["calibration"], "calibration");
    if (source == calibration_source_name(CalibrationSource::kLab))
      scene.calibration = CalibrationSource::kLab;
    else if (source == calibration_source_name(CalibrationSource::kUser))
      scene.calibration = CalibrationSource::kUser;
    else
      fail("{}: 'calibration' must be \"lab\" or \"user\", got \"{}\"", file.string(), source);
  }
  if (j.contains("clocks")) {
    const std::string source = f.string(j["clocks"], "clocks");
    if (source == clock_source_name(ClockSource::kGiven))
      scene.clock_source = ClockSource::kGiven;
    else if (source == clock_source_name(ClockSource::kEstimated))
      scene.clock_source = ClockSource::kEstimated;
    else
      fail("{}: 'clocks' must be \"given\" or \"estimated\", got \"{}\"", file.string(), source);
  }
  const json& cams = f.require(j, "cameras", "");
  if (!cams.is_array() || cams.empty())
    fail("{}: 'cameras' must be a non-empty array", file.string());
  std::set<std::string> names;
  for (std::size_t i = 0; i < cams.size(); ++i) {
    const std::string path = fmt::format("cameras[{}]", i);
    scene.cameras.push_back(parse_camera(cams[i], path, f));
    if (!names.insert(scene.cameras.back().name).second)
      fail("{}: camera name '{}' appears twice", file.string(), scene.cameras.back().name);
    scene.clocks.push_back(
        parse_clock(cams[i], path, scene.cameras.back().name, scene.num_frames, f));
  }
  if (!has_own_clocks(scene)) scene.clocks.clear();
  return scene;
}

void write_scene_json(const Scene& scene) {
  if (!scene.sources.empty() && scene.sources.size() != scene.cameras.size())
    fail("{}: {} camera sources for {} cameras", scene.json_path().string(), scene.sources.size(),
         scene.cameras.size());
  if (!scene.clocks.empty() && scene.clocks.size() != scene.cameras.size())
    fail("{}: {} camera clocks for {} cameras", scene.json_path().string(), scene.clocks.size(),
         scene.cameras.size());
  json cams = json::array();
  for (std::size_t c = 0; c < scene.cameras.size(); ++c) {
    const Camera& cam = scene.cameras[c];
    json m = json::array();
    for (int r = 0; r < 4; ++r)
      m.push_back({cam.world_to_camera(r, 0), cam.world_to_camera(r, 1), cam.world_to_camera(r, 2),
                   cam.world_to_camera(r, 3)});
    cams.push_back({{"name", cam.name},
                    {"width", cam.width},
                    {"height", cam.height},
                    {"fx", cam.fx},
                    {"fy", cam.fy},
                    {"cx", cam.cx},
                    {"cy", cam.cy},
                    {"world_to_camera", m},
                    {"split", cam.split == Split::kTest ? "test" : "train"}});
    if (!scene.clocks.empty()) {
      // Only what differs from the default clock, so that a genlocked scene's file is unchanged.
      const CameraClock& clock = scene.clocks[c];
      check_clock(clock, scene.num_frames,
                  fmt::format("{}: camera '{}'", scene.json_path().string(), cam.name));
      if (clock.time_offset != 0) cams.back()["time_offset"] = clock.time_offset;
      if (!clock.frame_times.empty()) cams.back()["frame_times"] = clock.frame_times;
    }
    if (scene.sources.empty()) continue;
    const CameraSource& source = scene.sources[c];
    json& entry = cams.back()["source"] = {{"file", source.file},
                                           {"first_frame", source.first_frame},
                                           {"last_frame", source.last_frame},
                                           {"offset", source.offset}};
    if (source.fps > 0) entry["fps"] = source.fps;
  }
  json j = {{"format", kFormat},
            {"version", kVersion},
            {"num_frames", scene.num_frames},
            {"fps", scene.fps},
            {"cameras", cams},
            {"up", {scene.up.x(), scene.up.y(), scene.up.z()}},
            {"calibration", calibration_source_name(scene.calibration)}};
  // Only estimated clocks are marked, so that the file of a scene with given clocks is unchanged.
  if (scene.clock_source == ClockSource::kEstimated)
    j["clocks"] = clock_source_name(scene.clock_source);
  write_text_file(scene.json_path(), j.dump(2) + "\n");
}

std::optional<Flow> load_flow(const Scene& scene, int camera, int from, int to) {
  const fs::path path = scene.flow_path(camera, from, to);
  if (!fs::exists(path)) return std::nullopt;
  check_input_file(path, "a flow");
  Flow flow = read_flo(path);
  check_file_size(path, scene.cameras.at(camera), flow.width, flow.height);
  return flow;
}

std::optional<PointCloud> load_points(const Scene& scene, int frame) {
  const fs::path path = scene.points_path(frame);
  if (!fs::exists(path)) return std::nullopt;
  check_input_file(path, "points");
  return read_points_ply(path);
}

}  // namespace retimegs::io
