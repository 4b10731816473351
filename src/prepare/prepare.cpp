#include "retimegs/prepare/prepare.hpp"

#include <algorithm>
#include <array>
#include <optional>
#include <system_error>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/core/progress.hpp"
#include "retimegs/core/stopwatch.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/media/scene_images.hpp"

namespace retimegs::prepare {

namespace fs = std::filesystem;

namespace {

// One pair of consecutive training frames of one camera: the forward and backward files.
struct FlowJob {
  int camera = 0, from = 0, to = 0;
  bool write_forward = false, write_backward = false;
};

// COLMAP's points of frame k, triangulated in a temporary folder that is removed afterwards,
// failed or not; its logs stay in the scene (SCENE/logs/colmap/<frame:05d>/), where a failure's
// message points.
io::PointCloud colmap_points(const io::Scene& scene, int k, const ColmapOptions& options) {
  const colmap::WorkFolder work(fmt::format("{:05d}", k));
  const fs::path logs = scene.root / "logs" / "colmap" / fmt::format("{:05d}", k);
  return triangulate_with_colmap(scene, k, work.path(), logs, options);
}

// The default points build a frame when their sources give at least this many points: fewer (a
// handful of COLMAP matches across a wide baseline) leave the frame's geometry to chance.
constexpr std::size_t kMinFramePoints = 100;

// What to try where --points colmap fails.
constexpr const char* kOtherSources =
    "Other point sources: --points hull (needs a mask for every training view), --points ply DIR "
    "(your own clouds), --points random (no geometry: fog where the images have little texture)";

// Appends b to a. When either has colours the result has them, grey where a source had none.
void append(io::PointCloud& a, const io::PointCloud& b) {
  constexpr float kGrey = 0.5f;
  const bool colours = !a.rgb.empty() || !b.rgb.empty();
  if (colours && a.rgb.empty()) a.rgb.assign(a.xyz.size(), kGrey);
  a.xyz.insert(a.xyz.end(), b.xyz.begin(), b.xyz.end());
  if (colours && b.rgb.empty()) a.rgb.insert(a.rgb.end(), b.xyz.size(), kGrey);
  if (colours && !b.rgb.empty()) a.rgb.insert(a.rgb.end(), b.rgb.begin(), b.rgb.end());
}

// OpenCV's own threads off while the OpenMP workers each run an estimator (no oversubscription).
class OpenCvThreads {
 public:
  explicit OpenCvThreads(int threads) : saved_(cv::getNumThreads()) { cv::setNumThreads(threads); }
  ~OpenCvThreads() { cv::setNumThreads(saved_); }

