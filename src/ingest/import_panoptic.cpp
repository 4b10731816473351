// CMU Panoptic in the Dynamic3DGaussians layout -> scene format.
#include <cmath>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "import_common.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/io/json_file.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/resize.hpp"

namespace retimegs::ingest {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kPanopticFps = 29.97;  // Panoptic Studio HD cameras

struct SourceCamera {
  Camera camera;
  std::vector<std::string> files;  // [T] "<cam>/<frame:06d>.jpg", relative to ims/
};

// An 'fn' entry names an image below ims/ (and its mask below seg/): a relative path that stays
// there. Absolute paths and '..' components would read any file of the machine into the scene;
// an empty name would be the folder itself; a NUL would cut the name short.
void check_frame_file(const std::string& value, const std::string& file, const std::string& where) {
  const auto refuse = [&](const char* why) {
    fail("{}: 'fn{}' is '{}': {} (a path relative to ims/ is expected)", file, where, value, why);
  };
  if (value.empty()) refuse("an empty name");
  if (value.find('\0') != std::string::npos) refuse("it holds a NUL byte");
  if (value.front() == '/') refuse("an absolute path");
  for (const auto& part : fs::path(value))
    if (part == "..") refuse("a '..' component leaves the source folder");
}

// Reads one of train_meta.json / test_meta.json into cameras (static: time step 0 defines them;
// later steps must agree).
std::vector<SourceCamera> read_meta(const fs::path& path, Split split) {
  const std::string file = path.string();
  const json j = io::read_json_file(path, "Panoptic metadata");
  for (const char* key : {"w", "h", "k", "w2c", "fn", "cam_id"})
    if (!j.is_object() || !j.contains(key)) fail("{}: missing required key '{}'", file, key);
  if (!j["w"].is_number_integer() || !j["h"].is_number_integer() || j["w"].get<int>() < 1 ||
      j["h"].get<int>() < 1)
    fail("{}: 'w' and 'h' must be positive integers", file);
  const int width = j["w"], height = j["h"];
  const json &k = j["k"], &w2c = j["w2c"], &fn = j["fn"], &ids = j["cam_id"];
  if (!fn.is_array() || fn.empty()) fail("{}: 'fn' must be a non-empty [T][C] array", file);
  const std::size_t steps = fn.size();
  for (const auto& [name, value] : {std::pair{"k", &k}, {"w2c", &w2c}, {"cam_id", &ids}})
    if (!value->is_array() || value->size() != steps)
      fail("{}: '{}' has {} time steps but 'fn' has {}", file, name,
           value->is_array() ? value->size() : 0, steps);
  if (!ids[0].is_array() || ids[0].empty()) fail("{}: 'cam_id' lists no camera", file);
  const std::size_t count = ids[0].size();
  std::vector<SourceCamera> cams(count);
  for (std::size_t t = 0; t < steps; ++t) {
    if (!ids[t].is_array() || ids[t].size() != count || !fn[t].is_array() ||
        fn[t].size() != count || !k[t].is_array() || k[t].size() != count || !w2c[t].is_array() ||
        w2c[t].size() != count)
      fail("{}: time step {} does not list the same {} cameras", file, t, count);
    for (std::size_t c = 0; c < count; ++c) {
      const std::string where = fmt::format("[{}][{}]", t, c);
      if (!ids[t][c].is_number_integer() || ids[t][c] != ids[0][c])
        fail("{}: 'cam_id{}' differs from time step 0", file, where);
      if (!fn[t][c].is_string()) fail("{}: 'fn{}' must be a string", file, where);
      check_frame_file(fn[t][c].get<std::string>(), file, where);
      cams[c].files.push_back(fn[t][c].get<std::string>());
      if (t > 0) continue;
      Camera& cam = cams[c].camera;
      cam.name = std::to_string(ids[0][c].get<int>());
      cam.width = width;
      cam.height = height;
      cam.split = split;
      const json& kk = k[0][c];
      if (!kk.is_array() || kk.size() != 3) fail("{}: 'k{}' must be 3x3", file, where);
      Eigen::Matrix3d intr;
      for (int r = 0; r < 3; ++r) {
        if (!kk[r].is_array() || kk[r].size() != 3) fail("{}: 'k{}' must be 3x3", file, where);
        for (int col = 0; col < 3; ++col)
          intr(r, col) =
              detail::finite_number(kk[r][col], file, fmt::format("k{}[{}][{}]", where, r, col));
      }
      cam.fx = intr(0, 0), cam.fy = intr(1, 1), cam.cx = intr(0, 2), cam.cy = intr(1, 2);
      if (!(cam.fx > 0 && cam.fy > 0)) fail("{}: 'k{}' has non-positive focal length", file, where);
      const json& m = w2c[0][c];
      if (!m.is_array() || m.size() != 4) fail("{}: 'w2c{}' must be 4x4", file, where);
      for (int r = 0; r < 4; ++r) {
        if (!m[r].is_array() || m[r].size() != 4) fail("{}: 'w2c{}' must be 4x4", file, where);
        for (int col = 0; col < 4; ++col)
          cam.world_to_camera(r, col) =
              detail::finite_number(m[r][col], file, fmt::format("w2c{}[{}][{}]", where, r, col));
      }
      check_rigid(cam.world_to_camera, fmt::format("{}: 'w2c{}'", file, where));
    }
  }
  return cams;
}

}  // namespace

