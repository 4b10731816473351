// retimegs export --model MODEL (--time T --out SPLAT.ply | --times A:B:STEP --out DIR)
// retimegs export --model MODEL --web DIR [--scene SCENE] [--near D]
// retimegs export --model MODEL --scene SCENE --calibration rig|colmap --out PATH
#include <memory>
#include <optional>

#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "retimegs/core/atomic_file.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/escape_control_chars.hpp"
#include "retimegs/media/scene_images.hpp"
#include "retimegs/playback/export_calibration.hpp"
#include "retimegs/playback/export_times.hpp"
#include "retimegs/playback/render_model.hpp"
#include "retimegs/playback/times.hpp"
#include "retimegs/view/pack.hpp"
#include "retimegs/view/web.hpp"

namespace retimegs::app {

void add_export_command(CLI::App& app) {
  struct Args {
    std::string model, times, out, web, scene, calibration;
    std::optional<double> time, near;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Write the 3D Gaussians of a time as a standard 3DGS .ply (Inria layout) that SuperSplat and "
      "other splat viewers open; --times writes a sequence DIR/<k:05d>.ply with DIR/times.csv; "
      "--web DIR writes the browser viewer with the model as a static site; --calibration writes "
      "the scene's cameras as the model refined them, as a rig file or a COLMAP model.");
  cmd->add_option("--model", args->model, "4D model (.rgs)")
      ->required()
      ->check(input_file("a model"));
  auto* time = cmd->add_option("--time", args->time, "time in scene frame units");
  auto* times = cmd->add_option("--times", args->times, "times A:B:STEP (inclusive of B)");
  time->excludes(times);
  auto* out_option = cmd->add_option(
      "--out", args->out,
      "SPLAT.ply for --time, a folder for --times; RIG.json or a folder for --calibration");
  auto* web = cmd->add_option("--web", args->web,
                              "folder: the browser viewer (index.html, its scripts, model.json, "
                              "model.bin) for any static web host");
  web->excludes(time)->excludes(times)->excludes(out_option);
  auto* calibration = cmd->add_option(
      "--calibration", args->calibration,
      "rig | colmap: the scene's cameras, each training camera through the pose correction the "
      "model learned, as a rig file (JSON) or a COLMAP text model, which import videos --calib "
      "reads; needs --scene and --out");
  calibration->excludes(time)->excludes(times)->excludes(web);
  cmd->add_option("--scene", args->scene,
                  "--web: scene folder whose cameras, up vector and near plane the viewer uses; "
                  "--calibration: scene folder whose cameras are written");
  add_near_option(*cmd, args->near);
  cmd->add_flag("--force", args->force, "replace an existing output");
  cmd->callback([args] {
    if (!args->web.empty()) {
      std::vector<InputPath> inputs = {{args->model, "model"}};
      if (!args->scene.empty()) inputs.push_back({args->scene, "scene"});
      // Nor may it replace the scene's own files (scene.json, images, ...), even with --force.
      for (const InputPath& in : scene_inputs(args->scene)) inputs.push_back(in);
      check_output_overlap(args->web, "--web", inputs);
      const view::Packed packed = view::pack_for_web(args->model, args->scene, args->near);
      view::write_web(args->web, view::web_files(packed), args->force);
      spdlog::info("wrote the viewer to {} ({:.1f} MB of model data)", args->web,
                   packed.data.size() / 1e6);
      return;
    }
    if (!args->calibration.empty()) {
      const playback::CalibrationFormat format =
          playback::parse_calibration_format(args->calibration, "--calibration");
      if (args->scene.empty() || args->out.empty())
        fail("export: --calibration needs --scene SCENE and --out PATH");
      if (args->near) fail("export: --near goes with --web");
      std::vector<InputPath> inputs = {{args->model, "model"}, {args->scene, "scene"}};
      for (const InputPath& in : scene_inputs(args->scene)) inputs.push_back(in);
      check_output_overlap(args->out, "--out", inputs);
      const model::Model m = playback::read_4d_model(args->model);
      const io::Scene scene = media::read_scene(args->scene, media::SceneCheck::kJson);
      const playback::ExportedCalibration written =
          playback::export_calibration(m, scene, format, args->out, args->force);
      if (!written.unmatched.empty())
        spdlog::warn(
            "the model refined {} camera{} that the scene does not have (a model of another "
            "scene?), left out: {}",
            written.unmatched.size(), written.unmatched.size() == 1 ? "" : "s",
            escape_control_chars(fmt::format("{}", fmt::join(written.unmatched, ", "))));
      spdlog::info("wrote {} cameras to {} ({} through the model's pose corrections)",
                   written.cameras, args->out, written.corrected);
      return;
    }
    if (!args->scene.empty() || args->near)
      fail("export: --scene goes with --web or --calibration, --near with --web");
    if (!args->time && args->times.empty())
      fail("export: give --time, --times, --web or --calibration");
    if (args->out.empty()) fail("export: --time and --times need --out");
    check_output_overlap(args->out, "--out", {{args->model, "model"}});
    const model::Model m = playback::read_4d_model(args->model);
    if (args->time) {
      const std::size_t n = playback::export_time(m, *args->time, args->out, args->force);
      spdlog::info("exported {} Gaussians at t = {} to {}", n, *args->time, args->out);
      return;
    }
    const std::vector<double> listed =
        playback::range_times(parse_time_range(args->times, "--times"), "--times");
    playback::export_times(m, listed, args->out, args->force);
    spdlog::info("exported {} times to {}", listed.size(), args->out);
  });
}

}  // namespace retimegs::app