 private:
  int saved_;
};

fs::path import_path(const fs::path& dir, const io::Scene& scene, int camera, int from, int to) {
  return dir / scene.cameras[camera].name / fmt::format("{:05d}_{:05d}.flo", from, to);
}

// Copies `source` to `target` atomically.
void copy_atomic(const fs::path& source, const fs::path& target) {
  AtomicFile file(target);
  std::error_code ec;
  fs::copy_file(source, file.temp_path(), fs::copy_options::overwrite_existing, ec);
  if (ec) fail("{}: cannot copy to {}: {}", source.string(), target.string(), ec.message());
  file.commit();
}

// Validates every flow file to import before anything is written.
void check_flow_imports(const io::Scene& scene, const std::vector<FlowJob>& jobs,
                        const fs::path& dir) {
  if (!fs::is_directory(dir)) fail("--flow-dir: {}: not a directory", dir.string());
  struct Import {
    fs::path path;
    int camera;
  };
  std::vector<Import> needed;
  for (const FlowJob& job : jobs) {
    if (job.write_forward)
      needed.push_back({import_path(dir, scene, job.camera, job.from, job.to), job.camera});
    if (job.write_backward)
      needed.push_back({import_path(dir, scene, job.camera, job.to, job.from), job.camera});
  }
  std::size_t missing = 0;
  const fs::path* first = nullptr;
  for (const Import& i : needed)
    if (!fs::is_regular_file(i.path)) {
      if (!first) first = &i.path;
      ++missing;
    }
  if (first)
    fail(
        "--flow-dir: {}: missing ({} of the {} flow files to import are missing; expected "
        "<dir>/<camera>/<from:05d>_<to:05d>.flo)",
        first->string(), missing, needed.size());
  parallel_for(needed.size(), [&](std::size_t i) {
    const Flow flow = io::read_flo(needed[i].path);  // tag, size, length, NaN
    const Camera& cam = scene.cameras[needed[i].camera];
    if (flow.width != cam.width || flow.height != cam.height)
      fail("{}: flow is {}x{} but camera '{}' images are {}x{}", needed[i].path.string(),
           flow.width, flow.height, cam.name, cam.width, cam.height);
  });
}

const char* points_source_name(PointsSource source) {
  switch (source) {
    case PointsSource::kHull:
      return "hull";
    case PointsSource::kRandom:
      return "random";
    case PointsSource::kPly:
      return "ply";
    case PointsSource::kColmap:
      return "colmap";
    case PointsSource::kStereo:
      return "stereo";
  }
  return "?";
}

bool has_every_mask(const io::Scene& scene, const std::vector<int>& cameras,
                    const std::vector<int>& frames) {
  for (int c : cameras)
    for (int k : frames)
      if (!fs::exists(scene.mask_path(c, k))) return false;
  return true;
}

// Background-model masks of every camera with a missing mask (prepare/masks.hpp), one camera per
// worker, each file atomic.
void write_masks(const io::Scene& scene, const std::vector<int>& train_frames,
                 const MaskOptions& mask_options, const PrepareOptions& options,
                 PrepareReport& report) {
  std::vector<int> cameras;
  for (int c = 0; c < int(scene.cameras.size()); ++c) {
    bool missing = false;
    for (int k = 0; k < scene.num_frames; ++k)
      if (options.force || !fs::exists(scene.mask_path(c, k)))
        missing = true;
      else
        ++report.masks_kept;
    if (missing) cameras.push_back(c);
  }
  const std::vector<std::size_t> learn(train_frames.begin(), train_frames.end());
  Progress progress("masks", cameras.size(), options.progress);
  const OpenCvThreads single(max_threads() > 1 ? 1 : cv::getNumThreads());
  double foreground = 0;
  parallel_for(cameras.size(), [&](std::size_t i) {
    const int c = cameras[i];
    std::vector<Image> clip;
    for (int k = 0; k < scene.num_frames; ++k) clip.push_back(media::load_image(scene, c, k));
    const std::vector<Image> masks = background_masks(clip, learn, mask_options);
    std::size_t written = 0;
    double share = 0;
    for (int k = 0; k < scene.num_frames; ++k) {
      const fs::path path = scene.mask_path(c, k);
      if (!options.force && fs::exists(path)) continue;
      media::write_png(path, masks[k]);
      share +=
          std::count(masks[k].data.begin(), masks[k].data.end(), 1.0f) / double(masks[k].pixels());
      ++written;
    }
#pragma omp critical(prepare_stats)
    report.masks_written += written, foreground += share;
    progress.tick();
  });
  if (report.masks_written > 0)
    write_text_file(scene.estimated_masks_marker(),
                    "{\"written_by\": \"retimegs prepare --masks\", \"approximate\": true}\n");
  report.mask_coverage = report.masks_written ? foreground / double(report.masks_written) : 0.0;
}

}  // namespace

PointsPlan default_points(const PointsRig& rig) {
  PointsPlan plan;
  std::vector<std::string> used;
  std::string aside;
  const bool own_masks = rig.every_view_has_mask && !rig.masks_estimated;
  if (own_masks) {
    plan.sources.push_back(PointsSource::kHull);
    used.push_back("hull (masks at every training view)");
  } else if (!rig.every_view_has_mask) {
    aside = "no hull: not every training view has a mask";
  }
  if (rig.colmap_found) {
    plan.sources.push_back(PointsSource::kColmap);
    used.push_back(
        fmt::format("colmap{} ({} training cameras)",
                    keeps_two_view_tracks(rig.training_cameras) ? " with two-view tracks" : "",
                    rig.training_cameras));
    // The approximate masks of --masks give a hull of what moves: better than no geometry.
    if (rig.every_view_has_mask && rig.masks_estimated) {
      plan.fallbacks.push_back(PointsSource::kHull);
      aside = "the hull of --masks' approximate masks only where colmap finds no point";
    }
  } else {
    plan.sources.push_back(PointsSource::kRandom);
    used.push_back("random (COLMAP not found)");
    plan.note = fmt::format(
        "COLMAP not found: random points stand in for the {}scene (install the Debian package "
        "colmap, as scripts/setup.sh does, for triangulated points)",
        own_masks ? "background of the " : "");
  }
  // Without masks of its own a rig of few cameras has only COLMAP's sparse points, a few dozen a
  // frame: dense pair stereo joins them where a pair's baseline allows. (With masks the hull gives
  // the foreground densely, and a large rig triangulates enough.)
  if (!own_masks && keeps_two_view_tracks(rig.training_cameras) && rig.stereo_pairs > 0) {
    plan.sources.push_back(PointsSource::kStereo);
    used.push_back(fmt::format("stereo ({} camera pair{})", rig.stereo_pairs,
                               rig.stereo_pairs == 1 ? "" : "s"));
  }
  plan.summary = fmt::format("{}", fmt::join(used, " + "));
  if (!aside.empty()) plan.summary += "; " + aside;
  return plan;
}

PrepareReport prepare_scene(const io::Scene& scene, const PrepareOptions& options) {
  PrepareReport report;
  if (options.window && options.masks)
    fail("{}: masks are learnt from the whole clip: write them without a window first",
         scene.json_path().string());
  const io::TrainingViews views = options.window
                                      ? io::training_views(scene, options.frames, *options.window)
                                      : io::training_views(scene, options.frames);
  const std::vector<int>& cameras = views.cameras;
  const std::vector<int>& frames = views.frames;
  if (cameras.empty()) fail("{}: no training cameras", scene.json_path().string());

  Stopwatch clock;
  if (options.masks) write_masks(scene, frames, *options.masks, options, report);
  report.masks_seconds = clock.lap();

  // What is missing.
  std::vector<FlowJob> jobs;
  for (int c : cameras)
    for (const auto& [from, to] : views.flow_pairs) {
      FlowJob job{c, from, to};
      job.write_forward = options.force || !fs::exists(scene.flow_path(c, job.from, job.to));
      job.write_backward = options.force || !fs::exists(scene.flow_path(c, job.to, job.from));
      report.flows_kept += !job.write_forward + !job.write_backward;
      if (job.write_forward || job.write_backward) jobs.push_back(job);
    }
  std::vector<int> point_frames;
  for (int k : frames)
    if (options.force || !fs::exists(scene.points_path(k)))
      point_frames.push_back(k);
    else
      ++report.points_kept;

  std::vector<PointsSource> sources = options.points, fallbacks;
  const bool default_points_used = sources.empty();
  if (default_points_used && !point_frames.empty()) {
    const PointsPlan plan =
        default_points({cameras.size(), has_every_mask(scene, cameras, frames),
                        fs::exists(scene.estimated_masks_marker()),
                        colmap_available(options.colmap), stereo_pairs(scene, cameras).size()});
    sources = plan.sources;
    fallbacks = plan.fallbacks;
    report.points_plan = plan.summary;
    report.points_note = plan.note;
  }

  // Check every input before writing anything.
  report.flows_imported = !options.flow_dir.empty();
  if (report.flows_imported) check_flow_imports(scene, jobs, options.flow_dir);
  std::vector<io::PointCloud> imported(point_frames.size());
  if (!point_frames.empty()) {
    for (PointsSource source : sources) switch (source) {
        case PointsSource::kHull:
          for (int c : cameras)
            for (int k : point_frames)
              if (!fs::exists(scene.mask_path(c, k)))
                fail(
                    "{}: no mask; --points hull needs a mask for every training camera at every "
                    "training frame (use --points random, ply or colmap instead)",
                    scene.mask_path(c, k).string());
          break;
        case PointsSource::kPly:
          if (!fs::is_directory(options.points_dir))
            fail("--points ply: {}: not a directory", options.points_dir.string());
          for (std::size_t i = 0; i < point_frames.size(); ++i)
            imported[i] =
                read_frame_points(options.points_dir / fmt::format("{:05d}.ply", point_frames[i]));
          break;
        case PointsSource::kColmap:
          find_colmap(options.colmap);
          break;
        default:
          break;
      }
  }

  // Flows.
  if (!jobs.empty()) {
    Progress progress(report.flows_imported ? "flow import" : "flow", jobs.size(),
                      options.progress);
    const OpenCvThreads single(max_threads() > 1 ? 1 : cv::getNumThreads());
    // Per camera: flows, unknown pixels, pixels.
    std::vector<std::array<std::size_t, 3>> by_camera(scene.cameras.size(), {0, 0, 0});
    // After an error the flows already written stay: each file is atomic, and a re-run keeps them.
    parallel_for(jobs.size(), [&](std::size_t j) {
      const FlowJob& job = jobs[j];
      const fs::path forward = scene.flow_path(job.camera, job.from, job.to);
      const fs::path backward = scene.flow_path(job.camera, job.to, job.from);
      if (report.flows_imported) {
        const fs::path& dir = options.flow_dir;
        if (job.write_forward)
          copy_atomic(import_path(dir, scene, job.camera, job.from, job.to), forward);
        if (job.write_backward)
          copy_atomic(import_path(dir, scene, job.camera, job.to, job.from), backward);
      } else {
        const FlowPair pair = estimate_flow_pair(media::load_image(scene, job.camera, job.from),
                                                 media::load_image(scene, job.camera, job.to),
                                                 options.flow_method, options.consistency);
        std::size_t marked = 0;
        if (job.write_forward) io::write_flo(forward, pair.forward);
        if (job.write_backward) io::write_flo(backward, pair.backward);
        for (const Flow* f : {&pair.forward, &pair.backward})
          marked += std::count(f->valid.begin(), f->valid.end(), 0);
#pragma omp critical(prepare_stats)
        {
          std::array<std::size_t, 3>& counts = by_camera[job.camera];
          counts[0] += 2, counts[1] += marked, counts[2] += 2 * pair.forward.pixels();
        }
      }
#pragma omp critical(prepare_stats)
      report.flows_written += job.write_forward + job.write_backward;
      progress.tick();
    });
    std::size_t unknown = 0, pixels = 0;
    for (std::size_t c = 0; c < by_camera.size(); ++c) {
      const auto [flows, marked, total] = by_camera[c];
      if (total == 0) continue;
      report.flow_by_camera.push_back({int(c), flows, double(marked) / double(total)});
      unknown += marked, pixels += total;
    }
    std::stable_sort(report.flow_by_camera.begin(), report.flow_by_camera.end(),
                     [](const CameraFlowCheck& a, const CameraFlowCheck& b) {
                       return a.unknown_fraction > b.unknown_fraction;
                     });
    report.unknown_fraction = pixels ? double(unknown) / double(pixels) : 0.0;
  }
  report.flow_seconds = clock.lap();

  // Points, one frame at a time (the hull is parallel inside).
  if (!point_frames.empty()) {
    for (PointsSource source : sources)
      report.points_source +=
          (report.points_source.empty() ? "" : ",") + std::string(points_source_name(source));
    const std::size_t random_count =
        std::max(kMinRandomPointsPerFrame, options.random_points_total / views.clip_frames.size());
    auto build = [&](PointsSource source, std::size_t i) -> io::PointCloud {
      const int k = point_frames[i];
      switch (source) {
        case PointsSource::kHull:
          return visual_hull(scene, cameras, k, options.hull);
        case PointsSource::kRandom:
          return random_points(scene, cameras, k, random_count, options.seed);
        case PointsSource::kPly:
          return std::move(imported[i]);
        case PointsSource::kColmap:
          return colmap_points(scene, k, options.colmap);
        case PointsSource::kStereo:
          return stereo_points(scene, cameras, k, options.stereo);
      }
      fail("points: unknown source");
    };
    Progress progress("points", point_frames.size(), options.progress);
    for (std::size_t i = 0; i < point_frames.size(); ++i) {
      const int k = point_frames[i];
      io::PointCloud cloud;
      if (!default_points_used) {
        // Asked for: each source must build, a failure stops prepare.
        for (PointsSource source : sources) {
          try {
            append(cloud, build(source, i));
          } catch (const Error& e) {
            if (source != PointsSource::kColmap) throw;
            fail("{}. {}", e.what(), kOtherSources);
          }
        }
      } else {
        // The default: what builds stands; a frame where nothing builds stops prepare.
        std::vector<std::string> built, failed;
        auto attempt = [&](PointsSource source) {
          try {
            append(cloud, build(source, i));
            built.push_back(points_source_name(source));
          } catch (const Error& e) {
            failed.push_back(fmt::format("{}: {}", points_source_name(source), e.what()));
          }
        };
        for (PointsSource source : sources) attempt(source);
        if (!built.empty() && cloud.size() < kMinFramePoints)
          failed.push_back(fmt::format("{}: {} point{} in all", fmt::join(built, ","), cloud.size(),
                                       cloud.size() == 1 ? "" : "s"));
        for (std::size_t f = 0; f < fallbacks.size() && cloud.size() < kMinFramePoints; ++f)
          attempt(fallbacks[f]);
        if (cloud.size() < kMinFramePoints)
          fail(
              "too few points for frame {} ({}, at least {} needed): {}. The default points need "
              "one of: a mask for every "
              "training view (the hull; --masks estimates approximate ones), cameras that "
              "overlap more (COLMAP matches features seen by two cameras at {} degrees or more, "
              "three where the rig has {} or more; pair stereo where two cameras look within {} "
              "degrees of each other), or your own clouds (--points ply DIR); "
              "--points random trains without geometry (fog where the images have little "
              "texture)",
              k, cloud.size(), kMinFramePoints, fmt::join(failed, "; "), kTwoViewMinAngleDegrees,
              kTwoViewTrackCameras, kMaxStereoAxisAngle);
        if (!failed.empty())
          report.points_fallbacks.push_back({k, fmt::format("{}", fmt::join(built, ",")),
                                             fmt::format("{}", fmt::join(failed, "; "))});
      }
      io::write_points_ply(scene.points_path(k), cloud);
      report.points_written.emplace_back(k, cloud.size());
      progress.tick();
    }
  }
  report.points_seconds = clock.lap();

  // What the points cover, once every training frame has them: the warnings of a rig that cannot
  // give what is asked come before the training, not after it. In the masks eval scores in.
  if (std::all_of(frames.begin(), frames.end(),
                  [&](int k) { return fs::exists(scene.points_path(k)); })) {
    io::CoverageCounter coverage(scene);
    for (const std::size_t i : io::coverage_frames(frames.size())) {
      const int k = frames[i];
      std::vector<std::optional<Image>> masks;
      std::vector<const Image*> mask_views;
      for (std::size_t c = 0; c < scene.cameras.size(); ++c)
        masks.push_back(media::load_mask(scene, int(c), k));
      for (const std::optional<Image>& m : masks) mask_views.push_back(m ? &*m : nullptr);
      coverage.add(*io::load_points(scene, k), mask_views);
    }
    report.coverage = coverage.result();
  }
  return report;
}

}  // namespace retimegs::prepare
