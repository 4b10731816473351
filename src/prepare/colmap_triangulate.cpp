// `prepare --points colmap`: triangulation with known poses through the COLMAP command line
// (feature_extractor -> exhaustive_matcher -> point_triangulator), as COLMAP's FAQ "Reconstruct
// sparse/dense model from known camera poses" describes.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <tuple>

#include <fmt/format.h>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/prepare/colmap_triangulate.hpp"

extern char** environ;

namespace retimegs::prepare {
namespace fs = std::filesystem;

namespace {

// The COLMAP executable as a path, or empty when it cannot be found.
fs::path find_executable(const std::string& name) {
  auto runnable = [](const fs::path& p) {
    return fs::is_regular_file(p) && ::access(p.c_str(), X_OK) == 0;
  };
  if (name.find('/') != std::string::npos) return runnable(name) ? fs::path(name) : fs::path();
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  for (std::size_t start = 0; start <= dirs.size();) {
    std::size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    const fs::path candidate = fs::path(dirs.substr(start, end - start)) / name;
    if (end > start && runnable(candidate)) return candidate;
    start = end + 1;
  }
  return {};
}

// The line of a log that best explains a failure: the last one that mentions an error (glog's
// "Check failed", "ERROR", boost's "error"), else the last non-empty one.
std::string last_error_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last, last_error;
  while (std::getline(in, line)) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    if (line.empty() || line.rfind("*** ", 0) == 0 || line.rfind("    @ ", 0) == 0) continue;
    last = line;
    std::string lower = line;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (lower.find("error") != std::string::npos ||
        lower.find("check failed") != std::string::npos ||
        lower.find("failed") != std::string::npos)
      last_error = line;
  }
  return last_error.empty() ? (last.empty() ? "(no output)" : last) : last_error;
}

// What a COLMAP failure means, in a user's words, from its error line; empty when the line says
// nothing known. Its bundle adjuster's check fails (glog "Check failed: bundle_adjuster.Solve")
// when the images of a frame share too few matched features to solve for the points.
std::string failure_reason(const std::string& line) {
  if (line.find("bundle_adjuster") != std::string::npos)
    return ": its bundle adjustment could not solve, which happens when the cameras share too few "
           "matched features at this frame (too little texture, overlap or resolution)";
  return {};
}

// Runs `exe step args...` headless (QT_QPA_PLATFORM=offscreen), stdout and stderr into
// logs/<step>.log; throws Error with the log's error line when it fails.
void run_colmap(const fs::path& exe, const std::string& step, const std::vector<std::string>& args,
                const fs::path& log_dir, bool verbose) {
  fs::create_directories(log_dir);
  const fs::path log = log_dir / (step + ".log");
  std::vector<std::string> argv_s = {exe.string(), step};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);

  std::vector<std::string> env_s;
  for (char** e = environ; e && *e; ++e)
    if (std::strncmp(*e, "QT_QPA_PLATFORM=", 16) != 0) env_s.emplace_back(*e);
  env_s.emplace_back("QT_QPA_PLATFORM=offscreen");
  std::vector<char*> envp;
  for (auto& e : env_s) envp.push_back(e.data());
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (!verbose) posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) fail("colmap {}: cannot start {}: {}", step, exe.string(), std::strerror(rc));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) fail("colmap {}: waitpid failed: {}", step, std::strerror(errno));
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  const std::string how = WIFEXITED(status)
                              ? fmt::format("exit status {}", WEXITSTATUS(status))
                              : fmt::format("crashed with signal {}", WTERMSIG(status));
  const std::string line = verbose ? std::string("see stderr") : last_error_line(log);
  fail("colmap {} failed ({}){}: {} (log: {})", step, how, failure_reason(line), line,
       log.string());
}

std::string number(double v) {
  return fmt::format("{:.17g}", v);
}

}  // namespace

fs::path find_colmap(const ColmapOptions& options) {
  const fs::path exe = find_executable(options.executable);
  if (exe.empty())
    fail("COLMAP not found: install the Debian package colmap (scripts/setup.sh does)");
  return exe;
}

bool colmap_available(const ColmapOptions& options) {
  return !find_executable(options.executable).empty();
}

