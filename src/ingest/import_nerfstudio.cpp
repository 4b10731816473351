// nerfstudio / instant-ngp transforms.json -> scene format.
//
// Intrinsics: fl_x, fl_y, cx, cy, w, h (or camera_angle_x / camera_angle_y with the principal
// point at the centre), distortion k1, k2, k3, k4, p1, p2 with camera_model OPENCV (default) or
// OPENCV_FISHEYE; every key may be overridden per frame. Poses: transform_matrix is
// camera-to-world with OpenGL / Blender camera axes (x right, y up, z backward); OpenCV's
// camera-to-world is transform_matrix * diag(1, -1, -1, 1) (nerfstudio's own COLMAP export
// negates the same two columns).
//
// Grouping of the frames[] entries into scene frames and cameras:
//  - no entry has "time": a static capture, one scene frame, every entry is its own camera;
//  - otherwise every entry needs "time" (any number: normalised [0, 1] or a frame index); the
//    distinct times, sorted, are the scene frames; the camera of an entry is its "camera" key,
//    else "camera_idx" / "camera_id", else the folder of file_path; every camera must have one
//    image at every time and the same pose and intrinsics throughout.
// Camera names are the "camera" value (or "cam<idx>", the folder name), or the file stem for
// static captures. fps comes from a top-level "fps" key, else 30. mask_path (nerfstudio's mask,
// non-zero = keep) becomes the scene mask; without one, the alpha channel of an RGBA image
// (Blender renders) does. Colours are kept as stored (not composited over a background).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "import_common.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/io/colmap.hpp"
#include "retimegs/io/json_file.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/resize.hpp"

