#include "retimegs/model/model_file.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <numbers>

#include <fmt/ranges.h>

#include <nlohmann/json.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/fnv1a.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/interrupt.hpp"
#include "retimegs/core/limits.hpp"

namespace retimegs::model {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

static_assert(std::endian::native == std::endian::little, "the .rgs writer assumes little-endian");

constexpr char kMagic[8] = {'R', 'E', 'T', 'I', 'M', 'E', 'G', 'S'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kPrefix = sizeof kMagic + 2 * sizeof(std::uint32_t);

// fnv1a64 of a file being read, polling for Ctrl-C between blocks (write_model does not poll: a
// train stopped by a signal still writes its checkpoint).
std::uint64_t fnv1a64_interruptible(const char* data, std::size_t size) {
  std::uint64_t hash = kFnv1a64Basis;
  const std::size_t block = 64 * kItemsPerInterruptPoll;
  for (std::size_t at = 0; at < size; at += block) {
    throw_if_interrupted();
    hash = fnv1a64(data + at, std::min(block, size - at), hash);
  }
  return hash;
}

template <typename U>
void put(std::string& out, U value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

const char* name_of(Representation r) {
  return r == Representation::kStgs ? "stgs" : "retime";
}
const char* name_of(TrajectoryKind k) {
  return k == TrajectoryKind::kLinear ? "linear" : "catmull-rom";
}

// The camera_colors entry of a header; throws Error naming `file` and the camera of a malformed or
// non-finite one.
std::map<std::string, CameraColor> camera_colors_from(const json& header, const std::string& file) {
  std::map<std::string, CameraColor> colors;
  if (!header.contains("camera_colors")) return colors;
  const json& table = header.at("camera_colors");
  if (!table.is_object()) fail("{}: 'camera_colors' is not an object", file);
  for (const auto& [camera, entry] : table.items()) {
    CameraColor& color = colors[camera];
    for (auto [key, values] : {std::pair{"m", &color.m}, std::pair{"c", &color.c}}) {
      const json* v = entry.is_object() && entry.contains(key) ? &entry.at(key) : nullptr;
      if (!v || !v->is_array() || v->size() != 3)
        fail("{}: camera colour of '{}' lacks '{}' as 3 numbers", file, camera, key);
      for (int k = 0; k < 3; ++k) {
        if (!(*v)[k].is_number() || !std::isfinite((*v)[k].get<double>()))
          fail("{}: camera colour '{}' of '{}' is not finite: {}", file, key, camera, v->dump());
        (*values)[k] = (*v)[k].get<float>();
      }
    }
  }
  return colors;
}

// The camera_poses entry of a header; throws Error naming `file` and the camera of an entry that
// is not 3 finite numbers per part, or whose rotation turns by π or more (check_camera_pose).
std::map<std::string, CameraPose> camera_poses_from(const json& header, const std::string& file) {
  std::map<std::string, CameraPose> poses;
  if (!header.contains("camera_poses")) return poses;
  const json& table = header.at("camera_poses");
  if (!table.is_object()) fail("{}: 'camera_poses' is not an object", file);
  for (const auto& [camera, entry] : table.items()) {
    CameraPose& pose = poses[camera];
    for (auto [key, values] :
         {std::pair{"rotation", &pose.rotation}, std::pair{"translation", &pose.translation}}) {
      const json* v = entry.is_object() && entry.contains(key) ? &entry.at(key) : nullptr;
      if (!v || !v->is_array() || v->size() != 3)
        fail("{}: camera pose of '{}' lacks '{}' as 3 numbers", file, camera, key);
      for (int k = 0; k < 3; ++k) {
        if (!(*v)[k].is_number())
          fail("{}: camera pose '{}' of '{}' is not finite: {}", file, key, camera, v->dump());
        (*values)[k] = (*v)[k].get<double>();
      }
    }
    check_camera_pose(pose, fmt::format("{}: camera pose of '{}'", file, camera));
  }
  return poses;
}

// The camera_clocks entry of a header; throws Error naming `file` and the camera of an entry that
// is not one finite number.
std::map<std::string, double> camera_clocks_from(const json& header, const std::string& file) {
  std::map<std::string, double> clocks;
  if (!header.contains("camera_clocks")) return clocks;
  const json& table = header.at("camera_clocks");
  if (!table.is_object()) fail("{}: 'camera_clocks' is not an object", file);
  for (const auto& [camera, entry] : table.items()) {
    if (!entry.is_number() || !std::isfinite(entry.get<double>()))
      fail("{}: clock correction of '{}' is not a finite number: {}", file, camera, entry.dump());
    clocks[camera] = entry.get<double>();
  }
  return clocks;
}

// The index of training time t in `grid`; throws Error naming `file` and `what` t is when t is not
// one.
int grid_index(const TimeGrid& grid, double t, const std::string& file, std::string_view what) {
  const double i = std::round((t - grid.first) / grid.step);
  if (!std::isfinite(t) || !(i >= 0 && i < grid.count) ||
      std::abs(grid.at(int(i)) - t) > 1e-6 * grid.step)
    fail("{}: {} {} is not a training frame of the model's time grid", file, what, t);
  return int(i);
}

}  // namespace

const CameraColor* find_camera_color(const Model& model, const std::string& camera) {
  const auto it = model.camera_colors.find(camera);
  return it == model.camera_colors.end() ? nullptr : &it->second;
}

const CameraPose* find_camera_pose(const Model& model, const std::string& camera) {
  const auto it = model.camera_poses.find(camera);
  return it == model.camera_poses.end() ? nullptr : &it->second;
}

double clock_correction(const Model& model, const std::string& camera) {
  const auto it = model.camera_clocks.find(camera);
  return it == model.camera_clocks.end() ? 0.0 : it->second;
}

Camera seen_camera(const Model& model, const Camera& camera) {
  const CameraPose* pose = find_camera_pose(model, camera.name);
  return pose ? corrected(camera, *pose) : camera;
}

void check_camera_pose(const CameraPose& pose, const std::string& what) {
  double angle2 = 0;
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(pose.rotation[k]) || !std::isfinite(pose.translation[k]))
      fail("{} is not finite: rotation [{}], translation [{}]", what,
           fmt::join(pose.rotation, ", "), fmt::join(pose.translation, ", "));
    angle2 += pose.rotation[k] * pose.rotation[k];
  }
  if (!(std::sqrt(angle2) < std::numbers::pi))
    fail("{} turns by {} rad, not less than pi: rotation [{}]", what, std::sqrt(angle2),
         fmt::join(pose.rotation, ", "));
}

