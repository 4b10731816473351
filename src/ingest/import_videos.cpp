// A user's own capture (a video or an image folder per camera, and a COLMAP model, a rig file or
// a calibration COLMAP recovers from the footage) -> scene format (import.hpp: import_videos).
#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <map>
#include <memory>

#include <fmt/format.h>

#include "calibration.hpp"
#include "import_common.hpp"
#include "retimegs/colmap/run.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/limits.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/ingest/import.hpp"
#include "retimegs/ingest/sync.hpp"
#include "retimegs/ingest/timestamps.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/resize.hpp"

namespace retimegs::ingest {
namespace fs = std::filesystem;

namespace {

constexpr double kDefaultFps = 30.0;    // image folders carry no frame rate
constexpr double kFpsTolerance = 1e-3;  // one capture's videos agree on the rate within 0.1 %
// Where a recovered calibration goes in the scene, and its COLMAP logs.
const fs::path kCalibrationModel = "calibration";
const fs::path kCalibrationLogs = fs::path("logs") / "colmap" / "calibration";
// Frames per camera a recovered calibration reads by default, spread over the footage: enough
// positions of what moves to place every camera of a 31-camera dome (CMU Panoptic, 17 frames).
constexpr int kDefaultCalibrationInstants = 17;

// One camera's footage: a video, or a folder of images.
struct Footage {
  std::string name;
  fs::path path;                 // the video file or the image folder
  std::vector<fs::path> images;  // a folder's frames, sorted by name; empty for a video
  int width = 0, height = 0, frames = 0;
  double fps = 0;  // a video's
  bool video() const { return images.empty(); }
};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool is_video(const fs::path& p) {
  const std::string e = lower(p.extension().string());
  return e == ".mp4" || e == ".mov" || e == ".mkv" || e == ".avi";
}

bool is_image(const fs::path& p) {
  const std::string e = lower(p.extension().string());
  return e == ".png" || e == ".jpg" || e == ".jpeg";
}

// The cameras of `source`, sorted by name. Folders without images are not footage (a COLMAP
// model or other material may sit beside the videos).
std::vector<Footage> find_footage(const fs::path& source) {
  if (!fs::is_directory(source)) fail("{}: footage folder does not exist", source.string());
  std::vector<Footage> out;
  std::map<std::string, fs::path> seen;
  for (const auto& entry : fs::directory_iterator(source)) {
    const fs::path& p = entry.path();
    Footage f;
    f.path = p;
    if (entry.is_regular_file() && is_video(p)) {
      f.name = p.stem().string();
    } else if (entry.is_directory()) {
      for (const auto& e : fs::directory_iterator(p))
        if (e.is_regular_file() && is_image(e.path())) f.images.push_back(e.path());
      if (f.images.empty()) continue;
      std::sort(f.images.begin(), f.images.end());
      f.name = p.filename().string();
    } else {
      continue;
    }
    if (const auto it = seen.find(f.name); it != seen.end())
      fail("{}: camera '{}' has two sources, {} and {}", source.string(), f.name,
           std::min(it->second, p).filename().string(),
           std::max(it->second, p).filename().string());
    seen[f.name] = p;
    out.push_back(std::move(f));
  }
  if (out.empty())
    fail(
        "{}: no footage (<camera>.mp4 / .mov / .mkv / .avi videos, or <camera>/ folders of PNG / "
        "JPEG images)",
        source.string());
  std::sort(out.begin(), out.end(),
            [](const Footage& a, const Footage& b) { return a.name < b.name; });
  return out;
}

void probe(Footage& f) {
  if (f.video()) {
    const detail::VideoInfo v = detail::probe_video(f.path);
    f.width = v.width, f.height = v.height, f.frames = v.frames, f.fps = v.fps;
  } else {
    const media::ImageSize size = media::read_image_size(f.images.front());
    f.width = size.width, f.height = size.height, f.frames = int(f.images.size());
  }
}

// Source frame k of an image folder, checked against the camera's first image.
Image folder_frame(const Footage& f, int k) {
  const fs::path& file = f.images[k];
  const Image image = media::read_image(file);
  if (image.width != f.width || image.height != f.height)
    fail("{}: image is {}x{} but {} (the camera's first) is {}x{}", file.string(), image.width,
         image.height, f.images.front().filename().string(), f.width, f.height);
  return image;
}

detail::VideoInfo video_info(const Footage& f) {
  return {f.path, f.width, f.height, f.frames, f.fps};
}

// Source frame k of a camera.
Image footage_frame(const Footage& f, int k) {
  if (!f.video()) return folder_frame(f, k);
  Image out;
  detail::decode_video(video_info(f), k, k, [&](const Image& image, int) { out = image; });
  return out;
}

// Whether `out` holds nothing but the logs a failed calibration left (kCalibrationLogs), which
// the next import may replace without --force.
bool only_calibration_logs(const fs::path& out) {
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(out, ec))) return false;
  const fs::path logs = out / kCalibrationLogs;
  for (auto it = fs::recursive_directory_iterator(out, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    const fs::path& p = it->path();
    const auto [mismatch, rest] = std::mismatch(logs.begin(), logs.end(), p.begin(), p.end());
    const bool inside = mismatch == logs.end();
    const bool above = rest == p.end();  // out/logs, out/logs/colmap
    if (!inside && !(above && it->is_directory())) return false;
  }
  return !ec;
}

// The frame rate and how it was chosen (for the log).
std::pair<double, std::string> choose_fps(const fs::path& source,
                                          const std::vector<Footage>& footage,
                                          const std::optional<double>& fps) {
  double first = 0, lo = 0, hi = 0;
  std::string rates;
  bool any = false;
  for (const Footage& f : footage) {
    if (!f.video()) continue;
    if (!any) first = lo = hi = f.fps;
    lo = std::min(lo, f.fps), hi = std::max(hi, f.fps);
    rates += fmt::format("{}{} {:.6g}", any ? ", " : "", f.path.filename().string(), f.fps);
    any = true;
  }
  if (fps) {
    check_fps(*fps, "--fps");
    if (!any) return {*fps, "--fps"};
    return {*fps, lo == hi ? fmt::format("--fps; the videos say {:.6g}", lo)
                           : fmt::format("--fps; the videos say {:.6g} to {:.6g}", lo, hi)};
  }
  if (!any) return {kDefaultFps, "the default for image folders; --fps sets it"};
  if (hi - lo > kFpsTolerance * hi)
    fail(
        "{}: the videos disagree on the frame rate (they must agree within 0.1 %; --fps F "
        "overrides): {}",
        source.string(), rates);
  return {first, "from the videos"};
}

// The first and last k that every camera has (source frame k + offset within its frames).
std::pair<int, int> common_frames(const std::vector<Footage>& footage,
                                  const std::vector<int>& offsets) {
  int lo = 0, hi = INT_MAX, lo_camera = -1, hi_camera = -1;
  for (std::size_t c = 0; c < footage.size(); ++c) {
    if (-offsets[c] > lo) lo = -offsets[c], lo_camera = int(c);
    if (footage[c].frames - 1 - offsets[c] < hi)
      hi = footage[c].frames - 1 - offsets[c], hi_camera = int(c);
  }
  if (hi >= lo) return {lo, hi};
  const Footage& h = footage[hi_camera];
  if (lo_camera < 0 || lo_camera == hi_camera || h.frames - 1 - offsets[hi_camera] < 0)
    fail("--offsets: {}:{} leaves no frame of {} ({} frames)", h.name, offsets[hi_camera],
         h.path.string(), h.frames);
  const Footage& l = footage[lo_camera];
  fail(
      "--offsets: no frame is common to every camera: {}:{} starts at scene frame {}, but {} "
      "({} frames, offset {}) ends at {}",
      l.name, offsets[lo_camera], lo, h.name, h.frames, offsets[hi_camera], hi);
}

std::string join(const std::vector<std::string>& names) {
  return fmt::format("{}", fmt::join(names, ", "));
}

// The calibrated cameras of a calibration file or model, in footage order; cameras without
// footage are listed in `without_footage`.
std::vector<detail::CalibratedCamera> match_calibration(const fs::path& path,
                                                        const std::vector<std::string>& names,
                                                        const fs::path& source,
                                                        std::vector<std::string>& without_footage) {
  const std::vector<detail::CalibratedCamera> calibration = detail::read_calibration(path);
  std::map<std::string, std::vector<const detail::CalibratedCamera*>> by_name;
  for (const auto& cam : calibration) by_name[cam.name].push_back(&cam);
  std::vector<std::string> missing;
  std::vector<detail::CalibratedCamera> matched;
  for (const std::string& name : names) {
    const auto it = by_name.find(name);
    if (it == by_name.end()) {
      missing.push_back(name);
      continue;
    }
    if (it->second.size() > 1)
      fail("{} and {}: both are camera '{}' (their file stems are equal)", it->second[0]->where,
           it->second[1]->where, name);
    matched.push_back(*it->second[0]);
  }
  if (!missing.empty())
    fail("{}: no calibration for camera{} {} (footage in {})", path.string(),
         missing.size() > 1 ? "s" : "", join(missing), source.string());
  for (const auto& [name, cams] : by_name)
    if (!std::binary_search(names.begin(), names.end(), name)) without_footage.push_back(name);
  return matched;
}

// Instants spread evenly over the k that every camera has, lo..hi, for a recovered calibration:
// `count` of them, or every k where there are fewer.
std::vector<int> calibration_instants(int lo, int hi, int count) {
  const int n = std::min(count, hi - lo + 1);
  std::vector<int> out;
  for (int i = 0; i < n; ++i)
    out.push_back(n == 1 ? lo + (hi - lo) / 2
                         : lo + int(std::lround(double(i) * (hi - lo) / (n - 1))));
  return out;
}

// A calibration recovered by COLMAP (detail::recover_calibration) from source frame `frame` +
// offsets[c] of every camera (the reference frame) and from `instants` (k, source frame k +
// offsets[c]), written to scene_root/calibration, its logs in scene_root/logs/colmap/calibration.
// Cameras it cannot place are removed from `footage` and `offsets` (and listed in the report);
// the others' calibrations are returned in footage order.
std::vector<detail::CalibratedCamera> recover(std::vector<Footage>& footage,
                                              std::vector<int>& offsets, int frame,
                                              const std::vector<int>& instants,
                                              const fs::path& scene_root,
                                              const std::string& camera_model,
                                              const ImportOptions& options, VideosReport& report) {
  const colmap::WorkFolder work("calibration");
  std::vector<std::string> names;
  detail::parallel_jobs(footage.size(), footage.size(), "calibration frames", options.progress,
                        [&](std::size_t c, Progress& progress) {
                          media::write_png(work.path() / "images" / (footage[c].name + ".png"),
                                           footage_frame(footage[c], frame + offsets[c]));
                          progress.tick();
                        });
  for (const Footage& f : footage) names.push_back(f.name);
  colmap::ColmapOptions colmap_options;
  colmap_options.threads = max_threads();
  colmap_options.camera_model = camera_model;
  detail::CalibrationFrames frames;
  frames.instants = int(instants.size());
  frames.frame = [&](std::size_t c, int k) {
    const Image image = footage_frame(footage[c], instants[k] + offsets[c]);
    if (image.width != footage[c].width || image.height != footage[c].height)
      fail("{}: frame {} is {}x{}, the camera's others {}x{}", footage[c].path.string(),
           instants[k] + offsets[c], image.width, image.height, footage[c].width,
           footage[c].height);
    return image;
  };
  detail::RecoveredCalibration recovered =
      detail::recover_calibration(names, frames, work.path(), scene_root / kCalibrationModel,
                                  scene_root / kCalibrationLogs, colmap_options, options.progress);
  std::vector<Footage> kept;
  std::vector<int> kept_offsets;
  for (std::size_t c = 0; c < footage.size(); ++c)
    if (!std::binary_search(recovered.unregistered.begin(), recovered.unregistered.end(),
                            footage[c].name))
      kept.push_back(std::move(footage[c])), kept_offsets.push_back(offsets[c]);
  footage = std::move(kept);
  offsets = std::move(kept_offsets);
  report.recovered = true;
  report.registered = int(recovered.cameras.size());
  report.unregistered = std::move(recovered.unregistered);
  report.points = recovered.points;
  report.reprojection_error = recovered.reprojection_error;
  report.moving_features = recovered.moving;
  report.reconstructions = recovered.reconstructions;
  report.spread = recovered.spread;
  report.spread_camera = std::move(recovered.spread_camera);
  return std::move(recovered.cameras);
}

// --sync auto: every camera's --offsets value, minus its lag against the first camera's (sync.hpp),
// from the motion energy of all its source frames, decoded one at a time, to kSyncResolution.
std::map<std::string, double> estimate_offsets(const std::vector<Footage>& footage,
                                               const std::optional<int>& max_lag,
                                               const ImportOptions& options, VideosReport& report) {
  std::vector<MotionEnergy> energy(footage.size());
  std::size_t total = 0;
  int common = INT_MAX;
  for (const Footage& f : footage)
    total += std::size_t(f.frames), common = std::min(common, f.frames);
  report.sync_max_lag = max_lag.value_or(default_max_lag(common));
  if (report.sync_max_lag < 1)
    fail("--sync-max-lag: {} is not a positive number of frames", report.sync_max_lag);
  detail::parallel_jobs(footage.size(), total, "sync", options.progress,
                        [&](std::size_t c, Progress& progress) {
                          const Footage& f = footage[c];
                          const auto use = [&](const Image& image, int) {
                            energy[c].add(image);
                            progress.tick();
                          };
                          if (f.video())
                            return detail::decode_video(video_info(f), 0, f.frames - 1, use);
                          for (int k = 0; k < f.frames; ++k) use(folder_frame(f, k), k);
                        });
  std::map<std::string, double> offsets;
  for (std::size_t c = 0; c < footage.size(); ++c) {
    VideosReport::SyncedCamera synced{footage[c].name, 0.0, 1.0, {}};
    if (c > 0) {
      const LagEstimate e =
          estimate_lag(energy[0].signal(), energy[c].signal(), report.sync_max_lag);
      synced.offset = round_to_sync_resolution(-e.lag);
      synced.peak = e.peak;
      synced.weak = e.weak;
    }
    offsets[synced.name] = synced.offset;
    report.sync.push_back(std::move(synced));
  }
  return offsets;
}

}  // namespace

