// retimegs import FORMAT --in SRC --out SCENE [--frames A:B] [--downscale F]
// retimegs import videos --in DIR
//                        [--calib PATH | --calib-frames K --calib-frame N --camera-model M]
//                        [--test-cameras ...] [--offsets ... | --sync auto [--sync-max-lag N]]
//                        [--timestamps FILE]
#include <map>
#include <memory>
#include <optional>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/escape_control_chars.hpp"
#include "retimegs/core/input_file.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/ingest/import.hpp"

namespace retimegs::app {

namespace {

// The options every format has.
struct Args {
  std::string in, out, frames;
  double downscale = 1.0;
  int threads = 0;
  bool force = false;
};

void add_common_options(CLI::App* sub, Args& args, const std::string& in_help) {
  sub->add_option("--in", args.in, in_help)->required();
  sub->add_option("--out", args.out, "scene folder to write (must not exist unless --force)")
      ->required();
  sub->add_option("--frames", args.frames,
                  "inclusive frame range A:B of the source (default: all)");
  sub->add_option("--downscale", args.downscale, "divide the image size by F (intrinsics follow)")
      ->capture_default_str();
  sub->add_option("--threads", args.threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  sub->add_flag("--force", args.force, "replace an existing output folder");
}

// The source (and calibration) must not be replaced by the output: import --in D --out D --force
// would delete the source before reading it.
void check_import_output(const Args& args, const std::string& calib = {}) {
  std::vector<InputPath> inputs = {{args.in, "source", true}};
  if (!calib.empty()) {
    if (!std::filesystem::is_directory(calib)) check_input_file(calib, "a calibration");
    inputs.push_back({calib, "calibration", true});
  }
  check_output_overlap(args.out, "--out", inputs);
}

ingest::ImportOptions import_options(const Args& args) {
  set_threads(args.threads);
  ingest::ImportOptions options;
  if (!args.frames.empty())
    std::tie(options.first_frame, options.last_frame) = parse_range(args.frames, "--frames");
  options.downscale = args.downscale;
  options.force = args.force;
  return options;
}

void add_videos_command(CLI::App* cmd) {
  struct VideoArgs : Args {
    std::string calib, test_cameras, offsets, sync, timestamps;
    std::optional<int> sync_max_lag;
    std::optional<double> fps;
    std::optional<int> calib_frame;
    std::optional<int> calib_frames;
    std::optional<std::string> camera_model;
  };
  auto args = std::make_shared<VideoArgs>();
  CLI::App* sub = cmd->add_subcommand(
      "videos",
      "Your own capture: DIR/<camera>.mp4 (.mov, .mkv, .avi) or DIR/<camera>/ image folders, "
      "calibrated by a COLMAP model, an OpenCV-style rig file, or without either by COLMAP from "
      "synchronised frames of every camera (docs/cli.md).");
  add_common_options(sub, *args,
                     "folder of <camera>.mp4 / .mov / .mkv / .avi videos or <camera>/ folders of "
                     "PNG / JPEG images (sorted by name)");
  sub->add_option(
      "--calib", args->calib,
      "COLMAP sparse model folder (image stem = camera), or a rig file .yaml / .yml / "
      ".json (per camera K, dist, R, t world-to-camera); without it COLMAP recovers the "
      "calibration from the footage and writes it to SCENE/calibration");
  sub->add_option("--calib-frame", args->calib_frame,
                  "without --calib: the scene frame COLMAP calibrates from where nothing moves "
                  "(default: the middle one)");
  sub->add_option("--calib-frames", args->calib_frames,
                  "without --calib: frames per camera, spread over the footage, in which COLMAP "
                  "places the cameras by what moves (default 17; below 3: --calib-frame alone)");
  sub->add_option(
      "--camera-model", args->camera_model,
      fmt::format("without --calib: COLMAP's model for every camera, {} (default: "
                  "a lens as it comes, one radial distortion term) or {} (footage "
                  "undistorted already)",
                  ingest::kRecoveredCameraModels[0], ingest::kRecoveredCameraModels[1]));
  sub->add_option("--test-cameras", args->test_cameras,
                  "comma-separated cameras held out for evaluation (split test)");
  sub->add_option("--offsets", args->offsets,
                  "sync offsets CAM:X,... in frames: scene frame k of CAM is its source frame "
                  "k + X; a fraction is kept as CAM's time_offset (frames k + round(X), at time "
                  "k + round(X) - X)");
  sub->add_option("--sync", args->sync,
                  "auto: estimate every camera's --offsets from when things move in its footage "
                  "against the first camera's (scene.json clocks \"estimated\"; not with "
                  "--offsets or --timestamps)")
      ->check(CLI::IsMember({"auto"}));
  sub->add_option("--sync-max-lag", args->sync_max_lag,
                  "with --sync auto: the largest offset searched, in frames (default: a quarter "
                  "of the frames every camera has)");
  sub->add_option("--timestamps", args->timestamps,
                  "CSV of camera,frame,seconds per source frame, on one clock for all cameras: "
                  "the cameras' frame_times (docs/formats.md); --offsets whole frames only")
      ->check(input_file("a timestamps file"));
  sub->add_option("--fps", args->fps,
                  "frame rate (default: the videos', which must agree within 0.1 %; 30 for image "
                  "folders); overrides the videos'");
  sub->callback([args] {
    check_import_output(*args, args->calib);
    const ingest::ImportOptions options = import_options(*args);
    ingest::VideosOptions videos;
    videos.calibration = args->calib;
    if (!args->test_cameras.empty())
      videos.test_cameras = split_list(args->test_cameras, "--test-cameras");
    if (!args->offsets.empty()) videos.offsets = parse_camera_values(args->offsets, "--offsets");
    videos.sync_auto = args->sync == "auto";
    videos.sync_max_lag = args->sync_max_lag;
    videos.timestamps = args->timestamps;
    videos.fps = args->fps;
    videos.calibration_frame = args->calib_frame;
    videos.calibration_instants = args->calib_frames;
    videos.camera_model = args->camera_model;
    const ingest::VideosReport r = ingest::import_videos(args->in, args->out, options, videos);
    const std::string start =
        videos.offsets.empty() && r.first_frame == 0
            ? std::string()
            : fmt::format("; scene frame 0 is source frame {} (+ each camera's offset)",
                          r.first_frame);
    spdlog::info("import videos: {} camera{} ({} test) x {} frame{} at {:.6g} fps ({}){}",
                 r.cameras, r.cameras == 1 ? "" : "s", r.test_cameras, r.frames,
                 r.frames == 1 ? "" : "s", r.fps, r.fps_source, start);
    spdlog::info(
        "calibration: {}; {} camera{} undistorted to pinhole; no masks (prepare works without "
        "them)",
        r.calibration, r.undistorted, r.undistorted == 1 ? "" : "s");
    if (!r.sync.empty()) {
      std::string offsets;
      for (std::size_t c = 1; c < r.sync.size(); ++c)
        offsets += fmt::format("{}{}:{:.2f} (peak correlation {:.2f})", c > 1 ? ", " : "",
                               r.sync[c].name, r.sync[c].offset, r.sync[c].peak);
      spdlog::info("--sync auto: offsets in frames, searched within ±{}, against {}: {}",
                   r.sync_max_lag, escape_control_chars(r.sync.front().name),
                   escape_control_chars(offsets));
      for (const auto& cam : r.sync)
        if (!cam.weak.empty())
          spdlog::warn(
              "--sync auto: camera {}: {}; its offset {:.2f} may be wrong (measure it and "
              "give every camera's with --offsets)",
              escape_control_chars(cam.name), cam.weak, cam.offset);
    }
    if (r.recovered) {
      const std::size_t total = std::size_t(r.registered) + r.unregistered.size();
      spdlog::info(
          "COLMAP registered {} of {} cameras, {} points, mean reprojection error {:.2f} px; "
          "the cameras keep these poses and intrinsics over the whole clip",
          r.registered, total, r.points, r.reprojection_error);
      if (r.reconstructions > 1)
        spdlog::info(
            "{} reconstructions combined, each camera placed where the others agree most; they "
            "differ by up to {:.2f} % of the rig's extent (camera {})",
            r.reconstructions, 100 * r.spread, escape_control_chars(r.spread_camera));
      if (!r.unregistered.empty())
        spdlog::warn(
            "{} camera{} not registered, left out: {} (more texture in view, another "
            "--calib-frame, or a rig file with --calib)",
            r.unregistered.size(), r.unregistered.size() == 1 ? "" : "s",
            escape_control_chars(fmt::format("{}", fmt::join(r.unregistered, ", "))));
    }
    if (!r.without_footage.empty()) {
      constexpr std::size_t kListed = 10;
      const std::size_t n = r.without_footage.size();
      const std::vector<std::string> listed(r.without_footage.begin(),
                                            r.without_footage.begin() + std::min(n, kListed));
      spdlog::warn("{} calibrated camera{} without footage left out: {}{}", n, n == 1 ? "" : "s",
                   escape_control_chars(fmt::format("{}", fmt::join(listed, ", "))),
                   n > kListed ? fmt::format(" (+{} more)", n - kListed) : std::string());
    }
  });
}

}  // namespace

void add_import_command(CLI::App& app) {
  using Importer = void (*)(const std::filesystem::path&, const std::filesystem::path&,
                            const ingest::ImportOptions&);
  struct Format {
    const char* name;
    const char* description;
    Importer run;
  };
  static const Format kFormats[] = {
      {"panoptic",
       "CMU Panoptic in the Dynamic3DGaussians layout: train_meta.json / test_meta.json, ims/, "
       "seg/ (masks); the test_meta cameras become test cameras.",
       ingest::import_panoptic},
      {"n3dv",
       "Neural3DV / DyNeRF: poses_bounds.npy and cam00.mp4, cam01.mp4, ...; cam00 becomes the "
       "test camera.",
       ingest::import_n3dv},
      {"colmap",
       "A COLMAP sparse model (SRC, SRC/sparse/0 or SRC/sparse; .bin or .txt) with SRC/images: one "
       "static frame, undistorted to pinhole.",
       ingest::import_colmap},
      {"nerfstudio",
       "A nerfstudio transforms.json (SRC or the file itself), with optional per-frame time and "
       "camera.",
       ingest::import_nerfstudio},
  };
  CLI::App* cmd = app.add_subcommand(
      "import", "Convert a public dataset layout or your own capture into the scene format.");
  cmd->require_subcommand(1);
  for (const Format& format : kFormats) {
    auto args = std::make_shared<Args>();
    CLI::App* sub = cmd->add_subcommand(format.name, format.description);
    add_common_options(sub, *args, "source folder");
    sub->callback([args, run = format.run] {
      check_import_output(*args);
      run(args->in, args->out, import_options(*args));
    });
  }
  add_videos_command(cmd);
}

}  // namespace retimegs::app