namespace retimegs::ingest {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kDefaultFps = 30.0;

struct Entry {
  int index = 0;  // in frames[]
  fs::path image, mask;
  io::ColmapCamera intrinsics;  // OPENCV / FULL_OPENCV / OPENCV_FISHEYE / PINHOLE
  Eigen::Matrix4d world_to_camera;
  bool has_time = false;
  double time = 0;
  std::string camera;  // identity (and name)
};

// The frame's value of `key`, else the global one; nullptr when neither has it.
const json* lookup(const json& frame, const json& root, const char* key) {
  if (frame.contains(key)) return &frame[key];
  if (root.contains(key)) return &root[key];
  return nullptr;
}

io::ColmapCamera intrinsics(const json& frame, const json& root, const fs::path& image,
                            const std::string& file, const std::string& where) {
  auto number = [&](const char* key, double fallback, bool required) {
    const json* v = lookup(frame, root, key);
    if (!v) {
      if (required) fail("{}: {} has no '{}' (nor a global one)", file, where, key);
      return fallback;
    }
    return detail::finite_number(*v, file, fmt::format("{}.{}", where, key));
  };
  // A declared size is checked against the image (its header only) before anything is sized by
  // it: the undistortion maps are w x h.
  const media::ImageSize size = media::read_image_size(image);
  const int w = size.width, h = size.height;
  if (lookup(frame, root, "w") || lookup(frame, root, "h")) {
    const double dw = number("w", w, false), dh = number("h", h, false);
    if (dw != w || dh != h)
      fail("{}: {} declares image size {}x{} but {} is {}x{}", file, where, dw, dh, image.string(),
           w, h);
  }
  double fx = 0, fy = 0;
  if (lookup(frame, root, "fl_x")) {
    fx = number("fl_x", 0, true);
    fy = lookup(frame, root, "fl_y") ? number("fl_y", 0, true) : fx;
  } else if (lookup(frame, root, "camera_angle_x")) {
    fx = 0.5 * w / std::tan(0.5 * number("camera_angle_x", 0, true));
    fy = lookup(frame, root, "camera_angle_y")
             ? 0.5 * h / std::tan(0.5 * number("camera_angle_y", 0, true))
             : fx;
  } else {
    fail("{}: {} has no focal length (fl_x or camera_angle_x)", file, where);
  }
  if (!(fx > 0 && fy > 0))
    fail("{}: {} has a non-positive focal length ({}, {})", file, where, fx, fy);
  const double cx = number("cx", 0.5 * w, false), cy = number("cy", 0.5 * h, false);
  const double k1 = number("k1", 0, false), k2 = number("k2", 0, false),
               k3 = number("k3", 0, false), k4 = number("k4", 0, false),
               p1 = number("p1", 0, false), p2 = number("p2", 0, false);
  std::string model = "OPENCV";
  if (const json* m = lookup(frame, root, "camera_model")) {
    if (!m->is_string()) fail("{}: {}.camera_model must be a string", file, where);
    model = m->get<std::string>();
  }
  io::ColmapCamera c;
  c.width = w, c.height = h;
  if (model == "OPENCV_FISHEYE") {
    c.model = "OPENCV_FISHEYE";
    c.params = {fx, fy, cx, cy, k1, k2, k3, k4};
  } else if (model == "OPENCV" || model == "PINHOLE") {
    if (k4 != 0)
      fail("{}: {}.k4 = {} is not supported for camera_model {} (only OPENCV_FISHEYE)", file, where,
           k4, model);
    if (k3 != 0) {
      c.model = "FULL_OPENCV";  // numerator 1 + k1 r^2 + k2 r^4 + k3 r^6, denominator 1
      c.params = {fx, fy, cx, cy, k1, k2, p1, p2, k3, 0, 0, 0};
    } else {
      c.model = "OPENCV";
      c.params = {fx, fy, cx, cy, k1, k2, p1, p2};
    }
  } else {
    fail("{}: {}.camera_model '{}' is not supported (OPENCV, OPENCV_FISHEYE, PINHOLE)", file, where,
         model);
  }
  return c;
}

fs::path resolve(const fs::path& base, const json& value, const std::string& file,
                 const std::string& field) {
  if (!value.is_string() || value.get<std::string>().empty())
    fail("{}: '{}' must be a non-empty string", file, field);
  fs::path p = base / value.get<std::string>();
  // Blender synthetic scenes leave the extension out ("./train/r_0").
  if (!fs::exists(input_status(p)) && !p.has_extension() &&
      fs::exists(input_status(fs::path(p) += ".png")))
    p += ".png";
  if (!fs::is_regular_file(input_status(p)))
    fail("{}: {}: missing file {}", file, field, p.string());
  return p.lexically_normal();
}

std::string camera_key(const json& frame, const fs::path& image) {
  if (frame.contains("camera")) {
    const json& v = frame["camera"];
    return v.is_string() ? v.get<std::string>() : v.dump();
  }
  for (const char* key : {"camera_idx", "camera_id"})
    if (frame.contains(key)) {
      const json& v = frame[key];
      return v.is_number_integer() ? fmt::format("cam{:02d}", v.get<int>())
                                   : (v.is_string() ? v.get<std::string>() : v.dump());
    }
  return image.parent_path().filename().string();
}

// The alpha channel of an RGBA / grey+alpha PNG as a mask (media::read_alpha_mask), else nullopt.
// Only the PNG header is read for images without alpha.
std::optional<Image> alpha_mask(const fs::path& path) {
  unsigned char header[26] = {};  // signature (8), IHDR length + type (8), size (8), depth, colour
  std::ifstream in(path, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(header), sizeof header) ||
      std::memcmp(header, "\x89PNG", 4) != 0 || (header[25] != 4 && header[25] != 6))
    return std::nullopt;
  return media::read_alpha_mask(path);
}

bool same_intrinsics(const io::ColmapCamera& a, const io::ColmapCamera& b) {
  return a.model == b.model && a.width == b.width && a.height == b.height && a.params == b.params;
}

}  // namespace