io::PointCloud triangulate_with_colmap(const io::Scene& scene, int frame, const fs::path& work_dir,
                                       const fs::path& log_dir, const ColmapOptions& options) {
  const fs::path exe = find_colmap(options);
  if (frame < 0 || frame >= scene.num_frames)
    fail("--points colmap: frame {} is outside the scene's frames 0:{}", frame,
         scene.num_frames - 1);
  const std::vector<int> cams = io::training_cameras(scene);
  if (cams.size() < 2)
    fail("--points colmap: triangulation needs at least 2 training cameras, the scene has {}",
         cams.size());

  // Fresh work folder (only what this function writes is removed).
  fs::create_directories(work_dir);
  for (const char* name : {"images", "known", "sparse", "database.db", "lists"})
    fs::remove_all(work_dir / name);
  const fs::path images = work_dir / "images", known = work_dir / "known",
                 sparse = work_dir / "sparse", &logs = log_dir, database = work_dir / "database.db";
  fs::create_directories(images);
  fs::create_directories(known);
  fs::create_directories(sparse);
  fs::create_directories(work_dir / "lists");

  // One COLMAP camera per distinct intrinsics; the known model below uses the same grouping.
  using Key = std::tuple<int, int, double, double, double, double>;
  std::map<Key, std::uint32_t> groups;
  io::ColmapModel model;
  std::map<std::uint32_t, std::vector<std::string>> group_images;
  for (std::size_t i = 0; i < cams.size(); ++i) {
    const Camera& cam = scene.cameras[cams[i]];
    const fs::path src = scene.image_path(cams[i], frame);
    if (!fs::is_regular_file(src)) fail("{}: missing image", src.string());
    const std::string name = cam.name + ".png";
    fs::copy_file(src, images / name, fs::copy_options::overwrite_existing);
    const Key key{cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy};
    auto [it, added] = groups.emplace(key, std::uint32_t(groups.size() + 1));
    if (added)
      model.cameras.push_back(
          {it->second, "PINHOLE", cam.width, cam.height, {cam.fx, cam.fy, cam.cx, cam.cy}});
    group_images[it->second].push_back(name);
    model.images.push_back(io::ColmapImage::from_world_to_camera(std::uint32_t(i + 1), it->second,
                                                                 name, cam.world_to_camera));
  }
  io::write_colmap_model_txt(model, known);

  const std::string threads = std::to_string(options.threads);
  for (const auto& cam : model.cameras) {
    const fs::path list = work_dir / "lists" / fmt::format("camera{}.txt", cam.id);
    write_text_file(list, fmt::format("{}\n", fmt::join(group_images[cam.id], "\n")));
    run_colmap(exe, "feature_extractor",
               {"--database_path",
                database.string(),
                "--image_path",
                images.string(),
                "--image_list_path",
                list.string(),
                "--ImageReader.camera_model",
                "PINHOLE",
                "--ImageReader.single_camera",
                "1",
                "--ImageReader.camera_params",
                fmt::format("{},{},{},{}", number(cam.params[0]), number(cam.params[1]),
                            number(cam.params[2]), number(cam.params[3])),
                "--SiftExtraction.use_gpu",
                "0",
                "--SiftExtraction.num_threads",
                threads,
                "--SiftExtraction.max_image_size",
                std::to_string(options.max_image_size),
                "--SiftExtraction.max_num_features",
                std::to_string(options.max_num_features),
                "--SiftExtraction.peak_threshold",
                number(options.peak_threshold)},
               logs, options.verbose);
  }
  run_colmap(exe, "exhaustive_matcher",
             {"--database_path", database.string(), "--SiftMatching.use_gpu", "0",
              "--SiftMatching.num_threads", threads, "--SiftMatching.guided_matching",
              options.guided_matching ? "1" : "0"},
             logs, options.verbose);
  // --clear_points 1 makes COLMAP renumber the known images by name to the database's ids.
  run_colmap(exe, "point_triangulator",
             {"--database_path", database.string(), "--image_path", images.string(), "--input_path",
              known.string(), "--output_path", sparse.string(), "--clear_points", "1",
              "--Mapper.num_threads", threads, "--Mapper.ba_refine_focal_length", "0",
              "--Mapper.ba_refine_principal_point", "0", "--Mapper.ba_refine_extra_params", "0",
              "--Mapper.filter_max_reproj_error", number(options.max_reprojection_error),
              // Known poses make a point seen by two cameras as good as any: keep them.
              "--Mapper.tri_ignore_two_view_tracks", "0"},
             logs, options.verbose);

  io::ColmapModel result = io::read_colmap_model(sparse);
  const std::size_t triangulated = result.points.size();
  std::erase_if(result.points, [&](const io::ColmapPoint& p) {
    return p.track_length < std::uint64_t(std::max(options.min_track_length, 2));
  });
  if (result.points.empty())
    fail(
        "colmap point_triangulator found no point seen by {} or more cameras for frame {} ({} "
        "triangulated from {} cameras; too little texture or overlap?); logs in {}",
        options.min_track_length, frame, triangulated, cams.size(), logs.string());
  return result.point_cloud();
}

}  // namespace retimegs::prepare