WholeOffset split_offset(double x) {
  if (!std::isfinite(x) || std::abs(x) > double(kMaxFrames))
    fail("--offsets: {} is not a finite number of frames within ±{}", x, kMaxFrames);
  const int frames = int(std::lround(x));
  return {frames, double(frames) - x};
}

VideosReport import_videos(const fs::path& source, const fs::path& out,
                           const ImportOptions& options, const VideosOptions& videos) {
  check_downscale(options.downscale);
  std::vector<Footage> footage = find_footage(source);
  std::vector<std::string> names;
  for (const Footage& f : footage) names.push_back(f.name);
  const bool recovering = videos.calibration.empty();
  if (!recovering && videos.calibration_frame)
    fail("--calib-frame: only without --calib (it chooses the frame COLMAP calibrates from)");
  if (!recovering && videos.calibration_instants)
    fail("--calib-frames: only without --calib (it chooses the frames COLMAP calibrates from)");
  const int instant_count = videos.calibration_instants.value_or(kDefaultCalibrationInstants);
  if (instant_count < 1) fail("--calib-frames: {} is not a positive count", instant_count);
  if (!recovering && videos.camera_model)
    fail("--camera-model: only without --calib (the calibration gives each camera's model)");
  const std::string camera_model =
      videos.camera_model.value_or(std::string(kRecoveredCameraModels.front()));
  if (std::find(kRecoveredCameraModels.begin(), kRecoveredCameraModels.end(), camera_model) ==
      kRecoveredCameraModels.end())
    fail("--camera-model: {} is not one a calibration is recovered with ({})", camera_model,
         fmt::join(kRecoveredCameraModels, ", "));

  VideosReport report;
  std::vector<detail::CalibratedCamera> calibration;
  if (!recovering)
    calibration = match_calibration(videos.calibration, names, source, report.without_footage);

  for (const std::string& name : videos.test_cameras)
    if (!std::binary_search(names.begin(), names.end(), name))
      fail("--test-cameras: unknown camera '{}' (cameras: {})", name, join(names));
  for (const auto& [name, offset] : videos.offsets) {
    if (!std::binary_search(names.begin(), names.end(), name))
      fail("--offsets: unknown camera '{}' (cameras: {})", name, join(names));
    if (!videos.timestamps.empty() && offset != std::floor(offset))
      fail(
          "--offsets: {}:{} is not a whole number of frames, which is all --offsets may be with "
          "--timestamps (the timestamps say when each frame shows the scene)",
          name, offset);
  }
  if (videos.sync_auto && !videos.offsets.empty())
    fail("--sync auto: not with --offsets (it estimates every camera's; give all of them instead)");
  if (videos.sync_auto && !videos.timestamps.empty())
    fail("--sync auto: not with --timestamps (they give every frame's time already)");
  if (!videos.sync_auto && videos.sync_max_lag)
    fail("--sync-max-lag: only with --sync auto (it bounds the offsets it estimates)");
  std::optional<Timestamps> timestamps;
  if (!videos.timestamps.empty()) timestamps = read_timestamps(videos.timestamps, names);

  for (Footage& f : footage) probe(f);
  const auto [fps, fps_source] = choose_fps(source, footage, videos.fps);
  const std::map<std::string, double> given =
      videos.sync_auto ? estimate_offsets(footage, videos.sync_max_lag, options, report)
                       : videos.offsets;
  std::vector<int> offsets;
  for (const Footage& f : footage) {
    const auto it = given.find(f.name);
    offsets.push_back(it == given.end() ? 0 : split_offset(it->second).frames);
  }
  const auto [lo, hi] = common_frames(footage, offsets);
  const auto [first, last] =
      detail::frame_range(options, hi - lo + 1,
                          videos.sync_auto ? "the footage after the offsets --sync auto estimated"
                          : videos.offsets.empty() ? "the footage"
                                                   : "the footage after --offsets");
  const int scene_start = lo + first;  // k of scene frame 0
  // Every camera's frame_times, checked before COLMAP or the images take their time.
  std::map<std::string, std::vector<double>> frame_times;
  if (timestamps) {
    std::vector<int> source_first;
    for (int offset : offsets) source_first.push_back(scene_start + offset);
    const auto times =
        frame_times_from_timestamps(*timestamps, names, source_first, last - first + 1, fps);
    for (std::size_t c = 0; c < names.size(); ++c) frame_times[names[c]] = times[c];
  }

  io::Scene scene;
  scene.num_frames = last - first + 1;
  scene.fps = fps;
  // A rig file, a COLMAP model or COLMAP from scratch: the user's, a few pixels off.
  scene.calibration = io::CalibrationSource::kUser;
  AtomicDirectory dir(out, options.force || (recovering && only_calibration_logs(out)));
  scene.root = dir.temp_path();
  if (recovering) {
    const int frame = videos.calibration_frame.value_or((scene.num_frames - 1) / 2);
    if (frame < 0 || frame >= scene.num_frames)
      fail("--calib-frame: {} is outside the scene's frames 0:{}", frame, scene.num_frames - 1);
    const std::vector<int> instants = calibration_instants(lo, hi, instant_count);
    try {
      calibration = recover(
          footage, offsets, scene_start + frame,
          instants.size() >= std::size_t(detail::kMinInstants) ? instants : std::vector<int>(),
          scene.root, camera_model, options, report);
    } catch (const Error&) {
      // The logs outlive the scene, where the message says they are.
      if (fs::is_directory(scene.root / kCalibrationLogs)) {
        const fs::path logs = output_path(out) / kCalibrationLogs;
        fs::remove_all(logs);
        fs::create_directories(logs.parent_path());
        fs::rename(scene.root / kCalibrationLogs, logs);
      }
      throw;
    }
    report.calibration =
        report.moving_features
            ? fmt::format(
                  "recovered by COLMAP from what moves in {} frames over the footage, refined with "
                  "what stands still, written to {}",
                  instants.size(), (output_path(out) / kCalibrationModel).string())
            : fmt::format("recovered by COLMAP from scene frame {}, written to {}", frame,
                          (output_path(out) / kCalibrationModel).string());
  } else {
    report.calibration = fs::is_directory(videos.calibration)
                             ? "COLMAP model " + io::find_colmap_model(videos.calibration).string()
                             : "rig file " + videos.calibration.string();
  }

  std::vector<std::unique_ptr<detail::Undistorter>> undistorters;
  for (std::size_t c = 0; c < footage.size(); ++c) {
    const Footage& f = footage[c];
    const detail::CalibratedCamera& cal = calibration[c];
    undistorters.push_back(std::make_unique<detail::Undistorter>(
        detail::fit_to_footage(cal.intrinsics, f.width, f.height, cal.where, f.path.string()),
        cal.where));
    Camera cam = undistorters.back()->pinhole();
    cam.name = f.name;
    cam.world_to_camera = cal.world_to_camera;
    const auto& test = videos.test_cameras;
    cam.split =
        std::find(test.begin(), test.end(), f.name) != test.end() ? Split::kTest : Split::kTrain;
    report.test_cameras += cam.split == Split::kTest;
    report.undistorted += !undistorters.back()->identity();
    scene.cameras.push_back(downscaled(cam, options.downscale));
  }
  scene.up = detail::mean_camera_up(scene.cameras);

  // The fractions of the offsets (split_offset) or the timestamps, as the cameras' clocks.
  for (const Footage& f : footage) {
    const auto it = given.find(f.name);
    scene.clocks.push_back({it == given.end() ? 0.0 : split_offset(it->second).time_offset,
                            timestamps ? frame_times.at(f.name) : std::vector<double>()});
  }
  if (!io::has_own_clocks(scene)) scene.clocks.clear();
  if (videos.sync_auto) scene.clock_source = io::ClockSource::kEstimated;
  for (std::size_t c = 0; c < footage.size(); ++c) {
    const int source_first = scene_start + offsets[c];
    scene.sources.push_back({footage[c].path.filename().string(), source_first,
                             source_first + scene.num_frames - 1, offsets[c], footage[c].fps});
  }
  const std::size_t total = footage.size() * std::size_t(scene.num_frames);
  detail::parallel_jobs(
      footage.size(), total, "import videos", options.progress,
      [&](std::size_t c, Progress& progress) {
        const Footage& f = footage[c];
        const Camera& cam = scene.cameras[c];
        const int source_first = scene.sources[c].first_frame;
        auto store = [&](const Image& image, int frame) {
          media::write_png(
              scene.image_path(int(c), frame),
              media::resize_area(undistorters[c]->apply(image), cam.width, cam.height));
          progress.tick();
        };
        if (!f.video()) {
          for (int j = 0; j < scene.num_frames; ++j) store(folder_frame(f, source_first + j), j);
          return;
        }
        detail::decode_video(video_info(f), source_first, source_first + scene.num_frames - 1,
                             [&](const Image& image, int k) { store(image, k - source_first); });
      });
  io::write_scene_json(scene);
  dir.commit();

  report.cameras = int(scene.cameras.size());
  report.frames = scene.num_frames;
  report.first_frame = scene_start;
  report.fps = fps;
  report.fps_source = fps_source;
  return report;
}

}  // namespace retimegs::ingest