void import_nerfstudio(const fs::path& source, const fs::path& out, const ImportOptions& options) {
  check_downscale(options.downscale);
  const fs::path json_path =
      fs::is_directory(source) ? source / "transforms.json" : source;  // folder or the file
  const fs::path base = json_path.parent_path();
  const std::string file = json_path.string();
  const json root = io::read_json_file(json_path, "nerfstudio transforms");
  if (!root.is_object() || !root.contains("frames") || !root["frames"].is_array() ||
      root["frames"].empty())
    fail("{}: missing required key 'frames' (a non-empty array)", file);
  const json& frames = root["frames"];

  std::vector<Entry> entries;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const json& f = frames[i];
    const std::string where = fmt::format("frames[{}]", i);
    if (!f.is_object()) fail("{}: {} must be an object", file, where);
    for (const char* key : {"file_path", "transform_matrix"})
      if (!f.contains(key)) fail("{}: {} is missing required key '{}'", file, where, key);
    Entry e;
    e.index = int(i);
    e.image = resolve(base, f["file_path"], file, where + ".file_path");
    if (f.contains("mask_path")) e.mask = resolve(base, f["mask_path"], file, where + ".mask_path");
    e.intrinsics = intrinsics(f, root, e.image, file, where);
    const json& m = f["transform_matrix"];
    Eigen::Matrix4d c2w;
    if (!m.is_array() || m.size() != 4) fail("{}: {}.transform_matrix must be 4x4", file, where);
    for (int r = 0; r < 4; ++r) {
      if (!m[r].is_array() || m[r].size() != 4)
        fail("{}: {}.transform_matrix must be 4x4", file, where);
      for (int c = 0; c < 4; ++c)
        c2w(r, c) = detail::finite_number(m[r][c], file,
                                          fmt::format("{}.transform_matrix[{}][{}]", where, r, c));
    }
    check_rigid(c2w, fmt::format("{}: {}.transform_matrix", file, where));
    e.world_to_camera = world_to_camera_from_opengl(c2w);
    if (f.contains("time")) {
      e.has_time = true;
      e.time = detail::finite_number(f["time"], file, where + ".time");
    }
    e.camera = camera_key(f, e.image);
    entries.push_back(std::move(e));
  }

  const bool timed = entries[0].has_time;
  for (const auto& e : entries)
    if (e.has_time != timed)
      fail("{}: frames[{}] {} 'time' but frames[0] {}; give every frame a time or none", file,
           e.index, e.has_time ? "has" : "has no", timed ? "has one" : "has none");

  // Scene frames (sorted distinct times, equal within 1e-6 of the time range) and cameras (first
  // appearance order, then by name).
  std::vector<double> times;
  std::vector<std::string> camera_names;
  if (timed) {
    for (const auto& e : entries) times.push_back(e.time);
    std::sort(times.begin(), times.end());
    // Times written by different tools for the same instant may differ in the last digits.
    const double tolerance = 1e-6 * std::max(1.0, times.back() - times.front());
    times.erase(std::unique(times.begin(), times.end(),
                            [&](double a, double b) { return b - a <= tolerance; }),
                times.end());
    for (const auto& e : entries) camera_names.push_back(e.camera);
    std::sort(camera_names.begin(), camera_names.end());
    camera_names.erase(std::unique(camera_names.begin(), camera_names.end()), camera_names.end());
  } else {
    times = {0.0};
    for (auto& e : entries) e.camera = e.image.stem().string();
    std::set<std::string> stems;
    bool unique = true;
    for (const auto& e : entries) unique &= stems.insert(e.camera).second;
    if (!unique)
      for (auto& e : entries) {
        e.camera = fs::relative(e.image, base).replace_extension().generic_string();
        std::replace(e.camera.begin(), e.camera.end(), '/', '_');
      }
    for (const auto& e : entries) camera_names.push_back(e.camera);
  }
  const int steps = int(times.size());
  // Plain ints, not a structured binding: clang 14 (the fuzzing build) cannot capture those in
  // lambdas.
  const auto [first_frame, last_frame] = detail::frame_range(options, steps, "the source");
  const int first = first_frame, last = last_frame;

  // grid[camera][frame] = entry index.
  std::map<std::string, int> camera_index;
  for (std::size_t c = 0; c < camera_names.size(); ++c) camera_index[camera_names[c]] = int(c);
  std::vector<std::vector<int>> grid(camera_names.size(), std::vector<int>(steps, -1));
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const Entry& e = entries[i];
    const int c = camera_index.at(e.camera);
    int k = 0;  // the nearest scene frame time
    for (int j = 1; j < steps; ++j)
      if (std::abs(times[j] - e.time) < std::abs(times[k] - e.time)) k = j;
    if (grid[c][k] >= 0)
      fail("{}: frames[{}] and frames[{}] are both camera '{}' at time {}", file,
           entries[grid[c][k]].index, e.index, e.camera, e.time);
    grid[c][k] = int(i);
  }
  for (std::size_t c = 0; c < grid.size(); ++c)
    for (int k = 0; k < steps; ++k)
      if (grid[c][k] < 0)
        fail(
            "{}: camera '{}' has no image at time {} (the scene format needs every camera at "
            "every time)",
            file, camera_names[c], times[k]);

  io::Scene scene;
  scene.num_frames = last - first + 1;
  scene.fps = kDefaultFps;
  scene.calibration = io::CalibrationSource::kUser;  // a user's reconstruction: a few pixels off
  if (root.contains("fps")) {
    scene.fps = detail::finite_number(root["fps"], file, "fps");
    check_fps(scene.fps, fmt::format("{}: 'fps'", file));
  }
  std::vector<std::unique_ptr<detail::Undistorter>> undistorters;
  for (std::size_t c = 0; c < grid.size(); ++c) {
    const Entry& e0 = entries[grid[c][0]];
    for (int k = 1; k < steps; ++k) {
      const Entry& e = entries[grid[c][k]];
      if (!same_intrinsics(e.intrinsics, e0.intrinsics))
        fail("{}: camera '{}' changes intrinsics between frames[{}] and frames[{}]", file, e.camera,
             e0.index, e.index);
      if ((e.world_to_camera - e0.world_to_camera).cwiseAbs().maxCoeff() > 1e-5)
        fail("{}: camera '{}' moves between frames[{}] and frames[{}] (cameras must be static)",
             file, e.camera, e0.index, e.index);
    }
    undistorters.push_back(std::make_unique<detail::Undistorter>(
        e0.intrinsics, fmt::format("{}: frames[{}]", file, e0.index)));
    Camera cam = undistorters.back()->pinhole();
    cam.name = camera_names[c];
    cam.world_to_camera = e0.world_to_camera;
    scene.cameras.push_back(downscaled(cam, options.downscale));
  }
  scene.up = detail::mean_camera_up(scene.cameras);

  AtomicDirectory dir(out, options.force);
  scene.root = dir.temp_path();
  const std::size_t jobs = grid.size() * scene.num_frames;
  detail::parallel_jobs(
      jobs, jobs, "import nerfstudio", options.progress, [&](std::size_t j, Progress& progress) {
        const int c = int(j / scene.num_frames), k = int(j % scene.num_frames);
        const Entry& e = entries[grid[c][first + k]];
        const Camera& cam = scene.cameras[c];
        const Image image = media::read_image(e.image);
        if (image.width != e.intrinsics.width || image.height != e.intrinsics.height)
          fail("{}: image is {}x{} but {} says {}x{}", e.image.string(), image.width, image.height,
               file, e.intrinsics.width, e.intrinsics.height);
        media::write_png(scene.image_path(c, k),
                         media::resize_area(undistorters[c]->apply(image), cam.width, cam.height));
        // mask_path, else the alpha channel of an RGBA image (Blender renders).
        const std::optional<Image> mask =
            e.mask.empty() ? alpha_mask(e.image) : std::optional<Image>(media::read_mask(e.mask));
        if (mask) {
          if (mask->width != image.width || mask->height != image.height)
            fail("{}: mask is {}x{} but its image is {}x{}", e.mask.string(), mask->width,
                 mask->height, image.width, image.height);
          media::write_png(scene.mask_path(c, k), media::resize_area(undistorters[c]->apply(*mask),
                                                                     cam.width, cam.height));
        }
        progress.tick();
      });
  io::write_scene_json(scene);
  dir.commit();
}

}  // namespace retimegs::ingest
