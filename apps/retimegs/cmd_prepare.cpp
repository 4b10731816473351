// retimegs prepare --scene SCENE [--train-frames even|all] [--flow METHOD]
//                  [--flow-dir DIR] [--points hull|random|ply DIR|colmap|stereo] [--masks]
//                  [--window A:B] [--force] [--threads T]
#include <memory>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/escape_control_chars.hpp"
#include "retimegs/core/parallel.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/io/training_views.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/prepare/prepare.hpp"

namespace retimegs::app {

void add_prepare_command(CLI::App& app) {
  struct Args {
    std::string scene, frames = "even", flow = "dis", flow_dir, window;
    std::vector<std::string> points;
    int threads = 0;
    bool force = false, masks = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "prepare",
      "Fill in what training needs that a scene lacks: optical flow in both directions between "
      "consecutive training frames of every training camera, and per-frame point clouds. "
      "Existing files are kept unless --force, so a re-run resumes.");
  cmd->add_option("--scene", args->scene, "scene folder")->required();
  cmd->add_option("--train-frames", args->frames,
                  "the frames training will use: even (0, 2, 4, ...; flows of stride 2) or all "
                  "(flows of stride 1)")
      ->check(CLI::IsMember({"even", "all"}))
      ->capture_default_str();
  std::vector<std::string> method_names;
  for (const prepare::FlowMethod method : prepare::flow_methods())
    method_names.push_back(prepare::flow_method_name(method));
  CLI::Option* flow =
      cmd->add_option("--flow", args->flow,
                      "built-in estimator, one of " + prepare::flow_method_names() +
                          " (dis, the default: DIS at full resolution; bench/README.md compares "
                          "them); a forward-backward check marks occluded pixels unknown")
          ->check(CLI::IsMember(method_names))
          ->capture_default_str();
  cmd->add_option("--flow-dir", args->flow_dir,
                  "import .flo files (e.g. from WAFT, RAFT, SEA-RAFT) named "
                  "DIR/<camera>/<from:05d>_<to:05d>.flo instead of estimating")
      ->excludes(flow);
  cmd->add_option("--points", args->points,
                  "per-frame points: hull (visual hull of the masks), colmap (COLMAP "
                  "triangulation with the known poses), stereo (dense depth from camera pairs "
                  "with a usable baseline), random (last resort), ply DIR (import "
                  "DIR/<frame:05d>.ply); a comma list concatenates them. Default: what the rig "
                  "supports, said in the log: hull where every training view has a mask not "
                  "written by --masks, plus colmap (with two-view tracks on a rig of few "
                  "cameras); where one fails at a frame the other stands, and a frame where none "
                  "builds stops with what to bring; random stands in for colmap when COLMAP is "
                  "not installed")
      ->expected(1, 2)
      ->type_name("SOURCE [DIR]");
  CLI::Option* window =
      cmd->add_option("--window", args->window,
                      "A:B: only the flows and points of training frames A..B (as train "
                      "--window A:B reads them)");
  cmd->add_flag("--masks", args->masks,
                "write approximate foreground masks for a capture without them, from a MOG2 "
                "background model of each (static) camera's training frames; what stays put for "
                "most of them counts as background")
      ->excludes(window);
  cmd->add_option("--threads", args->threads, "worker threads (0 = all cores)")
      ->capture_default_str();
  cmd->add_flag("--force", args->force, "recompute and overwrite existing flow and point files");
  cmd->callback([args] {
    set_threads(args->threads);
    prepare::PrepareOptions options;
    options.frames = io::parse_frame_selection(args->frames, "--train-frames");
    options.flow_method = prepare::parse_flow_method(args->flow);
    options.flow_dir = args->flow_dir;
    options.force = args->force;
    if (args->masks) options.masks.emplace();
    if (!args->window.empty()) options.window = io::parse_frame_window(args->window, "--window");
    if (!args->points.empty()) {
      const std::string& kinds = args->points[0];
      bool needs_dir = false;
      for (const std::string& kind : split_list(kinds, "--points")) {
        if (kind == "ply") {
          options.points.push_back(prepare::PointsSource::kPly);
          needs_dir = true;
        } else if (kind == "hull") {
          options.points.push_back(prepare::PointsSource::kHull);
        } else if (kind == "random") {
          options.points.push_back(prepare::PointsSource::kRandom);
        } else if (kind == "colmap") {
          options.points.push_back(prepare::PointsSource::kColmap);
        } else if (kind == "stereo") {
          options.points.push_back(prepare::PointsSource::kStereo);
        } else {
          fail(
              "--points: unknown source '{}' (hull, random, ply DIR, colmap, stereo, or a comma "
              "list)",
              kind);
        }
      }
      if (needs_dir && args->points.size() != 2)
        fail("--points {}: ply needs a folder (--points ply DIR)", kinds);
      if (!needs_dir && args->points.size() == 2)
        fail("--points {}: takes no folder (got '{}')", kinds, args->points[1]);
      if (needs_dir) options.points_dir = args->points[1];
    }

    const io::Scene scene = media::read_scene(args->scene);
    const prepare::PrepareReport r = prepare::prepare_scene(scene, options);

    if (options.masks)
      spdlog::info(
          "masks (approximate): {} file{} written ({:.1f} % foreground), {} kept, {:.1f} s",
          r.masks_written, r.masks_written == 1 ? "" : "s", 100 * r.mask_coverage, r.masks_kept,
          r.masks_seconds);
    if (!r.points_plan.empty()) spdlog::info("points: {}", escape_control_chars(r.points_plan));
    if (!r.points_note.empty()) spdlog::warn("points: {}", escape_control_chars(r.points_note));
    for (const prepare::PrepareReport::PointsFallback& f : r.points_fallbacks)
      spdlog::warn("points: frame {}: {} ({})", f.frame, f.used, escape_control_chars(f.reason));
    const std::string how = options.flow_dir.empty()
                                ? fmt::format("estimated with {}", args->flow)
                                : fmt::format("imported from {}", args->flow_dir);
    spdlog::info("flow: {} file{} written ({}), {} kept, {:.1f} s", r.flows_written,
                 r.flows_written == 1 ? "" : "s", how, r.flows_kept, r.flow_seconds);
    if (r.flows_written && options.flow_dir.empty()) {
      spdlog::info("flow: {:.1f} % of pixels marked unknown by the forward-backward check",
                   100 * r.unknown_fraction);
      // The cameras to look at first: a camera far above the median has flows the estimator got
      // wrong, not just occlusions.
      const std::vector<prepare::CameraFlowCheck>& cams = r.flow_by_camera;
      std::string worst;
      for (std::size_t i = 0; i < std::min<std::size_t>(3, cams.size()); ++i)
        worst += fmt::format("{}{} {:.1f} %", i ? ", " : "",
                             escape_control_chars(scene.cameras[cams[i].camera].name),
                             100 * cams[i].unknown_fraction);
      if (cams.size() > 1)
        spdlog::info("flow: unknown by camera, most first: {} (median camera {:.1f} %)", worst,
                     100 * cams[cams.size() / 2].unknown_fraction);
    }
    if (!r.points_written.empty()) {
      std::string counts;
      for (const auto& [frame, n] : r.points_written)
        counts += fmt::format("{}{}: {}", counts.empty() ? "" : ", ", frame, n);
      spdlog::info("points ({}): {} frame{} written ({}), {} kept, {:.1f} s", r.points_source,
                   r.points_written.size(), r.points_written.size() == 1 ? "" : "s", counts,
                   r.points_kept, r.points_seconds);
    } else {
      spdlog::info("points: {} kept", r.points_kept);
    }
    if (r.coverage) {
      spdlog::info("{}", escape_control_chars(io::describe_coverage(scene, *r.coverage)));
      for (const std::string& line : io::coverage_warnings(scene, *r.coverage))
        spdlog::warn("{}", escape_control_chars(line));
    }
  });
}

}  // namespace retimegs::app