void check_times(const Model& model, const std::vector<double>& times, std::string_view what) {
  const double first = model.grid.first, last = model.grid.last();
  const double slack = 1e-6 * std::max(1.0, last - first);  // A:B:STEP sums may overshoot B
  for (const double t : times)
    if (!(t >= first - slack && t <= last + slack))
      fail(
          "{}: time {} is outside the model's time range [{}, {}] (its first and last training "
          "frames)",
          what, t, first, last);
}

void check_model_file_name(const fs::path& path, const std::string& what) {
  if (path.extension() != ".rgs")
    fail("{} {}: a model file's name must end in .rgs", what, path.string());
}

void write_model(const fs::path& path, const Model& model, bool replace) {
  check_model_file_name(path, "model");
  check_primitives(model.primitives, path.string());
  const std::size_t n = model.primitives.size();
  json fields = json::array();
  std::size_t offset = 0;
  for (const auto& f : model.primitives.fields()) {
    const std::size_t bytes = f.values->size() * sizeof(float);
    fields.push_back({{"name", f.name},
                      {"width", f.width},
                      {"dtype", "<f4"},
                      {"offset", offset},
                      {"bytes", bytes}});
    offset += bytes;
  }
  json training;
  try {
    training = json::parse(model.training_config);
  } catch (const json::exception& e) {
    fail("{}: training config is not valid JSON: {}", path.string(), e.what());
  }
  json header = {
      {"count", n},
      {"time_grid",
       {{"first", model.grid.first}, {"step", model.grid.step}, {"count", model.grid.count}}},
      {"model",
       {{"representation", name_of(model.config.representation)},
        {"trajectory", name_of(model.config.trajectory)},
        {"gamma", model.config.gamma},
        {"epsilon", model.config.epsilon},
        {"sh_degree", model.config.sh_degree}}},
      {"fields", fields},
      {"training_config", training}};
  if (const auto& w = model.window) {
    if (!(w->first >= 0 && w->first < w->last && w->last < model.grid.count))
      fail("{}: window {}..{} is not a run of the {} training frames", path.string(), w->first,
           w->last, model.grid.count);
    header["window"] = {{"first", model.grid.at(w->first)}, {"last", model.grid.at(w->last)}};
  }
  if (!model.config.seams.empty()) {
    json seams = json::array();
    for (const int s : model.config.seams) {
      if (!(s > 0 && s < model.grid.count - 1))
        fail("{}: seam {} is not an interior training frame of the {}", path.string(), s,
             model.grid.count);
      seams.push_back(model.grid.at(s));
    }
    header["seams"] = seams;
    if (model.config.seam_fade > 0) header["seam_fade"] = model.config.seam_fade;
  }
  for (const auto& [camera, color] : model.camera_colors) {
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(color.m[k]) || !std::isfinite(color.c[k]))
        fail("{}: camera colour of '{}' is not finite", path.string(), camera);
    header["camera_colors"][camera] = {{"m", color.m}, {"c", color.c}};
  }
  for (const auto& [camera, pose] : model.camera_poses) {
    check_camera_pose(pose, fmt::format("{}: camera pose of '{}'", path.string(), camera));
    header["camera_poses"][camera] = {{"rotation", pose.rotation},
                                      {"translation", pose.translation}};
  }
  for (const auto& [camera, delta] : model.camera_clocks) {
    if (!std::isfinite(delta))
      fail("{}: clock correction of '{}' is not finite", path.string(), camera);
    header["camera_clocks"][camera] = delta;
  }
  const std::string header_text = header.dump();

  std::string bytes(kMagic, sizeof kMagic);
  put(bytes, kVersion);
  put(bytes, std::uint32_t(header_text.size()));
  bytes += header_text;
  for (const auto& f : model.primitives.fields())
    bytes.append(reinterpret_cast<const char*>(f.values->data()), f.values->size() * sizeof(float));
  put(bytes, fnv1a64(bytes.data(), bytes.size()));

  AtomicFile out(path, replace);
  {
    errno = 0;
    std::ofstream o(out.temp_path(), std::ios::binary);
    o.write(bytes.data(), std::streamsize(bytes.size()));
    o.close();  // the last bytes reach the disk here: a full disk shows only now
    check_written(o, path);
  }
  out.commit();
}