void import_panoptic(const fs::path& source, const fs::path& out, const ImportOptions& options) {
  if (!fs::is_directory(source)) fail("{}: Panoptic source folder does not exist", source.string());
  check_downscale(options.downscale);
  std::vector<SourceCamera> cams = read_meta(source / "train_meta.json", Split::kTrain);
  if (fs::exists(source / "test_meta.json")) {
    auto test = read_meta(source / "test_meta.json", Split::kTest);
    cams.insert(cams.end(), test.begin(), test.end());
  }
  // Panoptic ids in numeric order: "0", "1", ... "30".
  std::sort(cams.begin(), cams.end(), [](const SourceCamera& a, const SourceCamera& b) {
    return std::stoi(a.camera.name) < std::stoi(b.camera.name);
  });
  for (std::size_t i = 1; i < cams.size(); ++i)
    if (cams[i].camera.name == cams[i - 1].camera.name)
      fail("{}: camera id {} appears in both train and test metadata", source.string(),
           cams[i].camera.name);

  const int steps = int(cams[0].files.size());
  for (const auto& c : cams)
    if (int(c.files.size()) != steps)
      fail("{}: train and test metadata have different frame counts ({} vs {})", source.string(),
           steps, c.files.size());
  // Plain ints, not a structured binding: clang 14 (the fuzzing build) cannot capture those in
  // lambdas.
  const auto [first_frame, last_frame] = detail::frame_range(options, steps, "the source");
  const int first = first_frame, last = last_frame;

  io::Scene scene;
  scene.num_frames = last - first + 1;
  scene.fps = kPanopticFps;
  scene.calibration = io::CalibrationSource::kLab;  // the dome's own calibration
  scene.up = {0, -1, 0};  // Panoptic world: floor at y = 0, people at y < 0
  for (const auto& c : cams) scene.cameras.push_back(downscaled(c.camera, options.downscale));

  // Check every source file before writing anything.
  struct Job {
    int camera, frame;
    fs::path image, mask;  // mask empty when absent
  };
  std::vector<Job> jobs;
  for (int c = 0; c < int(cams.size()); ++c)
    for (int k = first; k <= last; ++k) {
      Job job{c, k - first, source / "ims" / cams[c].files[k], {}};
      if (!fs::exists(input_status(job.image)))
        fail("{}: missing Panoptic image", job.image.string());
      fs::path mask = source / "seg" / cams[c].files[k];
      mask.replace_extension(".png");
      if (fs::exists(input_status(mask))) job.mask = mask;
      jobs.push_back(std::move(job));
    }

  AtomicDirectory dir(out, options.force);
  scene.root = dir.temp_path();
  const auto import_job = [&](std::size_t i, Progress& progress) {
    const Job& job = jobs[i];
    const Camera& cam = scene.cameras[job.camera];
    const Image image = media::read_image(job.image);
    if (image.width != cams[job.camera].camera.width ||
        image.height != cams[job.camera].camera.height)
      fail("{}: image is {}x{} but the metadata says {}x{}", job.image.string(), image.width,
           image.height, cams[job.camera].camera.width, cams[job.camera].camera.height);
    media::write_png(scene.image_path(job.camera, job.frame),
                     media::resize_area(image, cam.width, cam.height));
    if (!job.mask.empty()) {
      const Image mask = media::read_mask(job.mask);
      if (mask.width != image.width || mask.height != image.height)
        fail("{}: mask is {}x{} but its image is {}x{}", job.mask.string(), mask.width, mask.height,
             image.width, image.height);
      media::write_png(scene.mask_path(job.camera, job.frame),
                       media::resize_area(mask, cam.width, cam.height));
    }
    progress.tick();
  };
  detail::parallel_jobs(jobs.size(), jobs.size(), "import panoptic", options.progress, import_job);
  io::write_scene_json(scene);
  dir.commit();
}

}  // namespace retimegs::ingest