Model read_model(const fs::path& path) {
  const std::string file = path.string();
  check_input_file(path, "a model");
  const std::string bytes = read_text_file(path, "model file");
  if (bytes.size() < kPrefix + sizeof(std::uint64_t) || std::memcmp(bytes.data(), kMagic, 8) != 0)
    fail("{}: not a retimegs model (.rgs) file", file);
  std::uint32_t version = 0, header_size = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(&header_size, bytes.data() + 12, 4);
  if (version != kVersion)
    fail("{}: model format version {} is not supported (this build reads {})", file, version,
         kVersion);
  if (kPrefix + std::size_t(header_size) + sizeof(std::uint64_t) > bytes.size())
    fail("{}: truncated model file (header)", file);
  json header;
  try {
    header = json::parse(bytes.substr(kPrefix, header_size));
  } catch (const json::exception& e) {
    fail("{}: malformed model header: {}", file, e.what());
  }

  if (!header.is_object()) fail("{}: malformed model header: not a JSON object", file);
  // Header numbers are type- and range-checked before use: the JSON library would wrap a negative
  // count and turn 1e20 into an arbitrary int.
  const auto integer = [&](const json& v, const char* key, std::int64_t low, std::int64_t high) {
    if (!v.is_number_integer() || (v.is_number_unsigned() && v.get<std::uint64_t>() > 1ull << 62) ||
        v.get<std::int64_t>() < low || v.get<std::int64_t>() > high)
      fail("{}: model header '{}' must be an integer in [{}, {}], got {}", file, key, low, high,
           v.dump());
    return v.get<std::int64_t>();
  };
  const auto number = [&](const json& v, const char* key) {
    if (!v.is_number() || !std::isfinite(v.get<double>()))
      fail("{}: model header '{}' must be a finite number, got {}", file, key, v.dump());
    return v.get<double>();
  };

  Model model;
  std::size_t n = 0;
  try {
    n = std::size_t(integer(header.at("count"), "count", 0, std::int64_t(1) << 62));
    const json& grid = header.at("time_grid");
    model.grid = {number(grid.at("first"), "time_grid.first"),
                  number(grid.at("step"), "time_grid.step"),
                  int(integer(grid.at("count"), "time_grid.count", 1, kMaxFrames))};
    const json& m = header.at("model");
    model.config.representation =
        m.at("representation") == "stgs" ? Representation::kStgs : Representation::kRetime;
    model.config.trajectory =
        m.at("trajectory") == "linear" ? TrajectoryKind::kLinear : TrajectoryKind::kCatmullRom;
    model.config.gamma = number(m.at("gamma"), "model.gamma");
    model.config.epsilon = number(m.at("epsilon"), "model.epsilon");
    model.config.sh_degree = int(integer(m.at("sh_degree"), "model.sh_degree", 0, 3));
    model.training_config = header.value("training_config", json::object()).dump();
    model.camera_colors = camera_colors_from(header, file);
    model.camera_poses = camera_poses_from(header, file);
    model.camera_clocks = camera_clocks_from(header, file);
    if (header.contains("window")) {
      const json& w = header.at("window");
      model.window =
          TimeWindow{grid_index(model.grid, w.at("first").get<double>(), file, "window end"),
                     grid_index(model.grid, w.at("last").get<double>(), file, "window end")};
      if (!(model.window->first < model.window->last))
        fail("{}: window {} ends before it starts", file, w.dump());
    }
    for (const json& t : header.value("seams", json::array())) {
      const int seam = grid_index(model.grid, t.get<double>(), file, "seam");
      if (seam == 0 || seam == model.grid.count - 1 ||
          (!model.config.seams.empty() && seam <= model.config.seams.back()))
        fail("{}: seams {} are not ascending interior training times", file,
             header.at("seams").dump());
      model.config.seams.push_back(seam);
    }
    if (header.contains("seam_fade")) {
      model.config.seam_fade = number(header.at("seam_fade"), "seam_fade");
      check_seam_fade(model.config.seam_fade, file + ": seam_fade");
    }
    if (model.config.seams.size() > std::size_t(kMaxSeams))
      fail("{}: {} seams, more than {}", file, model.config.seams.size(), kMaxSeams);
  } catch (const json::exception& e) {
    fail("{}: malformed model header: {}", file, e.what());
  }
  if (!(model.grid.step > 0) || !std::isfinite(model.grid.last()) || !(model.config.gamma > 0))
    fail("{}: model header has an invalid time grid or config", file);

  // The declared count is checked against the file's size before anything is allocated for it.
  const std::size_t data_start = kPrefix + header_size;
  const std::size_t data_size = bytes.size() - data_start - sizeof(std::uint64_t);
  std::size_t row_bytes = 0;
  for (const auto& f : model.primitives.fields()) row_bytes += f.width * sizeof(float);
  if (n > data_size / row_bytes || n * row_bytes != data_size)
    fail(
        "{}: header count {} does not match the file ({} data bytes; {} primitives of {} bytes "
        "expected): truncated, padded or edited",
        file, n, data_size, data_size / row_bytes, row_bytes);
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - sizeof stored, sizeof stored);
  if (stored != fnv1a64_interruptible(bytes.data(), bytes.size() - sizeof stored))
    fail("{}: checksum mismatch: the model file is corrupted", file);
  model.primitives.resize(n);

  const json table = header.value("fields", json::array());
  if (!table.is_array()) fail("{}: model header 'fields' is not an array", file);
  for (const auto& f : model.primitives.fields()) {
    const auto it = std::find_if(table.begin(), table.end(), [&](const json& e) {
      return e.is_object() && e.contains("name") && e["name"] == f.name;
    });
    if (it == table.end()) fail("{}: model file lacks field '{}'", file, f.name);
    const std::size_t size = f.values->size() * sizeof(float);
    const auto entry = [&](const char* key) -> const json& {
      static const json none;
      return it->contains(key) ? (*it)[key] : none;
    };
    const bool layout_ok = entry("width") == f.width && entry("dtype") == "<f4" &&
                           entry("bytes") == size && entry("offset").is_number_unsigned() &&
                           entry("offset").get<std::uint64_t>() <= data_size - size;
    if (!layout_ok) fail("{}: field '{}' has an unexpected layout", file, f.name);
    if (size > 0)  // memcpy from an empty vector's null data() is undefined
      std::memcpy(f.values->data(),
                  bytes.data() + data_start + entry("offset").get<std::uint64_t>(), size);
  }
  check_primitives(model.primitives, file);
  return model;
}

}  // namespace retimegs::model
